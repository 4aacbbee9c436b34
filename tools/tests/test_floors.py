"""Noise floors in the tools: the resolution rules (floors.py) on hand-worked values and, for the
comparison rule, against the truth on random images; then what the report, its tables and the claims
make of a fixture run whose pillars scene has an unresolved cell (fixture.FLIP_FLOOR)."""

import csv
import io
import math
import os
import re
import unittest
from contextlib import redirect_stdout

import numpy as np

from common import TempRuns

from pbtools import figures as F
from pbtools import floors, style, tables
from pbtools import report as R
from pbtools.claims import paper1
from pbtools.rundata import Run

# The fixture's pillars tiled cell with 200000 photons: FLIP ~0.12 over a floor of ~0.033 (3.7x).
UNRESOLVED_SETTING = "photons=200000"


class RulesTest(unittest.TestCase):
    def test_distances_put_every_metric_on_one_scale(self):
        self.assertEqual(floors.distance("flip", 0.2), 0.2)
        self.assertAlmostEqual(floors.distance("ssim", 0.9), 0.1)
        self.assertAlmostEqual(floors.distance("psnr", 20.0), 0.1)  # display RMS error 10^(-20/20)
        self.assertAlmostEqual(floors.distance("relmse", 0.04), 0.2)
        for m in floors.FLOOR_METRICS:
            self.assertAlmostEqual(floors.from_distance(m, floors.distance(m, 0.3 if m != "psnr" else 31.0)),
                                   0.3 if m != "psnr" else 31.0)
        self.assertTrue(math.isnan(floors.distance("flip", math.nan)))

    def test_a_score_is_resolved_from_four_times_its_floor(self):
        self.assertTrue(floors.resolved("flip", 0.12, 0.03))
        self.assertFalse(floors.resolved("flip", 0.1199, 0.03))
        # PSNR: 4x the display RMS error is 20 log10(4) = 12.04 dB below the floor's PSNR.
        self.assertTrue(floors.resolved("psnr", 40.0 - 12.05, 40.0))
        self.assertFalse(floors.resolved("psnr", 40.0 - 12.0, 40.0))
        # SSIM: 1 - SSIM at 4x.
        self.assertTrue(floors.resolved("ssim", 0.799, 0.95))
        self.assertFalse(floors.resolved("ssim", 0.801, 0.95))
        self.assertAlmostEqual(floors.unresolved_line("ssim", 0.95), 0.80)
        self.assertIsNone(floors.resolved("flip", 0.2, math.nan))
        self.assertAlmostEqual(floors.floor_ratio("relmse", 0.16, 0.01), 4.0)

    def test_comparison_needs_a_difference_beyond_both_floors_or_two_resolved_scores(self):
        # Worst case: 0.2 apart, floors 0.1 each.
        self.assertFalse(floors.comparison_resolved("rmse", 0.35, 0.1, 0.15, 0.1))
        self.assertTrue(floors.comparison_resolved("rmse", 0.36, 0.1, 0.15, 0.1))
        # Both at least 4x their (equal) floors: any difference holds; equal scores never do.
        self.assertTrue(floors.comparison_resolved("rmse", 0.41, 0.1, 0.40, 0.1))
        self.assertFalse(floors.comparison_resolved("rmse", 0.41, 0.1, 0.41, 0.1))
        # One of them within 4x: only the worst-case rule applies.
        self.assertFalse(floors.comparison_resolved("rmse", 0.41, 0.1, 0.39, 0.1))
        # Unequal floors: the quadrature-corrected distances decide (sqrt(0.5^2 - 0.1^2) = 0.490 is
        # below sqrt(0.51^2 - 0.01^2) = 0.510, as 0.5 is below 0.51).
        self.assertTrue(floors.comparison_resolved("rmse", 0.50, 0.1, 0.51, 0.01))
        self.assertIsNone(floors.comparison_resolved("rmse", 0.51, math.nan, 0.3, 0.1))

    def test_the_worst_case_rule_keeps_the_order_against_the_truth(self):
        """RMSE against a noisy reference R = T + e, for techniques A = T + x and B = T + y whose errors
        are of the reference noise's size: whenever the worst-case rule holds, the order of rmse(R, A)
        and rmse(R, B) is the order against the truth. A rule half as strict is wrong some of the time
        (this is what lets the test fail)."""
        rng = np.random.default_rng(3)

        def rms(v):
            return float(np.sqrt(np.mean(v ** 2)))

        resolved = wrong = loose_wrong = 0
        for _ in range(3000):
            n = 16
            e = rng.normal(0, 1, n)
            x, y = rng.normal(0, rng.uniform(0.2, 3), n), rng.normal(0, rng.uniform(0.2, 3), n)
            # The floor is the rms of the reference's own error, d(R, T).
            a, b, f = rms(x - e), rms(y - e), rms(e)
            truth_order = rms(x) < rms(y)
            if floors.order_holds_in_worst_case("rmse", a, f, b, f):
                resolved += 1
                wrong += (a < b) != truth_order
            if abs(a - b) > f:  # half the rule: one floor
                loose_wrong += (a < b) != truth_order
        self.assertGreater(resolved, 100)
        self.assertEqual(wrong, 0)
        self.assertGreater(loose_wrong, 0)


    def test_two_resolved_scores_keep_their_order_against_the_truth(self):
        """Many pixels, techniques whose errors are 4 to 8 times the reference noise: when both are
        resolved, the order against the reference is the order against the truth whenever the true
        distances differ by more than 1% (closer than that, the cross term of error and noise, about
        1/sqrt(pixels) of the error, can swap them)."""
        rng = np.random.default_rng(4)
        n, checked, wrong = 4096, 0, 0
        for _ in range(300):
            e = rng.normal(0, 1, n)
            x, y = rng.normal(0, rng.uniform(4, 8), n), rng.normal(0, rng.uniform(4, 8), n)
            f = float(np.sqrt(np.mean(e ** 2)))
            a, b = float(np.sqrt(np.mean((x - e) ** 2))), float(np.sqrt(np.mean((y - e) ** 2)))
            tx, ty = float(np.sqrt(np.mean(x ** 2))), float(np.sqrt(np.mean(y ** 2)))
            if floors.comparison_resolved("rmse", a, f, b, f) and abs(tx - ty) > 0.01 * tx:
                checked += 1
                wrong += (a < b) != (tx < ty)
        self.assertGreater(checked, 250)
        self.assertEqual(wrong, 0)


class FixtureFloorsTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = TempRuns()
        cls.run_dir = cls.tmp.make("run", seed=5, bounce_matched=True)
        cls.rd = Run(cls.run_dir)
        cls.styles = style.TechniqueStyle(cls.rd.techniques())
        with redirect_stdout(io.StringIO()):
            R.main([cls.run_dir])
        with open(os.path.join(cls.run_dir, "report", "index.html"), encoding="utf-8") as f:
            cls.html = f.read()
        cls.loose = [c for c in cls.rd.cells_of("pillars")
                     if c.technique == "tiled" and c.params.get("photons") == 200000][0]

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_the_fixture_has_the_cell_it_is_meant_to(self):
        ratio = floors.floor_ratio("flip", self.loose.value("flip_mean"), self.loose.value("flip_floor"))
        self.assertLess(ratio, floors.RESOLVE_FACTOR)
        self.assertGreater(ratio, 3.0)

    def test_quality_figure_draws_the_floor_and_hollows_unresolved_points(self):
        fig = F.quality_vs_time(self.rd, "pillars", self.styles)
        artists = {a.get_gid(): a for ax in fig.fig.axes for a in list(ax.lines) + list(ax.patches)}
        ok = [c for c in self.rd.cells_of("pillars") if c.ok]
        for m in ("flip", "ssim", "psnr"):
            floor = float(np.median([c.value(f"{m}_floor") for c in ok]))
            line = artists[f"floor:{m}"]
            self.assertAlmostEqual(float(line.get_ydata()[0]), floor, places=9)
            self.assertIn(f"unresolved-band:{m}", artists)
            hollow = artists[f"unresolved:tiled:{m}"]
            self.assertEqual([tuple(p) for p in hollow.get_xydata()],
                             [(self.loose.value("wall_ms_median"), self.loose.value(f"{m}_mean"))])
        self.assertNotIn("unresolved:cluster:flip", artists)
        col = fig.header.index("resolved_flip")
        flags = {r[0]: r[col] for r in fig.rows}
        self.assertEqual(flags[self.loose.id], 0)
        self.assertEqual(sum(v == 0 for v in flags.values()), 1)
        self.assertIn("noise floor", fig.caption)
        style.close(fig.fig)
        # cornell-box's floor is low: nothing hollow.
        fig = F.quality_vs_time(self.rd, "cornell-box", self.styles)
        self.assertFalse([a for ax in fig.fig.axes for a in ax.lines
                          if (a.get_gid() or "").startswith("unresolved:")])
        style.close(fig.fig)

    def test_tables_mark_the_unresolved_cell(self):
        rows = tables.summary_rows(self.rd)
        marked = [r["cell"] for r in rows if r["resolved_flip"] is False]
        self.assertEqual(marked, [self.loose.id])
        with open(os.path.join(self.run_dir, "report", "tables", "summary.csv"), newline="") as f:
            csv_rows = {r["cell"]: r for r in csv.DictReader(f)}
        self.assertEqual(csv_rows[self.loose.id]["resolved_flip"], "0")
        self.assertEqual(csv_rows[self.loose.id]["flip_floor"], f"{self.loose.value('flip_floor'):.6g}")
        with open(os.path.join(self.run_dir, "report", "tables", "summary.tex"), encoding="utf-8") as f:
            tex = f.read()
        daggers = [line for line in tex.splitlines() if r"$^\dagger$" in line and line.endswith(r"\\")]
        self.assertEqual(len(daggers), 1)
        self.assertIn("photons=200000", daggers[0].replace(r"\_", "_").replace(" ", ""))
        self.assertEqual(daggers[0].count(r"$^\dagger$"), 3)  # FLIP, SSIM and PSNR
        unresolved_tds = re.findall(r'<td class="num unresolved"[^>]*>([^<]*)', self.html)
        self.assertGreaterEqual(len(unresolved_tds), 3)

    def test_floor_section_names_the_unresolved_cells(self):
        section = self.html.split('id="floors"', 1)[1].split("<h2", 1)[0]
        listed = section.split('<table class="unresolved-flip">', 1)[1].split("</table>", 1)[0]
        rows = re.findall(r"<tr><td>(.*?)</td><td>(.*?)</td><td>(.*?)</td><td>(.*?)</td>", listed)
        # Against the full reference, the unresolved cell's two classes (the fixture scales a class's
        # score and floor alike) and no other; against the bounce-matched one (scores 20% lower) more
        # pillars cells fall within 4x, and no cornell-box cell.
        full = sorted(r for r in rows if r[2] == "full")
        self.assertEqual(full, [("pillars", "tiled (photons=200000)", "full", cls)
                                for cls in ("caustics", "combined")])
        self.assertTrue(all(r[0] == "pillars" for r in rows))
        with open(os.path.join(self.run_dir, "report", "tables", "floors.csv"), newline="") as f:
            floor_csv = list(csv.DictReader(f))
        loose = {(r["cell"], r["reference"], r["path_class"], r["metric"]) for r in floor_csv
                 if r["resolved"] == "0"}
        self.assertIn((self.loose.id, "full", "combined", "flip"), loose)
        self.assertIn((self.loose.id, "full", "combined", "relmse"), loose)
        for r in floor_csv:
            self.assertAlmostEqual(float(r["floor_ratio"]) / floors.floor_ratio(
                r["metric"], float(r["mean"]), float(r["floor"])), 1.0, places=4)

    def test_each_unresolved_flip_score_says_why_and_what_reference_would_resolve_it(self):
        section = self.html.split('id="floors"', 1)[1].split("<h2", 1)[0]
        listed = section.split('<table class="unresolved-flip">', 1)[1].split("</table>", 1)[0]
        rows = re.findall(r"<tr><td>(.*?)</td><td>.*?</td><td>(.*?)</td><td>(.*?)</td>"
                          r"<td[^>]*>.*?</td><td[^>]*>.*?</td><td[^>]*>(.*?)x</td><td>(.*?)</td></tr>",
                          listed)
        self.assertTrue(rows)
        for scene, reference, cls, ratio, why in rows:
            # pillars' references stopped at their 60 s limit at 14% (fixture.REFERENCE_STOP).
            self.assertIn("reference at 14% after 60 s a frame (stopped by its time limit)", why)
            needed = re.search(r"about ([0-9.]+)% would resolve it, about ([0-9.]+)x its time", why)
            self.assertIsNotNone(needed, why)
            # Quadrature: t = f sqrt(r^2 - 1) stays, the floor must fall to t / sqrt(15); the ratio
            # is printed to 2 decimals, the figures to 3 significant digits.
            shrink = math.sqrt(float(ratio) ** 2 - 1) / math.sqrt(15)
            self.assertAlmostEqual(float(needed.group(1)), 14 * shrink, delta=0.1)
            self.assertAlmostEqual(float(needed.group(2)), 1 / shrink ** 2, delta=0.02)

    def test_finer_reference_follows_the_floor_and_the_time(self):
        # A score at 2x its floor with a 10% reference: t = f sqrt(3), the floor must fall to
        # t / sqrt(15) = 0.4472 f, so 4.47% and (1 / 0.4472)^2 = 5x the time.
        text = floors.finer_reference(2.0, 0.1, 2.0, "rel_error")
        self.assertIn("reference at 10% after 2 s a frame (stopped by its error target)", text)
        self.assertIn("about 4.47% would resolve it, about 5x its time (10 s a frame)", text)
        # At 4x the floor (not unresolved) nothing changes: 1x.
        self.assertIn("about 10% would resolve it, about 1x", floors.finer_reference(4.0, 0.1, 2.0, "rel_error"))
        # Within the floor, the technique's own error is unknown.
        self.assertIn("within its floor", floors.finer_reference(0.9, 0.1, 2.0, "max_seconds"))

    def test_claims_report_table2_against_both_references_with_floors(self):
        text = paper1.claims(self.rd)
        self.assertIn("against the full reference", text)
        self.assertIn("against the bounce-matched reference", text)
        full = text.split("against the full reference", 1)[1].split("against the bounce-matched", 1)[0]
        row = [line for line in full.splitlines()
               if line.startswith("| pillars | 200000 paths") and "ind." in line]
        self.assertEqual(len(row), 1, full)
        self.assertIn("†", row[0])
        self.assertIn("Combined FLIP within 4× its floor: 1 of", full)


if __name__ == "__main__":
    unittest.main()
