"""verdict: per scene, the settings ordered by combined FLIP, `<` only where the gap beats both noise
floors (and, with seeds, the seed test), `≈` otherwise with what would resolve it; the time each step
up in quality costs; each technique's own class beside the combined score; the report's bold best only
where resolved."""

import csv
import json
import os
import shutil
import tempfile
import unittest

import common  # noqa: F401  (puts tools/ on the import path)

from pbtools import tables, verdict
from pbtools.rundata import Run

# cell, technique, [(class, flip, floor)], frame ms, seed
CELLS = [("box__direct__0", "direct", [("combined", 0.100, 0.005)], 300.0, 1),
         ("box__directional__0", "directional", [("combined", 0.206, 0.01), ("caustics", 0.31, 0.02)],
          200.0, 1),
         ("box__tiled__0", "tiled", [("combined", 0.207, 0.01), ("caustics", 0.40, 0.02)], 150.0, 1)]


def write_run(path, cells, rel_error=0.1, reached=None):
    os.makedirs(os.path.join(path, "cells"))
    with open(os.path.join(path, "summary.csv"), "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(["cell", "scene", "technique", "status", "wall_ms_median", "flip_mean",
                    "flip_floor", "seed"])
        for cell, technique, scores, ms, seed in cells:
            w.writerow([cell, "box", technique, "ok", ms, scores[0][1], scores[0][2], seed])
    for cell, technique, scores, ms, seed in cells:
        d = os.path.join(path, "cells", cell)
        os.makedirs(d)
        with open(os.path.join(d, "cell.json"), "w", encoding="utf-8") as f:
            references = [] if reached is None else [
                {"frame": 4, "path_class": "combined", "reference": "full", "rel_error": reached,
                 "seconds": 60.0, "stopped_by": "max_seconds"}]
            json.dump({"cell": cell, "status": "ok", "seed": seed,
                       "seed_group": cell.split("__seed")[0], "params": {},
                       "references": references}, f)
        with open(os.path.join(d, "metrics.csv"), "w", newline="", encoding="utf-8") as f:
            w = csv.writer(f)
            w.writerow(["frame", "path_class", "reference", "flip", "flip_floor"])
            for cls, flip, floor in scores:
                w.writerow([4, cls, "full", flip, floor])
    with open(os.path.join(path, "run.json"), "w", encoding="utf-8") as f:
        # A scene entry's own stop rules come first in the text, as a config writes them.
        json.dump({"name": "v", "config": "scenes:\n  - {scene: box, reference: {rel_error: 0.02}}\n"
                   f"reference: {{rel_error: {rel_error}}}\n"}, f)


class VerdictTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="pbtools-verdict-")

    def tearDown(self):
        shutil.rmtree(self.dir, ignore_errors=True)

    def run_of(self, cells):
        path = os.path.join(self.dir, str(len(os.listdir(self.dir))))
        write_run(path, cells)
        return Run(path)

    def test_a_gap_within_the_floors_is_unresolved_with_the_reference_it_needs(self):
        v = verdict.scene_verdict(self.run_of(CELLS), "box")
        self.assertEqual(v.order, "direct < directional ≈ tiled")
        first, second = v.steps
        self.assertTrue(first.resolved)
        self.assertEqual(first.cost, "+100.0 ms (1.50x)")
        self.assertEqual(second.cost, "+50.0 ms (1.33x)")
        # 0.001 apart with floors summing to 0.02: a reference 20x finer would resolve it.
        self.assertFalse(second.resolved)
        self.assertIn("reference.rel_error <= 0.005 (now 0.1)", second.needs[0])
        self.assertTrue(v.one_seed)
        self.assertTrue(v.best_resolved)

    def test_the_reference_it_needs_starts_from_the_error_the_scenes_references_reached(self):
        path = os.path.join(self.dir, "reached")
        write_run(path, CELLS, reached=0.14)  # stopped by its time limit above the config's 0.1
        second = verdict.scene_verdict(Run(path), "box").steps[1]
        self.assertIn("reference.rel_error <= 0.007 (now 0.14)", second.needs[0])

    def test_each_techniques_own_class_is_beside_the_combined_score(self):
        rows = verdict.view(self.run_of(CELLS))[0]["rows"]
        self.assertEqual(rows[1]["own"], "caustics: 0.3100 (floor 0.0200)")
        self.assertEqual(rows[0]["own"], "")
        self.assertEqual([r["sign"] for r in rows], ["", "<", "≈"])

    def test_seeds_must_confirm_an_order_the_floors_resolve(self):
        # Two settings far apart against the floors, but the seeds' spread swallows the gap.
        cells = []
        for seed, (a, b) in enumerate([(0.10, 0.20), (0.30, 0.12), (0.11, 0.25)], start=1):
            cells.append((f"box__a__0__seed{seed}", "a", [("combined", a, 0.001)], 100.0, seed))
            cells.append((f"box__b__0__seed{seed}", "b", [("combined", b, 0.001)], 100.0, seed))
        v = verdict.scene_verdict(self.run_of(cells), "box")
        self.assertTrue(v.steps[0].by_floors)
        self.assertFalse(v.steps[0].resolved)
        self.assertEqual(v.order.count("≈"), 1)
        self.assertIn("more seeds", v.steps[0].needs[-1])
        self.assertFalse(v.one_seed)

    def test_the_bold_best_score_only_where_resolved(self):
        run = self.run_of(CELLS)
        bold = tables.best_mask(tables.summary_table(run))
        self.assertEqual(list(bold["flip_mean"]), [True, False, False])
        close = self.run_of(CELLS[1:])  # directional 0.206 against tiled 0.207: no best
        self.assertEqual(list(tables.best_mask(tables.summary_table(close))["flip_mean"]),
                         [False, False])

    def test_claims_order_follows_the_same_rule(self):
        from pbtools.claims import paper1
        run = self.run_of(CELLS)
        kinds = {c.technique: c for c in run.cells}
        order = paper1.flip_order(kinds, "combined", "full")
        self.assertEqual([(k, sep) for k, _, sep in order],
                         [("direct", ""), ("directional", "<"), ("tiled", "≈")])


if __name__ == "__main__":
    unittest.main()


class ClaimsMemoryTest(unittest.TestCase):
    def test_a_technique_that_did_not_run_has_no_memory_total(self):
        import test_claims
        from pbtools.claims import paper1
        d = tempfile.mkdtemp(prefix="pb_claims_memory_")
        saved = dict(test_claims.CELLS)
        try:
            del test_claims.CELLS["directional"]
            test_claims.make_run(d)
            text = paper1.claims(Run(d))
        finally:
            test_claims.CELLS.clear()
            test_claims.CELLS.update(saved)
            shutil.rmtree(d)
        total = next(line for line in text.splitlines() if line.startswith("| **Total** |"))
        self.assertIn("| – (not run) (942) |", total)
        self.assertNotIn("0.000", total)
