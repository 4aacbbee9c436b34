"""The statistics behind claims (stats.py) on synthetic data with known answers, the temporal and
seed views (seeds.py) and the claims' p-values on a small seed-axis run written here."""

import csv
import json
import math
import os
import unittest

import numpy as np

from common import TempRuns

from pbtools import figures as F
from pbtools import measures, seeds, stats, style
from pbtools.claims import paper1
from pbtools.rundata import Run


class WelchTest(unittest.TestCase):
    def test_equal_distributions_are_rejected_at_the_stated_rate(self):
        rng = np.random.default_rng(3)
        trials = 4000
        rejected = sum(stats.welch(rng.normal(0, 1, 6), rng.normal(0, 2, 9)).p < 0.05
                       for _ in range(trials))
        # Binomial(4000, 0.05): sd 13.8; +-4 sd.
        self.assertGreater(rejected, 145)
        self.assertLess(rejected, 255)

    def test_shifted_distributions_are_rejected(self):
        rng = np.random.default_rng(4)
        rejected = 0
        for _ in range(200):
            a, b = rng.normal(0, 1, 8), rng.normal(3, 1, 8)
            rejected += stats.welch(a, b).p < 0.05
            # One-sided: a is lower, so "less" rejects and "greater" does not.
            self.assertLess(stats.welch(a, b, "less").p, 0.05)
            self.assertGreater(stats.welch(a, b, "greater").p, 0.5)
        # A 3-sigma shift with 8 samples a side: power about 0.99.
        self.assertGreaterEqual(rejected, 190)

    def test_statistic_and_degrees_of_freedom(self):
        # Hand-worked: means 2 and 5, variances 1 and 4 (n 3 and 4): t = -3 / sqrt(1/3 + 1) and
        # df = (1/3 + 1)^2 / ((1/3)^2 / 2 + 1 / 3).
        w = stats.welch([1, 2, 3], [5 - math.sqrt(4 * 3 / 4) * x for x in (-1, -1 / 3, 1 / 3, 1)])
        self.assertAlmostEqual(np.mean([5 - math.sqrt(3) * x for x in (-1, -1 / 3, 1 / 3, 1)]), 5)
        var_b = np.var([5 - math.sqrt(3) * x for x in (-1, -1 / 3, 1 / 3, 1)], ddof=1)
        t = -3 / math.sqrt(1 / 3 + var_b / 4)
        self.assertAlmostEqual(w.t, t, places=9)
        df = (1 / 3 + var_b / 4) ** 2 / ((1 / 3) ** 2 / 2 + (var_b / 4) ** 2 / 3)
        self.assertAlmostEqual(w.df, df, places=9)

    def test_one_seed_is_no_test(self):
        w = stats.welch([0.1], [0.2, 0.3])
        self.assertFalse(w.possible)
        self.assertIn("not possible", w.test)
        # No spread on either side: exact, no p-value invented from a zero variance.
        self.assertEqual(stats.welch([1, 1], [1, 1]).p, 1.0)
        self.assertEqual(stats.welch([1, 1], [2, 2], "less").p, 0.0)


class PoppingTest(unittest.TestCase):
    def test_a_spike_pops_and_a_smooth_series_does_not(self):
        frames = list(range(4, 36, 2))
        smooth = [0.1 + 0.002 * i for i in range(len(frames))]
        self.assertEqual(stats.popping_frames(frames, smooth), [])
        rng = np.random.default_rng(5)
        noisy = np.array(smooth) + rng.normal(0, 0.002, len(frames))
        self.assertEqual(stats.popping_frames(frames, noisy), [])
        spiked = noisy.copy()
        spiked[7] += 0.05  # 25 noise sds
        self.assertEqual(stats.popping_frames(frames, spiked), [frames[7]])
        # A drop is not a pop.
        dropped = noisy.copy()
        dropped[7] -= 0.05
        self.assertEqual(stats.popping_frames(frames, dropped), [])

    def test_k_sets_the_threshold(self):
        frames = list(range(40))
        base = 0.1 + np.random.default_rng(6).normal(0, 0.002, 40)
        self.assertEqual(stats.popping_frames(frames, base, k=4), [])
        bump = base.copy()
        # 6 robust sds above the median jump (the bump barely moves the MAD of 38 jumps).
        j = stats.jumps(base)
        bump[20] += np.nanmedian(j) - j[20] + 6 * measures.robust_sigma(j)
        self.assertEqual(stats.popping_frames(frames, bump, k=4), [20])
        self.assertEqual(stats.popping_frames(frames, bump, k=8), [])

    def test_spread(self):
        s = stats.spread([1.0, 2.0, 4.0, math.nan])
        self.assertEqual((s.n, s.min, s.max), (3, 1.0, 4.0))
        self.assertAlmostEqual(s.mean, 7 / 3)
        self.assertAlmostEqual(s.std, math.sqrt(((1 - 7 / 3) ** 2 + (2 - 7 / 3) ** 2 + (4 - 7 / 3) ** 2) / 2))
        self.assertTrue(math.isnan(stats.spread([3.0]).std))
        self.assertIsNone(stats.spread([]))


# cell -> per seed, per metric frame, the FLIP values.
def write_seed_run(path, seed_flips, flicker=None, floor=0.001):
    """A run of tiled and cluster-trivial cells on one scene and setting, each with len(flips) seeds
    (cell.json seed and seed_group as the harness writes them), metrics.csv with flip and its floor."""
    os.makedirs(os.path.join(path, "cells"))
    rows = []
    for (technique, variant), per_seed in seed_flips.items():
        group = f"box__{technique}__{variant or 'none'}"
        for i, flips in enumerate(per_seed):
            cid = f"{group}__seed{1 + i}" if len(per_seed) > 1 else group
            d = os.path.join(path, "cells", cid)
            os.makedirs(d)
            params = {"photons": "10000", "radius": "0.1", **({"variant": variant} if variant else {})}
            with open(os.path.join(d, "cell.json"), "w") as f:
                json.dump({"cell": cid, "status": "ok", "seed": 1 + i, "seed_index": i,
                           "seed_group": group, "params": params}, f)
            with open(os.path.join(d, "metrics.csv"), "w", newline="") as f:
                w = csv.writer(f)
                w.writerow(["frame", "path_class", "reference", "flip", "flip_floor", "flicker"])
                for k, v in enumerate(flips):
                    fl = "" if flicker is None or k == 0 else flicker
                    w.writerow([4 + 2 * k, "combined", "full", v, floor, fl])
            rows.append([cid, "box", technique, "ok", "10000", "0.1", variant or "", 1 + i])
    with open(os.path.join(path, "summary.csv"), "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["cell", "scene", "technique", "status", "param.photons", "param.radius",
                    "param.variant", "seed"])
        w.writerows(rows)
    return path


class SeedRunTest(unittest.TestCase):
    def setUp(self):
        self.runs = TempRuns()
        rng = np.random.default_rng(8)
        # cluster-trivial clearly better than tiled; 4 seeds of 5 metric frames each.
        self.flips = {("tiled", None): [list(0.20 + rng.normal(0, 0.005, 5)) for _ in range(4)],
                      ("cluster", "trivial"): [list(0.10 + rng.normal(0, 0.005, 5)) for _ in range(4)]}

    def tearDown(self):
        self.runs.cleanup()

    def test_groups_and_spread_across_seeds(self):
        run = Run(write_seed_run(self.runs.path("seeds"), self.flips, flicker=0.03))
        groups = seeds.groups(run)
        self.assertEqual([len(g) for g in groups.values()], [4, 4])
        self.assertEqual([seeds.seed_of(c) for c in groups["box__tiled__none"]], [1, 2, 3, 4])
        rows = {(r["group"], r["metric"]): r for r in seeds.spread_rows(run)}
        per_seed = [np.mean(f) for f in self.flips[("tiled", None)]]
        r = rows[("box__tiled__none", "flip")]
        self.assertEqual(r["seeds"], 4)
        self.assertAlmostEqual(r["mean"], np.mean(per_seed))
        self.assertAlmostEqual(r["std"], np.std(per_seed, ddof=1))
        self.assertAlmostEqual(r["max"], max(per_seed))
        self.assertAlmostEqual(rows[("box__tiled__none", "flicker")]["mean"], 0.03)
        # The K cells of one setting are told apart by their seed.
        self.assertEqual(run.label(groups["box__tiled__none"][1]), "tiled (seed=2)")
        self.assertEqual(rows[("box__tiled__none", "flip")]["label"], "tiled")
        temporal = seeds.temporal_rows(run)
        self.assertEqual(len(temporal), 8)
        self.assertAlmostEqual(temporal[0]["flicker"], 0.03)

    def test_claims_carry_the_test_and_its_p_value(self):
        run = Run(write_seed_run(self.runs.path("seeds"), self.flips))
        text = paper1.claims(run)
        line = next(l for l in text.splitlines() if "cluster-trivial beats tiled" in l)
        self.assertIn("Welch's t-test (one-sided)", line)
        a = [np.mean(f) for f in self.flips[("cluster", "trivial")]]
        b = [np.mean(f) for f in self.flips[("tiled", None)]]
        expected = stats.welch(a, b, "less").p
        self.assertIn(f"| 4 / 4 | {expected:.3g} |", line)
        self.assertLess(expected, 1e-4)

    def test_equal_techniques_are_tested_two_sided(self):
        rng = np.random.default_rng(9)
        same = {("tiled", None): [list(0.15 + rng.normal(0, 0.01, 5)) for _ in range(4)],
                ("cluster", "trivial"): [list(0.15 + rng.normal(0, 0.01, 5)) for _ in range(4)]}
        # Floors far above the difference: the order is unresolved (≈), an "equals" claim.
        text = paper1.claims(Run(write_seed_run(self.runs.path("same"), same, floor=0.05)))
        line = next(l for l in text.splitlines() if l.startswith("| box") and " equals " in l)
        self.assertIn("Welch's t-test (two-sided)", line)
        self.assertGreater(float(line.rstrip(" |").split("|")[-1]), 0.05)

    def test_without_seeds_the_test_was_not_possible(self):
        one = {k: v[:1] for k, v in self.flips.items()}
        run = Run(write_seed_run(self.runs.path("one"), one))
        self.assertEqual(run.label(run.cells[0]), "tiled")  # one seed: no seed in the label
        text = paper1.claims(run)
        line = next(l for l in text.splitlines() if "cluster-trivial beats tiled" in l)
        self.assertIn("not possible", line)
        self.assertTrue(line.rstrip().endswith("| 1 / 1 | – |"))

    def test_timeline_marks_popping_frames(self):
        # A pop also lowers its two neighbours' jumps: 16 metric frames keep the MAD robust.
        flips = {("tiled", None): [[0.2, 0.21] + [0.2, 0.6] + [0.2, 0.21] * 6],
                 ("cluster", "trivial"): [[0.1, 0.11] * 8]}
        run = Run(write_seed_run(self.runs.path("pop"), flips))
        self.assertEqual([r["popping_frames"] for r in seeds.temporal_rows(run)], [[10], []])
        # The timeline needs frame times: give every cell one whole-frame row per frame.
        for c in run.cells:
            with open(os.path.join(c.dir, "frames.csv"), "w") as f:
                f.write("frame,pass,gpu_ms,cpu_ms\n" + "".join(f"{4 + 2 * k},frame,1,1\n" for k in range(16)))
        fig = F.timeline(run, "box", style.TechniqueStyle(run.techniques()))
        gids = [line.get_gid() for ax in fig.fig.axes for line in ax.lines if line.get_gid()]
        self.assertEqual([g for g in gids if g.startswith("pop:")], ["pop:box__tiled__none:10"])
        self.assertIn(["box__tiled__none", "tiled", run.label(run.cells[0]), "pop", 10, 0.6], fig.rows)
        style.close(fig.fig)


if __name__ == "__main__":
    unittest.main()
