"""measures.py, the one home of the metric directions and the noise formulas: its values on
hand-worked cases, and the tools that used to repeat them (compare, history, export, floors, tables,
figures, claims) now answering with it."""

import glob
import math
import os
import re
import tokenize
import unittest

import numpy as np

import common  # noqa: F401  (import paths for pbtools)
from pbtools import compare, export, figures, floors, history, measures, tables
from pbtools.claims import paper1


class DirectionsTest(unittest.TestCase):
    def test_errors_are_lower_is_better_similarities_higher(self):
        self.assertEqual({m: measures.lower_is_better(m) for m in measures.METRICS},
                         {"flip": True, "ssim": False, "psnr": False, "rmse": True, "relmse": True})
        with self.assertRaises(ValueError):
            measures.lower_is_better("psnr_mean")

    def test_tables_and_export_take_their_direction_from_it(self):
        ranked = {key: lower for key, _, _, _, lower in tables.SUMMARY_COLUMNS
                  if key.endswith("_mean")}
        self.assertEqual(ranked, {f"{m}_mean": measures.lower_is_better(m)
                                  for m in ("flip", "ssim", "psnr")})
        # The LaTeX heading's arrow points to better values.
        self.assertEqual(measures.latex_heading("flip"), r"\textsc{Flip}~$\downarrow$")
        self.assertEqual(measures.latex_heading("psnr"), r"PSNR [dB]~$\uparrow$")
        self.assertEqual([m for m in export.EXPORTED_METRICS if measures.lower_is_better(m)],
                         ["flip", "relmse"])

    def test_no_tool_keeps_its_own_copy(self):
        """The formulas and tables live in measures.py only: no other module's code (strings and
        comments aside) spells the MAD constant, a MAD, a metric-direction table or the PSNR/SSIM
        error transforms again."""
        pbtools = os.path.dirname(measures.__file__)
        patterns = [r"1\.4826", r"LOWER_IS_BETTER =", r"10\.0 \*\* \(",
                    r"1\.0 - (base|value|new)\b", r"median \( np \. abs \("]
        for path in glob.glob(os.path.join(pbtools, "**", "*.py"), recursive=True):
            if os.path.basename(path) == "measures.py":
                continue
            text = (tokenize.STRING, tokenize.COMMENT, tokenize.ENCODING)
            with open(path, "rb") as f:
                tokens = tokenize.tokenize(f.readline)
                code = " ".join(t.string for t in tokens if t.type not in text)
            for pattern in patterns:
                self.assertIsNone(re.search(pattern, code), f"{path}: {pattern}")


class DistanceAndErrorTest(unittest.TestCase):
    def test_distances_invert(self):
        for m, v in (("flip", 0.2), ("ssim", 0.9), ("psnr", 31.0), ("rmse", 0.05),
                     ("relmse", 0.04)):
            self.assertAlmostEqual(measures.from_distance(m, measures.distance(m, v)), v)
        self.assertAlmostEqual(measures.distance("psnr", 40.0), 0.01)
        self.assertTrue(math.isnan(measures.distance("ssim", math.nan)))
        self.assertIs(floors.distance, measures.distance)

    def test_error_change_is_of_the_error_behind_the_metric(self):
        # PSNR: a drop of 10 log10(1.1) dB is 10% more MSE; SSIM: 1 - SSIM 0.10 -> 0.12 is +20%.
        drop = 10 * math.log10(1.1)
        self.assertAlmostEqual(measures.error_change("psnr", 30.0, 30.0 - drop), 10.0)
        self.assertAlmostEqual(measures.error_change("ssim", 0.90, 0.88), 20.0)
        self.assertAlmostEqual(measures.error_change("relmse", 0.02, 0.01), -50.0)
        self.assertEqual(measures.error_change("flip", 0.0, 0.0), 0.0)
        self.assertEqual(measures.error_change("flip", 0.0, 0.1), math.inf)
        self.assertEqual(compare.error_change("psnr", 30.0, 29.0),
                         measures.error_change("psnr", 30.0, 29.0))


class NoiseTest(unittest.TestCase):
    def test_successive_difference_sigma_by_hand(self):
        x = np.array([10.0, 12.0, 11.0, 15.0, 14.0, 14.5])
        d = np.diff(x)  # 2, -1, 4, -1, 0.5: median 0.5, |d - 0.5| = 1.5, 1.5, 3.5, 1.5, 0: MAD 1.5
        self.assertEqual(float(np.median(np.abs(d - np.median(d)))), 1.5)
        # 1 / Phi^-1(3/4) is the normal distribution's MAD scale.
        expected = 1.5 / (math.sqrt(2) * 0.6744897501960817)
        self.assertAlmostEqual(measures.successive_difference_sigma(x), expected, places=12)
        self.assertTrue(math.isnan(measures.successive_difference_sigma([1.0, 2.0])))

    def test_it_measures_the_noise_not_the_trend(self):
        rng = np.random.default_rng(7)
        x = np.linspace(0, 100, 2000) + rng.normal(0, 2.0, 2000)
        self.assertAlmostEqual(measures.successive_difference_sigma(x), 2.0, delta=0.1)

    def test_compare_and_history_use_it(self):
        x = 10 * np.exp(np.random.default_rng(8).normal(0, 0.05, 40))
        self.assertEqual(compare.robust_noise(x), measures.successive_difference_sigma(x))
        self.assertEqual(history._noise(np.log(x)), measures.successive_difference_sigma(np.log(x)))
        # Too short for a change to be tested: no noise.
        self.assertEqual(history._noise(np.array([1.0, 2.0])), 0.0)

    def test_percentile_range_is_the_harness_rule(self):
        # harness/src/cell/stats.cpp: rank p/100 (n - 1), linear between the order statistics.
        np.testing.assert_allclose(measures.percentile_range([4.0, 1.0, 3.0, 2.0]), (1.15, 3.85))
        self.assertTrue(all(math.isnan(v) for v in measures.percentile_range([])))

    def test_coefficient_of_variation(self):
        self.assertAlmostEqual(measures.coefficient_of_variation([1.0, 3.0]), 0.5)  # s.d. 1, mean 2
        self.assertTrue(math.isnan(measures.coefficient_of_variation([5.0])))
        self.assertTrue(math.isnan(measures.coefficient_of_variation([0.0, 0.0])))


class UsersTest(unittest.TestCase):
    def test_every_tool_imports_it(self):
        for module in (compare, history, export, tables, figures, paper1):
            self.assertIs(getattr(module, "measures", None), measures, module.__name__)
        self.assertEqual(floors.FLOOR_METRICS, tuple(measures.METRICS))


if __name__ == "__main__":
    unittest.main()
