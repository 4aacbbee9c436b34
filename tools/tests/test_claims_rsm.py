"""photonbench claims --paper rsm (seed 000, reflective-shadow-map photons): the stage ablation with each
score beside its floor, the Fig. 1.2 groups' times as shares, gathering against splatting and the thesis's
statements, on a synthetic run folder written with fixture.py's writers, whose numbers are chosen so each
figure can be worked out by hand (the class docstrings)."""

import os
import shutil
import unittest

import common  # noqa: F401  (import paths for pbtools)
from fixture import write_csv, write_json
from pbtools import claims as claims_cli
from pbtools.claims import rsm
from pbtools.rundata import Run
from test_claims import ClaimsCase

SCENE = "spot-window"
# cell -> (params as the config sets them, indirect FLIP, indirect flicker, estimate ms per frame,
# estimate process-CPU ms per frame)
CELLS = {
    "none": ({"temporal": "false", "spatial": "false"}, 0.30, 0.60, (40, 44), (20, 20)),
    "temporal": ({"temporal": "true", "spatial": "false"}, 0.20, 0.12, (40, 44), (20, 20)),
    "spatial": ({"temporal": "false", "spatial": "true"}, 0.18, 0.15, (40, 44), (20, 20)),
    "both": ({"temporal": "true", "spatial": "true"}, 0.16, 0.06, (40, 44), (20, 20)),
    "gather": ({"estimate": "gather"}, 0.16, 0.06, (160, 176), (50, 50)),
    "noclip": ({"detail_clip": "false"}, 0.17, 0.07, (40, 44), (20, 20)),
}
FLOOR = {"indirect": 0.03, "combined": 0.025}


def metric_rows(indirect_flip, indirect_flicker, combined_flip):
    """Frames 6 and 7 (a scored pair: flicker on the second), both classes, scores with their floors."""
    header = ["frame", "path_class", "reference", "flip", "ssim", "psnr", "flicker", "flip_floor",
              "ssim_floor", "psnr_floor", "flicker_floor"]
    rows = []
    for frame in (6, 7):
        for cls, flip, flicker in (("combined", combined_flip, 0.14), ("indirect", indirect_flip,
                                                                         indirect_flicker)):
            if flip is None:
                continue
            rows.append([frame, cls, "full", flip, 1 - flip, 20 + 10 * (0.3 - flip), flicker if frame == 7 else "",
                         FLOOR[cls], 0.97, 43.5, 0.02 if frame == 7 else ""])
    return header, rows


def frame_rows(estimate_ms, estimate_cpu_ms):
    """Two measured frames: rsm 2 and 4 ms, photon-trace 10 and 14, estimate as given, filters 20 and 22
    (its nested temporal and spatial passes inside it), gi-shade 1, the whole frame 90 and 100 ms."""
    rows = []
    for i, frame in enumerate((6, 7)):
        passes = [("rsm", (2, 4)[i], 1), ("rsm/cast", 1, 1), ("photon-trace", (10, 14)[i], 5),
                  ("estimate", estimate_ms[i], estimate_cpu_ms[i]), ("filters", (20, 22)[i], 10),
                  ("filters/temporal", 1, 1), ("filters/spatial", 15, 8), ("gi-shade", 1, 1),
                  ("frame", (90, 100)[i], 40)]
        rows += [[frame, name, ms, 0.1, cpu] for name, ms, cpu in passes]
    return rows


def make_run(root, cells=CELLS, with_direct=True):
    header = ["cell", "scene", "technique", "status", "param.temporal", "param.spatial", "param.estimate",
              "param.detail_clip"]
    rows = []
    entries = [(name, "rsm-photons", spec) for name, spec in cells.items()]
    if with_direct:
        entries.append(("direct", "direct", ({}, None, None, (0, 0), (0, 0))))
    for name, technique, (params, flip, flicker, estimate, estimate_cpu) in entries:
        cid = f"{SCENE}__{name}"
        rows.append([cid, SCENE, technique, "ok"] + [params.get(p, "") for p in
                                                      ("temporal", "spatial", "estimate", "detail_clip")])
        d = os.path.join(root, "cells", cid)
        os.makedirs(d)
        timing = frame_rows(estimate, estimate_cpu) if technique == "rsm-photons" else \
            [[f, "frame", 12, 0.1, 5] for f in (6, 7)]
        write_csv(os.path.join(d, "frames.csv"), ["frame", "pass", "gpu_ms", "cpu_ms", "process_cpu_ms"], timing)
        write_csv(os.path.join(d, "metrics.csv"), *metric_rows(flip, flicker, 0.09 if name == "both" else
                                                               0.5 if technique == "direct" else 0.2))
        write_json(os.path.join(d, "cell.json"), {"status": "ok"})
    # Sorted by cell id, as the harness writes summary.csv: not the ablation's order.
    write_csv(os.path.join(root, "summary.csv"), header, sorted(rows))
    write_json(os.path.join(root, "run.json"), {"device": "test", "git_commit": "abc"})


class ClaimsRsmTest(ClaimsCase):
    """The cells of CELLS on one scene, with `direct`. The `both` cell's Fig. 1.2 groups over its two
    frames: RSM (2 + 4) / 2 = 3 ms, photon tracing 12, estimate 42, filters 21 (their nested passes not
    counted again): 78 ms, shares 4%, 15%, 54%, 27%, and 78 / 95 = 82% of the frame. Gathering's estimate
    is 168 ms against the splat's 42 (x4.00), 50 against 20 ms of process CPU (x2.50)."""
    make, paper = make_run, rsm

    def test_stages_are_read_from_the_parameters_with_their_defaults_in_the_ablations_order(self):
        labels = [line.split("|")[1].strip() for line in self.text.split("### Stage ablation")[1]
                  .split("###")[0].splitlines() if line.startswith("| ") and "floor)" not in line]
        self.assertEqual(labels, ["filters none", "temporal only", "spatial only", "both",
                                  "both, estimate gather", "both, no detail clip", "`direct` (no indirect light)"])

    def test_each_score_sits_beside_its_floor_and_unresolved_flip_is_marked(self):
        both = self.cells("| both | 0.090")
        # combined: FLIP 0.09 against a 0.025 floor is 3.6x (unresolved), SSIM, PSNR, flicker.
        self.assertEqual(both[1:5], ["0.090 (0.025) unresolved", "0.910 (0.970)", "22.10 (43.50)",
                                     "0.140 (0.020)"])
        self.assertEqual(both[5:9], ["0.160 (0.030)", "0.840 (0.970)", "21.40 (43.50)", "0.060 (0.020)"])
        self.assertEqual(self.cells("| `direct` (no indirect light) |")[5:9], ["-", "-", "-", "-"])

    def test_group_times_are_frame_means_and_shares_of_their_sum(self):
        self.assertEqual(self.cells("| both | 95.0 |")[1:],
                         ["95.0", "3.0 (4%)", "12.0 (15%)", "42.0 (54%)", "21.0 (27%)", "82%"])
        self.assertEqual(self.cells("| thesis: Conference room")[2:],
                         ["0.6 (7%)", "0.7 (8%)", "4.1 (49%)", "3.0 (36%)", "-"])  # of 8.4 ms, the four summed

    def test_process_cpu_shares_are_given_beside(self):
        # process CPU of `both`: rsm 1, photon-trace 5, estimate 20, filters 10: 36 ms of a 40 ms frame.
        self.assertEqual(self.cells("| both | 40.0 |")[1:],
                         ["40.0", "1.0 (3%)", "5.0 (14%)", "20.0 (56%)", "10.0 (28%)", "90%"])

    def test_gathering_against_splatting_is_the_estimates_time_ratio(self):
        line = self.row("§6.4, Table 6.1")
        self.assertIn("Sponza, 500,000 photons 5.1x, Conference room, 100,000 photons 8.2x", line)
        self.assertIn("both, estimate gather against both: estimate time x4.00 (process CPU x2.50), "
                      "slower, as the thesis found", line)

    def test_statements_compare_the_stages(self):
        self.assertIn("indirect flicker x0.20 (better)", self.row("§7.2"))
        self.assertIn("indirect FLIP better than filters none", self.row("§7.3 ("))
        self.assertIn("; the lowest indirect FLIP of the filter stages\n", self.text)
        # FLIP 0.16 against 0.17, both resolved (floor 0.03): the order holds; flicker 0.06 against
        # 0.07 differ by less than their floors together (0.02 + 0.02): unresolved.
        self.assertIn("with them indirect FLIP better, flicker better (unresolved)", self.row("§7.3.1"))
        self.assertIn("indirect FLIP 0.160 against 0.160 (floor 0.030): equal", self.row("§6.4"))
        self.assertIn("6 of 6 cells lower", self.row("against no indirect light"))

    def test_a_run_without_the_technique_is_refused(self):
        shutil.rmtree(self.dir)
        os.makedirs(self.dir)
        make_run(self.dir, cells={})
        with self.assertRaises(rsm.MissingCells):
            rsm.claims(Run(self.dir))

    def test_the_cli_writes_the_claims_beside_the_run(self):
        self.assertEqual(claims_cli.main([self.dir, "--paper", "rsm"]), 0)
        with open(os.path.join(self.dir, "report", "claims-rsm.md"), encoding="utf-8") as f:
            self.assertEqual(f.read(), self.text)


if __name__ == "__main__":
    unittest.main()
