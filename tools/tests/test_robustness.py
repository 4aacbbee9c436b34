"""The robustness matrix (robustness.py) from a hand-written stability.csv: the worst class of each
square, what fits in it, the figure's numbers, the rows the page lists, and a class it does not know."""

import csv
import os
import tempfile
import unittest

import common  # noqa: F401  (the import paths)
from pbtools import robustness, style

HEADER = ["scenario", "technique", "class", "reason", "flip", "flip_floor", "baseline_flip", "ratio",
          "cell", "baseline_cell", "aims_at"]
ROWS = [
    ["baseline", "tiled", "ok", "FLIP 0.2", "0.2", "0.03", "", "", "room__tiled__1", "", "ref"],
    ["one-photon", "tiled", "degraded", "FLIP 0.48 = 2.40x the baseline's 0.2 (bound 2x)", "0.48",
     "0.03", "0.2", "2.4", "room__tiled__2", "room__tiled__1", "Paper I limitation 4"],
    # Two cells of one square (a swept parameter): the failed one is shown.
    ["tiny", "tiled", "ok", "FLIP 0.2", "0.2", "0.03", "0.2", "1", "room__tiled__3", "", "x"],
    ["tiny", "tiled", "failed", "warning at frame 0: tiled: per-tile photon lists overflowed: "
     "7314 entries wanted", "0.45", "0.03", "0.2", "", "room__tiled__4", "", "Paper I §5.2"],
    ["tiny", "aaps", "skipped", "technique not built", "", "", "", "", "", "", "x"],
]


class RobustnessTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp()
        self.write(ROWS)

    def write(self, rows):
        with open(os.path.join(self.dir, "stability.csv"), "w", newline="") as f:
            csv.writer(f).writerows([HEADER] + rows)

    def test_each_square_shows_its_worst_class(self):
        scenarios, techniques, worst = robustness.worst_cells(robustness.read(self.dir))
        self.assertEqual(scenarios, ["baseline", "one-photon", "tiny"])
        self.assertEqual(techniques, ["tiled", "aaps"])
        self.assertEqual(worst[("tiny", "tiled")]["cell"], "room__tiled__4")
        self.assertEqual(worst[("one-photon", "tiled")]["class"], "degraded")
        self.assertNotIn(("baseline", "aaps"), worst)

    def test_a_square_holds_the_ratio_or_two_lines_of_the_reason(self):
        _, _, worst = robustness.worst_cells(robustness.read(self.dir))
        self.assertEqual(robustness.short_reason(worst[("one-photon", "tiled")]), "2.40x baseline")
        failed = robustness.short_reason(worst[("tiny", "tiled")]).split("\n")
        self.assertEqual(len(failed), 2)
        self.assertTrue(failed[1].endswith("\u2026"))
        self.assertLessEqual(max(len(line) for line in failed), 22)

    def test_the_figure_keeps_every_row_and_counts_the_classes(self):
        fig = robustness.matrix_figure(self.dir)
        style.close(fig.fig)
        self.assertEqual(len(fig.rows), len(ROWS))
        self.assertIn("1 failed, 1 degraded, 0 unrated, 2 ok, 1 skipped", fig.caption)
        self.assertEqual([p["class"] for p in robustness.problem_rows(self.dir)],
                         ["degraded", "failed"])

    def test_no_stability_csv_no_matrix(self):
        os.remove(os.path.join(self.dir, "stability.csv"))
        self.assertIsNone(robustness.matrix_figure(self.dir))
        self.assertEqual(robustness.problem_rows(self.dir), [])

    def test_an_unknown_class_is_an_error_naming_it(self):
        self.write([ROWS[0][:2] + ["broken"] + ROWS[0][3:]])
        with self.assertRaisesRegex(ValueError, "unknown class 'broken'"):
            robustness.read(self.dir)


if __name__ == "__main__":
    unittest.main()
