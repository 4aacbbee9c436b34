"""photonbench claims (Paper I): the ratios, rejection rates and memory it prints are the ones the run's
CSVs imply. A hand-made run with known per-frame times and counters: tiled's splat + estimate takes
exactly 3x (frame 0) and 1x (frame 1) cluster-trivial's, so the mean ratio is 2x and the peak 3x."""

import csv
import json
import os
import shutil
import tempfile
import unittest

import common  # noqa: F401  (import paths for pbtools)
from pbtools.claims import paper1
from pbtools.rundata import Run


def write_csv(path, header, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)


# kind -> (technique, variant, {pass: [ms at frame 0, frame 1]}, {counter: value per frame})
CELLS = {
    "tiled": ("tiled", None, {"tile-bounds": [1, 1], "splat": [10, 4], "radiance-estimate": [50, 16],
                              "photon-trace": [100, 100]},
              {"photons_read": 1000, "photons_rejected": 900, "bytes_tile_bounds": 2 ** 20}),
    "cluster-trivial": ("cluster", "trivial",
                        {"cluster-build": [3, 3], "splat": [5, 5], "radiance-estimate": [15, 15],
                         "photon-trace": [100, 100]},
                        {"photons_read": 400, "photons_rejected": 8, "trivial_accepts": 50,
                         "bytes_cluster_hierarchy": 3 * 2 ** 20}),
    "directional": ("directional", None,
                    {"cluster-build": [3, 3], "splat": [4, 4], "radiance-estimate": [2, 2], "blur": [4, 4]},
                    {"bytes_accum_flux": 2 ** 19}),
}


def make_run(root):
    header = ["cell", "scene", "technique", "status", "param.photons", "param.radius", "param.variant"]
    rows = []
    for kind, (technique, variant, passes, counters) in CELLS.items():
        cid = f"cornell-box__{kind}"
        rows.append([cid, "cornell-box", technique, "ok", "1000", "0.05", variant or ""])
        d = os.path.join(root, "cells", cid)
        os.makedirs(d)
        write_csv(os.path.join(d, "frames.csv"), ["frame", "pass", "gpu_ms", "cpu_ms"],
                  [[f, p, ms[f], 0.1] for p, ms in passes.items() for f in (0, 1)])
        write_csv(os.path.join(d, "counters.csv"), ["frame", "name", "value"],
                  [[f, n, v] for n, v in counters.items() for f in (0, 1)])
        write_csv(os.path.join(d, "metrics.csv"), ["frame", "path_class", "flip", "ssim", "psnr", "rmse", "relmse"],
                  [[0, "combined", 0.2, 0.9, 30, 0.1, 0.01], [0, "indirect", 0.3, 0.8, 25, 0.1, 0.05]])
        with open(os.path.join(d, "cell.json"), "w") as f:
            json.dump({"status": "ok"}, f)
    write_csv(os.path.join(root, "summary.csv"), header, rows)
    with open(os.path.join(root, "run.json"), "w") as f:
        json.dump({"config": "resolution: [320, 180]\n", "overrides": [], "device": "test"}, f)


class ClaimsPaper1Test(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="pb_claims_")
        make_run(self.dir)
        self.text = paper1.claims(Run(self.dir))

    def tearDown(self):
        shutil.rmtree(self.dir)

    def row(self, *needles):
        for line in self.text.splitlines():
            if all(n in line for n in needles):
                return line
        self.fail(f"no line with {needles} in:\n{self.text}")

    def test_tiled_over_cluster_is_averaged_per_frame_with_its_peak(self):
        # splat + estimate: tiled 60 and 20 ms, cluster 20 and 20 ms -> 3x and 1x: mean 2x, peak 3x.
        # + build: tiled 61, 21; cluster 23, 23 -> 2.652 and 0.913: mean 1.78x, peak 2.65x.
        line = self.row("| cluster-trivial |", "cornell-box")
        self.assertIn("2.00× (3.00×)", line)
        self.assertIn("1.78× (2.65×)", line)

    def test_rejected_share_is_rejected_over_read(self):
        self.assertIn("2.00%", self.row("| cluster-trivial | 400 |"))
        self.assertIn("90.00%", self.row("| tiled | 1,000 |"))
        self.assertIn("| 50 |", self.row("| cluster-trivial | 400 |"))

    def test_directional_speed_up_includes_its_blur(self):
        # cluster-trivial splat + estimate 20 ms, directional 4 + 2 + 4 = 10 ms -> 2x.
        self.assertIn("2.00× (2.00×)", self.row("cornell-box", "1000 paths", "/ 0.0% /"))

    def test_memory_rows_in_mib_beside_the_paper(self):
        self.assertIn("3.000 (97)", self.row("| Cluster Hierarchy |"))
        self.assertIn("0.500 (582)", self.row("| Accum. Flux |"))
        self.assertIn("1.000 (0.016)", self.row("| Tiles z-Bounds |"))

    def test_quality_table_has_ssim_percent_and_indirect_relmse(self):
        self.assertIn("90.0 / 30.0 / 0.200; ind. 0.300 / 0.050", self.row("| cornell-box | 1000 paths, r 0.05 | 90.0"))


if __name__ == "__main__":
    unittest.main()
