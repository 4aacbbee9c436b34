"""photonbench scaling: log-log slopes of pass times against a swept budget knob or the pixel count,
with their intervals, and the harness's share of each cell process, on small hand-made runs whose
costs follow known laws (a linear pass, a fixed cost, a quadratic one)."""

import csv
import json
import math
import os
import unittest

from common import TempRuns

from pbtools import scaling
from pbtools.rundata import Run


def write_run(path, resolution, cells):
    """cells: [(id, technique, {param: value}, {pass: ms}, stages_ms)]"""
    os.makedirs(os.path.join(path, "cells"), exist_ok=True)
    params = sorted({k for _, _, p, _, _ in cells for k in p})
    passes = sorted({k for _, _, _, t, _ in cells for k in t})
    header = (["cell", "scene", "technique", "status", "frames", "wall_ms_median", "seed",
               "harness_overhead_pct"] +
              [f"param.{k}" for k in params] + [f"pass.{k}.ms_median" for k in passes])
    with open(os.path.join(path, "summary.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        for cell, technique, p, t, stages in cells:
            w.writerow([cell, "box", technique, "ok", 4, sum(t.values()), 1, 1.25] +
                       [p.get(k, "") for k in params] + [t.get(k, "") for k in passes])
            d = os.path.join(path, "cells", cell)
            os.makedirs(d, exist_ok=True)
            with open(os.path.join(d, "cell.json"), "w") as g:
                json.dump({"cell": cell, "status": "ok", "stages_ms": stages}, g)
            with open(os.path.join(d, "frames.csv"), "w") as g:
                g.write("frame,pass,gpu_ms,cpu_ms\n")
                for frame in range(6):  # 2 warm-up frames and 4 measured, all played
                    g.write(f"{frame},frame,{sum(t.values())},0\n")
    with open(os.path.join(path, "run.json"), "w") as f:
        json.dump({"resolution": list(resolution), "git_commit": "x"}, f)
    return path


class FitTest(unittest.TestCase):
    def test_a_power_law_gives_its_exponent_with_an_interval_around_it(self):
        x = [1e4, 3e4, 1e5, 3e5, 1e6]
        noise = [1.02, 0.97, 1.01, 0.99, 1.03]
        fit = scaling.fit_loglog(x, [2e-3 * v ** 1.5 * e for v, e in zip(x, noise)])
        self.assertEqual(fit["n"], 5)
        self.assertAlmostEqual(fit["slope"], 1.5, delta=0.02)
        self.assertLess(fit["lo"], 1.5)
        self.assertGreater(fit["hi"], 1.5)
        self.assertLess(fit["hi"] - fit["lo"], 0.1)
        exact = scaling.fit_loglog(x, [7 * v for v in x])
        self.assertAlmostEqual(exact["slope"], 1.0, places=9)

    def test_a_fixed_cost_flattens_the_first_pair_not_the_last(self):
        x = [1e2, 1e3, 1e5, 1e6]
        fit = scaling.fit_loglog(x, [5 + 1e-3 * v for v in x])  # 5 ms of fixed cost
        self.assertLess(fit["slope_first"], 0.1)
        self.assertGreater(fit["slope_last"], 0.9)

    def test_two_points_give_no_interval_and_non_positive_values_are_dropped(self):
        fit = scaling.fit_loglog([1, 10, 100], [0, 1, 10])
        self.assertEqual(fit["n"], 2)
        self.assertAlmostEqual(fit["slope"], 1.0)
        self.assertTrue(math.isnan(fit["lo"]))


class SeriesTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = TempRuns()
        cells = []
        for i, photons in enumerate([1e4, 1e5, 1e6]):
            cells.append((f"box__tiled__{i}", "tiled", {"photons": int(photons), "radius": 0.1},
                          {"splat": 1e-3 * photons, "gbuffer": 2.0, "estimate": 1e-8 * photons ** 2},
                          {"plan": 20, "startup": 300, "setup": 30, "frames": 6 * 1e-3 * photons + 500,
                           "scoring": 100, "teardown": 50}))
        # One technique whose parameters differ in two ways at once: no series.
        cells.append(("box__direct__0", "direct", {"shadow_map_size": 256, "bias": 0.1},
                      {"direct-light": 1.0}, {}))
        cells.append(("box__direct__1", "direct", {"shadow_map_size": 1024, "bias": 0.2},
                      {"direct-light": 4.0}, {}))
        cls.knob = write_run(cls.tmp.path("knob"), (320, 180), cells)
        cls.resolutions = []
        for w, h in [(160, 90), (320, 180), (640, 360)]:
            pixels = w * h
            cls.resolutions.append(write_run(
                cls.tmp.path(f"res{w}"), (w, h),
                [("box__direct__0", "direct", {"shadow_map_size": 512},
                  {"gbuffer": 1e-4 * pixels, "shadow-maps": 3.0}, {})]))

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def row(self, table, technique, work, name):
        rows = table[(table["technique"] == technique) & (table["work"] == work) &
                     (table["pass"] == name)]
        self.assertEqual(len(rows), 1, f"{technique} {work} {name}")
        return rows.iloc[0]

    def test_a_swept_knob_gives_each_pass_its_own_slope(self):
        table = scaling.scaling_table([Run(self.knob)])
        self.assertAlmostEqual(self.row(table, "tiled", "photons", "splat")["slope"], 1.0, places=6)
        self.assertAlmostEqual(self.row(table, "tiled", "photons", "gbuffer")["slope"], 0.0, places=6)
        self.assertAlmostEqual(self.row(table, "tiled", "photons", "estimate")["slope"], 2.0,
                               places=6)
        frame = self.row(table, "tiled", "photons", "frame")
        self.assertGreater(frame["slope_last"], frame["slope_first"])
        self.assertEqual(frame["fixed"], "radius=0.1")
        self.assertFalse((table["technique"] == "direct").any())

    def test_runs_differing_in_resolution_form_a_pixel_series(self):
        table = scaling.scaling_table([Run(p) for p in self.resolutions])
        self.assertAlmostEqual(self.row(table, "direct", scaling.PIXELS, "gbuffer")["slope"], 1.0,
                               places=6)
        self.assertAlmostEqual(self.row(table, "direct", scaling.PIXELS, "shadow-maps")["slope"], 0.0,
                               places=6)
        self.assertEqual(self.row(table, "direct", scaling.PIXELS, "gbuffer")["n"], 3)

    def test_the_harness_share_is_what_the_frame_loop_leaves(self):
        table = scaling.harness_table([Run(self.knob)])
        row = table[table["cell"] == "box__tiled__0"].iloc[0]
        frames = 6 * 1e-3 * 1e4 + 500
        total = 20 + 300 + 30 + frames + 100 + 50
        self.assertAlmostEqual(row["total_ms"], total)
        self.assertAlmostEqual(row["frames_ms"], frames)
        self.assertAlmostEqual(row["outside_frames_share"], 1 - frames / total)
        self.assertAlmostEqual(row["in_frames_share"], 0.0125)

    def test_the_command_writes_its_tables_and_figures(self):
        out = self.tmp.path("out")
        self.assertEqual(scaling.main([self.knob, "--out", out]), 0)
        self.assertTrue(os.path.isfile(os.path.join(out, "scaling.csv")))
        self.assertTrue(os.path.isfile(os.path.join(out, "harness.csv")))
        self.assertTrue(any(f.endswith(".png") for f in os.listdir(out)))
        self.assertEqual(scaling.main([self.tmp.path("missing")]), 2)


if __name__ == "__main__":
    unittest.main()
