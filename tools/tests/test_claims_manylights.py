"""photonbench claims --paper manylights (seed 002 Papers III and IV) on a hand-made run of
configs/manylights.yaml's shape whose answers are worked out by hand: two alternating rounds (seeds 1, 2)
of `direct` with `direct_light: nee` on a static and a moving scene, each cell's rmse, NEE pass times,
update times and counters chosen so that every ratio is exact (the class docstring)."""

import json
import os
import shutil
import tempfile
import unittest

import common  # noqa: F401  (import paths for pbtools)
from fixture import write_csv
from pbtools import claims as claims_cli
from pbtools.claims import manylights
from pbtools.rundata import Run

FRAMES = (2, 3, 4, 5)
SCORED = (2, 4)
# scene -> [(params, rmse per scored frame, NEE ms per round (sample, trace, shade split 3:1:1 of it),
#            update ms per frame (build or refit), nodes per sample)]
STATIC = [
    ({"nee_sampler": "uniform"}, (4.0, 4.0), (5, 5), 0, 0),             # MSE 16
    ({"nee_sampler": "power"}, (3.0, 3.0), (5, 5), 0, 0),               # MSE 9
    ({"nee_sampler": "bvh", "nee_importance": "d"}, (2.0, 2.0), (10, 10), 0, 10),     # MSE 4
    ({"nee_sampler": "bvh", "nee_importance": "dfbo"}, (1.0, 1.0), (15, 10), 0, 20),  # MSE 1
    ({"nee_sampler": "bvh", "nee_levels": "two"}, (1.0, 1.1), (15, 10), 0, 22),       # MSE 1.105
]
MOVING = [
    ({"nee_sampler": "uniform"}, (4.0, 4.0), (5, 5), 0, 0),
    ({"nee_sampler": "bvh", "nee_levels": "one", "nee_update": "rebuild"}, (1.0, 1.0), (10, 10), 100, 20),
    ({"nee_sampler": "bvh", "nee_levels": "one", "nee_update": "refit"}, (1.0, 2.0), (10, 10), 1, 20),
    ({"nee_sampler": "bvh", "nee_levels": "two", "nee_update": "rebuild"}, (1.0, 1.0), (10, 10), 100, 22),
    ({"nee_sampler": "bvh", "nee_levels": "two", "nee_update": "refit"}, (1.0, 1.2), (10, 10), 0.5, 22),
]
SCENES = {"lamp-hall": STATIC, "lamp-hall-moving": MOVING}
PARAMS = ["direct_light", "nee_importance", "nee_levels", "nee_sampler", "nee_update"]


def make_run(root, scenes=SCENES, config="seeds: 2\nseed_order: rounds\n", rounds=2, unbiased_offset=None):
    header = ["cell", "scene", "technique", "status", "seed"] + [f"param.{p}" for p in PARAMS]
    plan = [(scene, i, cell) for scene, cells in scenes.items() for i, cell in enumerate(cells)]
    rows = []
    for r in range(rounds):
        for scene, i, (params, rmse, nee, update, nodes) in (plan if r % 2 == 0 else plan[::-1]):
            params = dict(params, direct_light="nee")
            group = f"{scene}__direct__{(7 * i + 3) % 10:02d}"  # ids not in the papers' order
            seed = 1 + r
            cid = f"{group}__seed{seed}" if rounds > 1 else group
            rows.append([cid, scene, "direct", "ok", seed] + [params.get(p, "") for p in PARAMS])
            d = os.path.join(root, "cells", cid)
            os.makedirs(d)
            frame_rows = []
            for f in FRAMES:
                ms = nee[r]
                frame_rows += [[f, "gbuffer", 2, 0.1, ""], [f, "direct-light", 0.5, ms + update, ""],
                               [f, "direct-light/nee/sample", 0.1, 0.6 * ms, ""],
                               [f, "direct-light/nee/trace", 0.1, 0.2 * ms, ""],
                               [f, "direct-light/nee/shade", 0.1, 0.2 * ms, ""]]
                if update:
                    name = "refit" if params.get("nee_update") == "refit" else "build"
                    frame_rows.append([f, f"direct-light/light-bvh/{name}", 0.1, update, ""])
                frame_rows.append([f, "frame", "", ms + update + 5, ""])
            write_csv(os.path.join(d, "frames.csv"), ["frame", "pass", "gpu_ms", "cpu_ms", "process_cpu_ms"],
                      frame_rows)
            write_csv(os.path.join(d, "counters.csv"), ["frame", "name", "value"],
                      [[f, n, v] for f in FRAMES for n, v in (("nee_nodes_per_sample", nodes),
                                                              ("nee_occluded_share", 0.25),
                                                              ("light_bvh_bytes", 1000 * nodes))])
            # The `direct` class carries the score; `combined` (the same image here) is ignored.
            columns = ["frame", "path_class", "reference", "rmse", "flip"]
            rows_m = [[f, cls, "full", e if cls == "direct" else 100, 0.5]
                      for f, e in zip(SCORED, rmse) for cls in ("combined", "direct")]
            if unbiased_offset is not None:
                columns.append("mse_unbiased")
                rows_m = [row + [row[3] ** 2 - unbiased_offset] for row in rows_m]
            write_csv(os.path.join(d, "metrics.csv"), columns, rows_m)
            with open(os.path.join(d, "cell.json"), "w") as fh:
                json.dump({"status": "ok", "seed": seed, "seed_index": r, "seed_group": group}, fh)
    write_csv(os.path.join(root, "summary.csv"), header, sorted(rows))  # by cell id, as the harness
    with open(os.path.join(root, "run.json"), "w") as f:
        json.dump({"config": "name: manylights\n" + config, "overrides": [], "device": "test",
                   "git_commit": "abc"}, f)


class ClaimsManyLightsTest(unittest.TestCase):
    """lamp-hall: MSE (rmse^2, direct class) uniform 16, power 9, bvh d 4, bvh dfbo 1, two levels 1.105
    (1 and 1.21 over its two frames). NEE ms (sample + trace + shade): uniform 5 in both rounds, bvh dfbo
    15 then 10: time ratios 3 and 2 (median 2.5). lamp-hall-moving: the one-level rebuild updates 100 ms a
    frame, the two-level refit 0.5 (ratio 0.005), MSE 1 against (1 + 1.44) / 2 = 1.22; efficiency
    1/((NEE + update) MSE): uniform 1/(5 x 16) = 1/80, two-level refit 1/(10.5 x 1.22), 80 / 12.81 =
    6.245x; the one-level rebuild 1/110, 0.727x."""

    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="pb_claims_manylights_")
        make_run(self.dir)
        self.text = manylights.claims(Run(self.dir))

    def tearDown(self):
        shutil.rmtree(self.dir)

    def cells(self, scene, *needles):
        section = self.text.split(f"## {scene}\n")[1].split("\n## ")[0]
        for line in section.splitlines():
            if all(n in line for n in needles):
                return [c.strip() for c in line.split("|")[1:-1]]
        self.fail(f"no line with {needles} in {scene}:\n{self.text}")

    def test_settings_are_labelled_from_their_parameters_and_defaults(self):
        labels = [row.split("|")[1].strip() for row in self.text.split("## lamp-hall\n")[1].split("###")[0]
                  .splitlines() if row.startswith("| ") and "setting" not in row]
        self.assertEqual(labels, ["uniform", "power", "bvh d", "bvh dfbo", "bvh dfbo, two levels"])

    def test_mse_is_the_mean_of_squared_rmse_of_the_direct_class(self):
        self.assertEqual(self.cells("lamp-hall", "| uniform |")[1:4], ["16.00", "5.00", "0.000"])
        self.assertEqual(self.cells("lamp-hall", "| bvh dfbo, two levels |")[1], "1.10")
        self.assertEqual(self.cells("lamp-hall", "| bvh d |")[4:7], ["10.0", "0.250", "10,000"])

    def test_paper_iii_ratios_are_per_round_with_the_papers_figures_beside(self):
        self.assertEqual(self.cells("lamp-hall", "III: the BVH with distance alone")[1:3],
                         ["4x-6x lower", "4.00× [4.00–4.00]"])
        self.assertEqual(self.cells("lamp-hall", "III: the full importance")[2], "4.00× [4.00–4.00]")
        # 15/5 in round 1, 10/5 in round 2.
        self.assertEqual(self.cells("lamp-hall", "III: BVH_DFBO's time")[1:3], ["2x-3x", "2.50× [2.00–3.00]"])
        self.assertEqual(self.cells("lamp-hall", "IV Table 1: two levels")[2], "1.10× [1.10–1.10]")

    def test_a_setting_the_run_lacks_is_named_not_guessed(self):
        self.assertIn("not in this run (`bvh dfbo, two levels, refit` missing)",
                      self.cells("lamp-hall", "a two-level refit against a one-level rebuild")[2])
        self.assertIn("not in this run (`bvh d` missing)",
                      self.cells("lamp-hall-moving", "III: the BVH with distance alone")[2])

    def test_paper_iv_update_time_and_efficiency_on_the_moving_scene(self):
        self.assertEqual(self.cells("lamp-hall-moving", "update time, two-level refit")[2],
                         "0.0050× [0.0050–0.0050]")
        self.assertEqual(self.cells("lamp-hall-moving", "a two-level refit against a one-level rebuild")[2],
                         "1.22× [1.22–1.22]")
        self.assertEqual(self.cells("lamp-hall-moving", "a one-level refit against a rebuild")[2],
                         "2.50× [2.50–2.50]")
        self.assertEqual(self.cells("lamp-hall-moving", "efficiency 1/(t MSE) of the two-level refit")[2],
                         "6.25× [6.25–6.25]")
        self.assertEqual(self.cells("lamp-hall-moving", "efficiency of the one-level rebuild")[2],
                         "0.73× [0.73–0.73]")

    def test_the_animation_table_lists_each_scored_frames_mse_on_the_moving_scene_only(self):
        self.assertEqual(self.cells("lamp-hall-moving", "| 4 |"), ["4", "1.00", "4.00", "1.00", "1.44"])
        self.assertNotIn("Fig. 7", self.text.split("## lamp-hall-moving")[0])

    def test_mse_unbiased_is_preferred_where_the_run_has_it(self):
        shutil.rmtree(self.dir)
        os.makedirs(self.dir)
        make_run(self.dir, unbiased_offset=0.5)
        text = manylights.claims(Run(self.dir))
        self.assertIn("| uniform | 15.50 |", text)
        self.assertIn("| bvh d | 3.50 |", text)

    def test_grouped_seeds_warn_that_the_time_ratios_are_not_side_by_side(self):
        shutil.rmtree(self.dir)
        os.makedirs(self.dir)
        make_run(self.dir, config="seeds: 2\n")
        self.assertIn("**Warning: not alternating rounds**", manylights.claims(Run(self.dir)))

    def test_a_run_without_nee_cells_is_refused(self):
        shutil.rmtree(self.dir)
        os.makedirs(self.dir)
        make_run(self.dir, scenes={"lamp-hall": []})
        with self.assertRaises(manylights.MissingCells):
            manylights.claims(Run(self.dir))

    def test_the_cli_writes_the_claims_beside_the_run(self):
        self.assertEqual(claims_cli.main([self.dir, "--paper", "manylights"]), 0)
        with open(os.path.join(self.dir, "report", "claims-manylights.md"), encoding="utf-8") as f:
            self.assertEqual(f.read(), self.text)


if __name__ == "__main__":
    unittest.main()
