"""One name per clock: every frame-time figure the tools print says which clock and which statistic
it is (the report's wall-clock medians, compare's per-clock means of the fastest frames)."""

import unittest

from common import TempRuns

from pbtools import compare, tables


class ClockNamesTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = TempRuns()
        cls.base = cls.tmp.make("base", seed=1, images=False)
        cls.new = cls.tmp.make("new", seed=2, images=False, slow={"splat": 1.6})

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_compare_tables_name_the_clock_and_the_statistic(self):
        c = compare.compare(compare.RunSet(self.base), compare.RunSet(self.new))
        text = compare.markdown(c)
        header = next(line for line in text.splitlines() if line.startswith("| cell | pass |"))
        self.assertIn("| clock |", header)
        self.assertIn(f"base ms (mean of {compare.FLOOR_SAMPLES} fastest)", header)
        row = next(line for line in text.splitlines() if "`splat`" in line)
        self.assertRegex(row, r"\| (process CPU|GPU|CPU|max\(GPU, CPU\)) \|")

    def test_the_summary_names_its_times_wall_clock(self):
        headings = [h for _, h, *_ in tables.SUMMARY_COLUMNS if "ms" in h]
        self.assertEqual(headings, ["wall median ms", "wall p5 ms", "wall p95 ms"])


if __name__ == "__main__":
    unittest.main()
