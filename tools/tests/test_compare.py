"""compare: A/A runs flag nothing (10 of 10 seeds), a pass made 25% slower is flagged, a newly failing
cell and a worse image are regressions, and the statistics behave as documented."""

import io
import json
import math
import os
import shutil
import unittest
from contextlib import redirect_stdout

import numpy as np

from common import TempRuns

from pbtools import compare as C
from pbtools.rundata import Run


class CompareFixtureTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = TempRuns()
        cls.base = cls.tmp.make("base", seed=100, images=False)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_a_a_flags_nothing_in_10_of_10_seeds(self):
        for seed in range(10):
            new = self.tmp.make(f"aa{seed}", seed=seed, images=False)
            result = C.compare(Run(self.base), Run(new))
            flagged = [(r.label, r.pass_name, r.change_pct) for r in result.passes if r.verdict != "same"]
            self.assertEqual(flagged, [], f"seed {seed}")
            self.assertEqual(result.regressions, 0, f"seed {seed}")
            self.assertEqual(result.improvements, 0, f"seed {seed}")
            # Same build: every pass of every cell was tested (24 frames each side).
            self.assertGreater(len(result.passes), 100)
            with redirect_stdout(io.StringIO()):
                self.assertEqual(C.main([self.base, new]), 0)
            shutil.rmtree(new)

    def test_one_pass_25_percent_slower_is_flagged(self):
        for seed in (1, 2, 3):
            new = self.tmp.make(f"slow{seed}", seed=seed, images=False, slow={"splat": 1.25})
            result = C.compare(Run(self.base), Run(new))
            splat = [r for r in result.passes if r.pass_name == "splat"]
            self.assertEqual(len(splat), 12)  # tiled x3 and cluster x3 in two scenes
            self.assertTrue(all(r.verdict == "slower" for r in splat), [(r.label, r.change_pct, r.limit_pct)
                                                                        for r in splat])
            # Only the slowed pass (and frames that contain it) are blamed, not its siblings or children.
            blamed = {r.pass_name for r in result.passes if r.verdict == "slower"}
            self.assertLessEqual(blamed, {"splat", "frame"})
            out = io.StringIO()
            with redirect_stdout(out):
                self.assertEqual(C.main([self.base, new]), 1)
            text = out.getvalue()
            self.assertIn("**REGRESSION**", text)
            self.assertIn("### Slower", text)
            self.assertIn("| `splat` |", text)

    def test_faster_is_an_improvement_not_a_failure(self):
        new = self.tmp.make("fast", seed=4, images=False, slow={"gbuffer": 0.7})
        result = C.compare(Run(self.base), Run(new))
        gb = [r for r in result.passes if r.pass_name == "gbuffer"]
        self.assertTrue(all(r.verdict == "faster" for r in gb))
        self.assertEqual(result.regressions, 0)
        with redirect_stdout(io.StringIO()):
            self.assertEqual(C.main([self.base, new]), 0)

    def test_threshold_option(self):
        new = self.tmp.make("slow_thr", seed=5, images=False, slow={"splat": 1.25})
        with redirect_stdout(io.StringIO()):
            self.assertEqual(C.main([self.base, new, "--threshold", "60"]), 0)

    def test_newly_failing_cell_and_worse_metric_are_regressions(self):
        new = self.tmp.make("broken", seed=6, images=False)
        # Make an ok cell fail, and a metric worse in another.
        cell = "001-cornell-box-tiled-photons=50000-radius=0.05"
        path = os.path.join(new, "cells", cell, "cell.json")
        with open(path) as f:
            info = json.load(f)
        info.update(status="failed", reason="device lost", failed_frame=3)
        with open(path, "w") as f:
            json.dump(info, f)
        summary = os.path.join(new, "summary.csv")
        with open(summary) as f:
            text = f.read()
        text = text.replace(f"{cell},cornell-box,tiled,ok", f"{cell},cornell-box,tiled,failed")
        with open(summary, "w") as f:
            f.write(text)
        mpath = os.path.join(new, "cells", "000-cornell-box-direct", "metrics.csv")
        with open(mpath) as f:
            lines = f.read().splitlines()
        out = [lines[0]]
        for line in lines[1:]:
            fr, cls, flip, *rest = line.split(",")
            out.append(",".join([fr, cls, f"{float(flip) * 1.1:.6g}"] + rest))
        with open(mpath, "w") as f:
            f.write("\n".join(out) + "\n")
        result = C.compare(Run(self.base), Run(new))
        self.assertEqual([r.cell for r in result.statuses if r.verdict == "regression"], [cell])
        worse = [(r.cell, r.metric) for r in result.metrics if r.verdict == "worse"]
        self.assertEqual(worse, [("000-cornell-box-direct", "flip")])
        self.assertEqual(result.regressions, 2)
        with redirect_stdout(io.StringIO()):
            self.assertEqual(C.main([self.base, new]), 1)

    def test_bad_input_exits_2(self):
        import contextlib
        with contextlib.redirect_stderr(io.StringIO()):
            self.assertEqual(C.main([self.base, self.tmp.path("missing")]), 2)


class StatisticsTest(unittest.TestCase):
    def test_robust_noise_ignores_trend_and_spikes(self):
        rng = np.random.default_rng(1)
        noise = rng.normal(0, 1.0, 400)
        trend = np.linspace(0, 50, 400)  # the animation's slow change: not noise
        x = 100 + trend + noise
        x[::37] += 40  # spikes
        self.assertAlmostEqual(C.robust_noise(x), 1.0, delta=0.15)

    def test_shifted_samples(self):
        rng = np.random.default_rng(2)
        base = 10 * np.exp(rng.normal(0, 0.05, 32))
        same = 10 * np.exp(rng.normal(0, 0.05, 32))
        slow = 12.5 * np.exp(rng.normal(0, 0.05, 32))
        self.assertEqual(C.compare_samples(base, same, 10, 0.01, 2, 0.02)[-1], "same")
        mb, mn, ch, p, noise, limit, verdict = C.compare_samples(base, slow, 10, 0.01, 2, 0.02)
        self.assertEqual(verdict, "slower")
        self.assertLess(p, 1e-6)
        self.assertAlmostEqual(ch, 25, delta=5)
        # Too few frames to test: not a verdict either way.
        self.assertEqual(C.compare_samples(base[:4], slow[:4], 10, 0.01, 2, 0.02)[-1], "n/a")
        # A large change that is not significant (two wildly noisy samples) is not flagged.
        wild_a = 10 * np.exp(rng.normal(0, 1.0, 8))
        wild_b = 13 * np.exp(rng.normal(0, 1.0, 8))
        self.assertNotEqual(C.compare_samples(wild_a, wild_b, 10, 0.01, 2, 0.02)[-1], "slower")

    def test_error_change_of_metrics(self):
        self.assertAlmostEqual(C.error_change("flip", 0.1, 0.11), 10.0)
        self.assertAlmostEqual(C.error_change("ssim", 0.9, 0.89), 10.0)  # 1-SSIM 0.10 -> 0.11
        self.assertAlmostEqual(C.error_change("psnr", 30.0, 30.0 - 10 * math.log10(1.1)), 10.0)
        self.assertLess(C.error_change("psnr", 30.0, 31.0), 0)
        self.assertTrue(math.isnan(C.error_change("flip", math.nan, 0.1)))


if __name__ == "__main__":
    unittest.main()
