"""One name per clock: every frame-time figure the tools print says which clock and which statistic
it is (the report's wall-clock medians, compare's per-clock means of the fastest frames, the run's
CSV columns wall_ms_median/p5/p95), and a run written under the old column names (frame_ms_*) still
reads."""

import csv
import json
import os
import unittest

from common import TempRuns

from pbtools import compare, history, matching, tables
from pbtools.rundata import RENAMED_COLUMNS, Run


def rename_header(path, names):
    """Rewrites a CSV file's header with `names` (old -> new) applied, rows untouched."""
    with open(path, newline="", encoding="utf-8") as f:
        rows = list(csv.reader(f))
    rows[0] = [names.get(c, c) for c in rows[0]]
    with open(path, "w", newline="", encoding="utf-8") as f:
        csv.writer(f).writerows(rows)


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


class OldColumnNamesTest(unittest.TestCase):
    """A run from before the rename (summary.csv's frame_ms_median, p5, p95; match.csv's frame_ms_n
    and probe_frame_ms; history entries keyed frame_ms_median) reads as a current one."""

    OLD = {new: old for old, new in RENAMED_COLUMNS.items()}

    @classmethod
    def setUpClass(cls):
        cls.tmp = TempRuns()
        cls.new = cls.tmp.make("new", seed=1, images=False)
        cls.old = cls.tmp.make("old", seed=1, images=False)
        rename_header(os.path.join(cls.old, "summary.csv"), cls.OLD)

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_the_fixture_writes_the_current_names(self):
        with open(os.path.join(self.new, "summary.csv"), newline="") as f:
            header = next(csv.reader(f))
        self.assertIn("wall_ms_median", header)
        self.assertNotIn("frame_ms_median", header)
        with open(os.path.join(self.old, "summary.csv"), newline="") as f:
            self.assertIn("frame_ms_median", next(csv.reader(f)))

    def test_an_old_summary_reads_its_wall_clock_columns(self):
        new, old = Run(self.new), Run(self.old)
        self.assertIn("wall_ms_median", old.columns)
        self.assertNotIn("frame_ms_median", old.columns)
        for a, b in zip(new.cells, old.cells):
            for column in ("wall_ms_median", "wall_ms_p5", "wall_ms_p95"):
                self.assertEqual(a.text(column), b.text(column), f"{b.id} {column}")
        self.assertTrue(any(c.value("wall_ms_median") > 0 for c in old.cells))

    def test_compare_and_history_read_an_old_run(self):
        c = compare.compare(compare.RunSet(self.old), compare.RunSet(self.new))
        self.assertIn("| cell | pass |", compare.markdown(c))
        path = self.tmp.path("history.jsonl")
        history.append(self.old, path, label="old")
        cell = next(iter(history.load(path)[0]["cells"].values()))
        self.assertIsNotNone(cell["wall_ms_median"])
        self.assertNotIn("frame_ms_median", cell)

    def test_an_old_history_entry_reads_under_the_current_names(self):
        path = self.tmp.path("old_history.jsonl")
        entry = history.entry_of(Run(self.new), label="before-the-rename")
        for cell in entry["cells"].values():
            for key in ("wall_ms_median", "wall_ms_p5", "wall_ms_p95"):
                cell[self.OLD[key]] = cell.pop(key)
        with open(path, "w", encoding="utf-8") as f:
            f.write(json.dumps(entry) + "\n")
        cell_id, cell = next(iter(history.load(path)[0]["cells"].items()))
        self.assertIsNotNone(cell["wall_ms_median"])
        self.assertEqual(history.series_of(history.load(path), cell_id)["frame"],
                         [cell["wall_ms_median"] if cell["status"] == "ok" else None])

    def test_an_old_match_csv_reads_under_the_current_names(self):
        run = self.tmp.make("match", seed=1, images=False)
        header = ["scene", "technique", "cell", "frame_ms_median", "frame_ms_p5", "frame_ms_p95",
                  "frame_ms_n", "probe_frame_ms"]
        with open(os.path.join(run, "match.csv"), "w", newline="", encoding="utf-8") as f:
            csv.writer(f).writerows([header, ["box", "a", "box__a__0", "250", "240", "260", "15",
                                              "251"]])
        (row,) = matching.read_matches(run)
        self.assertEqual((row["wall_ms_median"], row["wall_ms_p5"], row["wall_ms_p95"],
                          row["wall_ms_n"], row["probe_wall_ms_median"]),
                         ("250", "240", "260", "15", "251"))


if __name__ == "__main__":
    unittest.main()
