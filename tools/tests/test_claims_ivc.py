"""photonbench claims --paper ivc (seed 002's Paper V against seed 004 §5.2's splat BVH): Table 1's
rows with the seeds' spread, temporal against basic and splat_bvh against plain aaps, on a synthetic
run folder written with fixture.py's writers, whose numbers are chosen so that each figure can be
worked out by hand (the class docstring)."""

import os
import shutil
import unittest

import common  # noqa: F401  (import paths for pbtools)
from fixture import write_csv, write_json
from pbtools import claims as claims_cli
from pbtools.claims import ivc
from pbtools.rundata import Run
from test_claims import ClaimsCase

SCENE = "caustic-box-ac"
FLOOR = 0.04
# cell -> (technique, params, seed, {frame: (MAE, FLIP)}, per-frame ms of the passes)
CELLS = {
    "cp_s1": (ivc.CP, {"temporal": "false"}, 1, {150: (0.010, 0.30), 298: (0.012, 0.40)},
              {"accumulate": 4}),
    "cp_s2": (ivc.CP, {"temporal": "false"}, 2, {150: (0.014, 0.32), 298: (0.012, 0.40)}, {}),
    "cpt_s1": (ivc.CP, {"temporal": "true"}, 1, {150: (0.008, 0.24), 298: (0.010, 0.30)}, {}),
    "cpt_s2": (ivc.CP, {"temporal": "true"}, 2, {150: (0.008, 0.26), 298: (0.010, 0.30)}, {}),
    # fixed4_28 is not a Table 1 row.
    "cp_fixed": (ivc.CP, {"accumulator": "fixed4_28"}, 1, {150: (0.5, 0.9)}, {}),
    # Nor is emission by power: Table 1 is the paper's aimed emission.
    "cp_power": (ivc.CP, {"emission": "power"}, 1, {150: (0.6, 0.8)}, {}),
    "aaps": (ivc.AAPS, {"indirect": "none"}, 1, {}, {"photon-trace": 4, "rasterize": 3, "apply": 1,
                                                     "task-update": 2}),
    "aaps_bvh": (ivc.AAPS, {"indirect": "splat_bvh"}, 1, {150: (0.02, 0.50)},
                 {"photon-trace": 4, "rasterize": 3, "apply": 1, "task-update": 2, "camera-paths": 5,
                  "camera-path-upload": 1, "splat-bvh": 6, "indirect": 18}),
}
# cell -> its counters, the same each frame
COUNTERS = {"cp_s1": {"photons_stored": 2000, "bytes_total": 5e6},
            "aaps": {"splats_drawn": 1000},
            "aaps_bvh": {"splats_drawn": 1000, "bvh_nodes": 8000, "bytes_indirect": 3e6}}
# match.csv of an equal-time run: aaps_bvh found at 40 ms (its FLIP 0.500 at frame 150).
MATCH_HEADER = ["scene", "technique", "at", "target", "tolerance", "knob", "knob_value", "status",
                "probes", "cell", "wall_ms_median", "wall_ms_p5", "wall_ms_p95"]
MATCH_ROWS = [[SCENE, ivc.AAPS, "time", "40", "0.15", "target_area", "3.5", "matched", "4",
               f"{SCENE}__aaps_bvh", "41.2", "39.0", "44.1"]]


def make_run(root, cells=CELLS, match=True):
    params = ("temporal", "accumulator", "indirect", "emission")
    header = ["cell", "scene", "technique", "status", "seed"] + [f"param.{p}" for p in params]
    rows = []
    for name, (technique, cell_params, seed, scores, passes) in cells.items():
        cid = f"{SCENE}__{name}"
        rows.append([cid, SCENE, technique, "ok", seed] + [cell_params.get(p, "") for p in params])
        d = os.path.join(root, "cells", cid)
        os.makedirs(d)
        frames = [[f, p, ms, 0.1] for f in (150, 151) for p, ms in passes.items()]
        write_csv(os.path.join(d, "frames.csv"), ["frame", "pass", "gpu_ms", "cpu_ms"], frames)
        write_csv(os.path.join(d, "metrics.csv"),
                  ["frame", "path_class", "reference", "mae", "flip", "flip_floor"],
                  [[f, "indirect_caustics", "full", mae, flip, FLOOR] for f, (mae, flip) in scores.items()])
        counters = [[f, n, v + (f - 150 if n == "bvh_nodes" else 0)]
                    for f in (150, 151) for n, v in COUNTERS.get(name, {}).items()]
        write_csv(os.path.join(d, "counters.csv"), ["frame", "name", "value"], counters)
        write_json(os.path.join(d, "cell.json"), {"status": "ok"})
    write_csv(os.path.join(root, "summary.csv"), header, sorted(rows))
    write_json(os.path.join(root, "run.json"), {"device": "test", "git_commit": "abc"})
    if match:
        write_csv(os.path.join(root, "match.csv"), MATCH_HEADER, MATCH_ROWS)


class ClaimsIvcTest(ClaimsCase):
    """AC@150 basic: FLIP 0.30 and 0.32 over seeds 1 and 2, mean 0.310, sd 0.01414 (4.6% of the mean),
    MAE 0.010 and 0.014, mean 0.0120 sd 0.0028; AC@298: 0.40 twice, sd 0. Temporal (0.24 and 0.26, sd
    0.014): 0.25 against 0.31
    at AC@150 (-19.4%), 0.30 against 0.40 at AC@298 (-25.0%). aaps: 10 ms a frame; splat_bvh 10 + 30 =
    40 ms (x4.00), the build 6 of 6 + 18 ms (25%), 8000.5 BVH nodes, 3e6 bytes, FLIP 0.500 against
    collection-points' 0.355 (basic, all frames). Accumulation: 4 ms for 2,000 photons, 2.000 ms a
    thousand; rasterisation: 3 ms for 1,000 splats, 3.000 ms a thousand. Equal time: aaps_bvh
    found at 41.2 ms with its FLIP 0.500 beside the floor 0.040."""
    make, paper = make_run, ivc

    def test_table1_rows_are_seed_means_with_their_spread_beside_the_floor(self):
        self.assertEqual(self.cells("| AC@150 | no |")[2:],
                         ["2", "0.0120 (0.0028)", "0.310 (0.014)", "0.040", "4.6%"])
        self.assertEqual(self.cells("| AC@298 | no |")[4:], ["0.400 (0.000)", "0.040", "0.0%"])
        self.assertEqual(self.cells("| AC@150 | yes |")[3:5], ["0.0080 (0.0000)", "0.250 (0.014)"])
        self.assertNotIn("0.900", self.text)  # the fixed4_28 cell is not a row
        self.assertNotIn("0.800", self.text)  # nor is emission by power

    def test_temporal_against_basic_is_the_flip_change(self):
        self.assertEqual(self.cells("| AC@150 | 0.310 | 0.250")[3], "-19.4%")
        self.assertEqual(self.cells("| AC@298 | 0.400 | 0.300")[3], "-25.0%")

    def test_splat_bvh_against_plain_aaps_is_the_frame_time_ratio_with_the_build_share(self):
        self.assertEqual(self.cells(f"| {SCENE} | 10.0")[1:],
                         ["10.0", "40.0", "4.00x", "25%", "8000", "3000000", "0.500", "0.355"])

    def test_accumulation_and_rasterisation_are_per_thousand_of_their_own_items(self):
        self.assertEqual(self.cells(f"| {SCENE} | {ivc.CP} |")[2:], ["2.000", "-", "2000", "5000000"])
        self.assertEqual(self.cells(f"| {SCENE} | {ivc.AAPS} (none) |")[2:4], ["-", "3.000"])
        self.assertEqual(self.cells(f"| {SCENE} | {ivc.CP} (power emission) |")[2], "-")

    def test_equal_time_gives_the_found_setting_its_time_and_class_flip(self):
        self.assertEqual(self.cells(f"| {SCENE} | {ivc.AAPS} (splat_bvh) | matched")[3:],
                         ["target_area = 3.5", "41.2 (39.0-44.1)", "0.500", "0.040"])

    def test_a_run_without_a_match_has_no_equal_time_section(self):
        shutil.rmtree(self.dir)
        os.makedirs(self.dir)
        make_run(self.dir, match=False)
        self.assertNotIn("### Equal time", ivc.claims(Run(self.dir)))

    def test_a_run_without_collection_points_is_refused(self):
        shutil.rmtree(self.dir)
        os.makedirs(self.dir)
        make_run(self.dir, cells={k: v for k, v in CELLS.items() if v[0] != ivc.CP})
        with self.assertRaises(ivc.MissingCells):
            ivc.claims(Run(self.dir))

    def test_the_cli_writes_the_claims_beside_the_run(self):
        self.assertEqual(claims_cli.main([self.dir, "--paper", "ivc"]), 0)
        self.assertTrue(os.path.exists(os.path.join(self.dir, "report", "claims-ivc.md")))


if __name__ == "__main__":
    unittest.main()
