"""history: append keyed by commit and device, change points, and the plots."""

import csv
import io
import json
import os
import unittest
from contextlib import redirect_stdout

import numpy as np

from common import TempRuns

from pbtools import history as H


class ChangePointTest(unittest.TestCase):
    def test_step_is_found_where_it_is(self):
        rng = np.random.default_rng(3)
        for seed in range(20):
            x = 10 * np.exp(rng.normal(0, 0.03, 14))
            x[8:] *= 1.25
            self.assertEqual(H.change_points(x), [8], seed)

    def test_no_change_in_noise_and_single_outliers(self):
        rng = np.random.default_rng(4)
        false = 0
        for _ in range(200):
            x = 10 * np.exp(rng.normal(0, 0.03, 12))
            false += bool(H.change_points(x))
        self.assertLessEqual(false, 2)  # documented: ~0.1% of such series
        x = np.full(12, 10.0)
        x[5] = 20.0  # one slow run is an outlier, not a new level
        self.assertEqual(H.change_points(x), [])

    def test_two_steps_and_gaps(self):
        x = [10, 10.2, 9.9, 10.1, 13, 13.1, 12.9, 13.2, None, 9, 9.1, 8.9, 9.05]
        self.assertEqual(H.change_points(x), [4, 9])


class HistoryFileTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = TempRuns()
        cls.file = cls.tmp.path("history.jsonl")
        with redirect_stdout(io.StringIO()):
            for i in range(8):
                slow = {"splat": 1.3} if i >= 4 else {}
                run = cls.tmp.make(f"r{i}", seed=i, images=False, slow=slow, commit=f"{i:040x}",
                                   scenes=["pillars"], techniques=["direct", "tiled"])
                assert H.main(["append", run, "--file", cls.file]) == 0
            # A second device keeps its own series.
            other = cls.tmp.make("gpu", seed=9, images=False, commit=f"{7:040x}", device="NVIDIA H100",
                                 scenes=["pillars"], techniques=["direct", "tiled"])
            assert H.main(["append", other, "--file", cls.file]) == 0

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_entries_keyed_by_commit_and_device(self):
        entries = H.load(self.file)
        self.assertEqual(len(entries), 9)
        self.assertEqual([e["commit"] for e in entries[:8]], [f"{i:040x}" for i in range(8)])
        self.assertEqual(entries[8]["device"], "NVIDIA H100")
        # Appending the same commit and device again replaces the entry in place.
        rerun = self.tmp.make("rerun", seed=42, images=False, commit=f"{2:040x}", scenes=["pillars"], techniques=["direct", "tiled"])
        entry, replaced = H.append(rerun, self.file)
        self.assertTrue(replaced)
        entries = H.load(self.file)
        self.assertEqual(len(entries), 9)
        self.assertEqual(entries[2]["run"], "rerun")
        cell = entries[0]["cells"]["001-pillars-tiled-photons=50000-radius=0.05"]
        self.assertEqual(cell["status"], "ok")
        self.assertIn("splat/sort", cell["passes"])

    def test_plot_marks_the_injected_step(self):
        out = self.tmp.path("plots")
        with redirect_stdout(io.StringIO()):
            self.assertEqual(H.main(["plot", "--file", self.file, "--out", out]), 0)
        with open(os.path.join(out, "changepoints.csv"), newline="") as f:
            rows = list(csv.DictReader(f))
        splat = [r for r in rows if r["series"] == "splat" and r["device"] != "NVIDIA H100"]
        self.assertEqual(len(splat), 3)  # every cell with a splat pass: tiled at three photon counts
        self.assertEqual({r["index"] for r in splat}, {"4"})
        # Passes that did not change are not marked.
        self.assertFalse([r for r in rows if r["series"] in ("gbuffer", "shade", "tonemap", "trace")])
        for ext in ("svg", "pdf", "png"):
            self.assertTrue([n for n in os.listdir(out) if n.endswith("." + ext)])
        self.assertTrue(os.path.isfile(os.path.join(out, "index.html")))


if __name__ == "__main__":
    unittest.main()
