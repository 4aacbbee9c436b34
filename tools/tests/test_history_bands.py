"""history's noise bands: an entry of replicate runs carries the p5-p95 of the runs' medians, an entry
of one run the p5-p95 of its frames; the plot shades them and rings a median outside the previous
entry's band, which a slowed pass is and an unchanged one is not."""

import csv
import io
import os
import unittest
from contextlib import redirect_stdout

import numpy as np

from common import TempRuns

from pbtools import history as H
from pbtools.rundata import Run

KW = dict(images=False, scenes=["pillars"], techniques=["direct", "tiled"],
          settings={"tiled": [{"photons": 50000, "radius": 0.05}]})


class HistoryBandsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = TempRuns()

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_replicates_pool_into_one_entry_with_the_runs_spread(self):
        commit = f"{1:040x}"
        dirs = [self.tmp.make(f"rep{i}", seed=i, commit=commit, **KW) for i in range(4)]
        path = self.tmp.path("replicates.jsonl")
        with redirect_stdout(io.StringIO()):
            self.assertEqual(H.main(["append", *dirs, "--file", path]), 0)
        (entry,) = H.load(path)
        self.assertEqual(entry["runs"], [os.path.basename(d) for d in dirs])
        runs = [Run(d) for d in dirs]
        for cell_id, cell in entry["cells"].items():
            medians = [r.cell(cell_id).value("wall_ms_median") for r in runs]
            self.assertEqual(cell["band"], "runs")
            self.assertEqual(cell["replicates"], 4)
            self.assertAlmostEqual(cell["wall_ms_median"], float(np.median(medians)))
            self.assertAlmostEqual(cell["wall_ms_band"][0], float(np.percentile(medians, 5)))
            self.assertAlmostEqual(cell["wall_ms_band"][1], float(np.percentile(medians, 95)))
            gbuffer = [r.cell(cell_id).pass_medians()["gbuffer"] for r in runs]
            self.assertAlmostEqual(cell["passes_band"]["gbuffer"][1], float(np.percentile(gbuffer, 95)))

    def test_replicates_of_another_build_are_refused(self):
        a = self.tmp.make("a", seed=1, commit=f"{1:040x}", **KW)
        b = self.tmp.make("b", seed=2, commit=f"{2:040x}", **KW)
        with self.assertRaisesRegex(Exception, "its commit"):
            H.append([a, b], self.tmp.path("mixed.jsonl"))

    def test_one_run_has_its_frames_spread_and_a_slowed_pass_leaves_the_band(self):
        path = self.tmp.path("history.jsonl")
        for i in range(5):
            run = self.tmp.make(f"c{i}", seed=10 + i, commit=f"{i + 10:040x}",
                                slow={"splat": 1.6} if i >= 3 else None, **KW)
            with redirect_stdout(io.StringIO()):
                self.assertEqual(H.main(["append", run, "--file", path]), 0)
        entries = H.load(path)
        run = Run(self.tmp.path("c0"))
        cell_id = next(c.id for c in run.cells if c.technique == "tiled")
        first = entries[0]["cells"][cell_id]
        self.assertEqual(first["band"], "frames")
        _, splat = run.cell(cell_id).pass_samples("splat")
        self.assertAlmostEqual(first["passes_band"]["splat"][0], float(np.percentile(splat, 5)))

        out = self.tmp.path("plots")
        with redirect_stdout(io.StringIO()):
            self.assertEqual(H.main(["plot", "--file", path, "--out", out]), 0)
        with open(os.path.join(out, "bands.csv"), newline="") as f:
            rows = [r for r in csv.DictReader(f) if r["cell"] == cell_id]
        outside = {(r["series"], int(r["index"])) for r in rows if r["outside_previous"] == "1"}
        self.assertIn(("splat", 3), outside)
        self.assertNotIn(("splat", 4), outside)  # the new level, inside its own previous band
        self.assertFalse([s for s in outside if s[0] == "gbuffer"])
        band_rows = [r for r in rows if r["series"] == "splat"]
        self.assertTrue(all(float(r["band_lo_ms"]) <= float(r["band_hi_ms"]) for r in band_rows))
        name = [n for n in os.listdir(out) if n.endswith(".svg") and "tiled" in n][0]
        with open(os.path.join(out, name), encoding="utf-8") as f:
            svg = f.read()
        self.assertIn('id="band:splat', svg)
        self.assertIn('id="outside:splat', svg)


if __name__ == "__main__":
    unittest.main()
