"""A match run's re-measurement rounds (role "round" in RUN/match/cells.json, run/match.cpp) are the found cell's
setting and seed timed again: never counted as seeds, and marked as rounds wherever a cell is
labelled (tables and plots take their row names from Run.label)."""

import csv
import json
import os
import shutil
import tempfile
import unittest

import common  # noqa: F401  (puts tools/ on the import path)

from pbtools import report, seeds
from pbtools.rundata import Run

FOUND = "box__tiled__1234abcd"


def write_run(path, cells):
    """A run folder of `cells` (id, seed_group), each ok with one combined FLIP score."""
    os.makedirs(os.path.join(path, "cells"))
    with open(os.path.join(path, "summary.csv"), "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["cell", "scene", "technique", "status", "wall_ms_median", "flip_mean", "seed",
                    "param.photons"])
        for i, (cell, group) in enumerate(cells):
            w.writerow([cell, "box", "tiled", "ok", 250 + i, 0.2 + 0.001 * i, 1, 20000])
    for i, (cell, group) in enumerate(cells):
        os.makedirs(os.path.join(path, "cells", cell))
        with open(os.path.join(path, "cells", cell, "cell.json"), "w", encoding="utf-8") as f:
            json.dump({"cell": cell, "status": "ok", "seed": 1, "seed_group": group,
                       "params": {"photons": "20000"}}, f)
    with open(os.path.join(path, "run.json"), "w", encoding="utf-8") as f:
        json.dump({"name": "match"}, f)
    # The run's extra cells with their roles, as run/match.cpp lists them.
    os.makedirs(os.path.join(path, "match"))
    with open(os.path.join(path, "match", "cells.json"), "w", encoding="utf-8") as f:
        json.dump([{"id": cell, "scene": "box", "technique": "tiled", "params": {"photons": "20000"},
                    "seed": 1, "seed_group": group, "role": "round" if "__round" in cell else "probe"}
                   for cell, group in cells], f)


class MatchRoundsTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="pbtools-rounds-")

    def tearDown(self):
        shutil.rmtree(self.dir, ignore_errors=True)

    def check(self, run):
        self.assertFalse(seeds.has_seed_axis(run), "rounds counted as seeds")
        self.assertEqual(seeds.spread_rows(run), [])
        labels = [run.label(c) for c in run.cells]
        self.assertEqual(labels, ["tiled", "tiled (round 1)", "tiled (round 2)"])
        self.assertEqual(report.status_view(run)["ok"], 3)

    def test_rounds_are_not_seeds_and_are_labelled_as_rounds(self):
        path = os.path.join(self.dir, "run")
        write_run(path, [(FOUND, FOUND), (FOUND + "__round1", FOUND + "__round1"),
                         (FOUND + "__round2", FOUND + "__round2")])
        self.check(Run(path))

    def test_a_run_recorded_with_rounds_in_the_found_cells_seed_group_too(self):
        path = os.path.join(self.dir, "old")
        write_run(path, [(FOUND, FOUND), (FOUND + "__round1", FOUND), (FOUND + "__round2", FOUND)])
        self.check(Run(path))


if __name__ == "__main__":
    unittest.main()
