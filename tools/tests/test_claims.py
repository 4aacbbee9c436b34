"""photonbench claims (Paper I): the ratios, rejection rates and memory it prints are the ones the run's
CSVs imply. A hand-made run with known per-frame times and counters: tiled's splat + estimate takes
exactly 3x (frame 0) and 1x (frame 1) cluster-trivial's, so the mean ratio is 2x and the peak 3x. Then each
paper's comparisons at equal time from hand-made matched runs (match.csv, match_probes.csv and the rounds'
frames), and what each says without one."""

import csv
import json
import os
import shutil
import tempfile
import unittest

import common  # noqa: F401  (import paths for pbtools)
from pbtools.claims import aaps, paper1, paper2
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


class ClaimsCase(unittest.TestCase):
    """A paper's claims on a hand-made run (make: the run's writer, paper: its claims module)."""
    make, paper = None, None

    def setUp(self):
        self.dir = tempfile.mkdtemp(prefix="pb_claims_")
        type(self).make(self.dir)
        self.text = self.paper.claims(Run(self.dir))

    def tearDown(self):
        shutil.rmtree(self.dir)

    def row(self, *needles):
        for line in self.text.splitlines():
            if all(n in line for n in needles):
                return line
        self.fail(f"no line with {needles} in:\n{self.text}")

    def cells(self, *needles):
        return [c.strip() for c in self.row(*needles).split("|")[1:-1]]


class ClaimsPaper1Test(ClaimsCase):
    make, paper = make_run, paper1

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



def make_paper2_run(root):
    """Three walker cells, one per reuse variant, over frames 0, 1, 245 and 250 (the last two inside the
    window around frame 250): the baseline traces 100 rays every frame; naive 100, 20, 10, 0 and
    error_based 100, 10, 5, 0 (the figure stands still in the last frame), 5 of error_based's 10 rays in
    frame 1 visibility rays; every frame's paths hold 100 segments. photon-trace takes 1 ms + 0.1 ms a
    ray; naive's dynamic-occlusion 0.5 ms, error_based's 2 ms (after the first frame, which traces all)."""
    frames = [0, 1, 245, 250]
    rays = {"none": [100, 100, 100, 100], "naive": [100, 20, 10, 0], "error_based": [100, 10, 5, 0]}
    segments = {"none": rays["none"], "naive": rays["naive"], "error_based": [100, 5, 5, 0]}
    occlusion_ms = {"none": None, "naive": 0.5, "error_based": 2.0}
    header = ["cell", "scene", "technique", "status", "param.photons", "param.reuse"]
    rows = []
    for reuse, per_frame in rays.items():
        cid = f"walker__pv__{reuse}"
        rows.append([cid, "walker", "path-verification", "ok", "1000", reuse])
        d = os.path.join(root, "cells", cid)
        os.makedirs(d)
        timing = [[f, "photon-trace", 1 + r / 10, 0.1] for f, r in zip(frames, per_frame)]
        if occlusion_ms[reuse] is not None:
            timing += [[f, "dynamic-occlusion", occlusion_ms[reuse], 0.1] for f in frames[1:]]
        write_csv(os.path.join(d, "frames.csv"), ["frame", "pass", "gpu_ms", "cpu_ms"], timing)
        write_csv(os.path.join(d, "counters.csv"), ["frame", "name", "value"],
                  [[f, n, v] for f, r, seg in zip(frames, per_frame, segments[reuse])
                   for n, v in (("rays_traced", r), ("segments_retraced", seg), ("paths_kept", 100 - r),
                                ("full_retrace_rays", 100))])
        relmse = {"none": 0.04, "naive": 0.042, "error_based": 0.044}[reuse]
        write_csv(os.path.join(d, "metrics.csv"),
                  ["frame", "path_class", "reference", "relmse", "relmse_floor", "flicker", "flicker_floor"],
                  [[0, "indirect", "full", relmse, 0.004, "", ""],
                   [1, "indirect", "full", relmse, 0.004, 0.1 if reuse == "none" else 0.05, 0.01]])
        with open(os.path.join(d, "cell.json"), "w") as f:
            json.dump({"status": "ok"}, f)
    write_csv(os.path.join(root, "summary.csv"), header, rows)
    with open(os.path.join(root, "run.json"), "w") as f:
        json.dump({"config": "resolution: [160, 90]\n", "overrides": [], "device": "test"}, f)


class ClaimsPaper2Test(ClaimsCase):
    """Paper II's tables: ratios of means over the frames after the first, with the largest per-frame
    ratio (frames where the variant traced anything); the light-transport time (every reuse step and the
    re-trace) as the headline, trace time alone beside it; the per-frame rays of every variant;
    error-based against naive in rays reused and rays traced, over the whole run and near frame 250;
    the errors and flicker against the baseline with their floors."""
    make, paper = make_paper2_run, paper2

    def test_baseline_over_variant_rays_is_a_ratio_of_means_with_the_peak(self):
        # naive: 300 / 30 rays over frames 1, 245, 250 (per frame 5x and 10x; 250 traced nothing).
        self.assertEqual(self.cells("| walker |", "| naive |", "up to 5×")[3], "10.00× (10.00×)")
        self.assertEqual(self.cells("| walker |", "| error_based |", "up to 5×")[3], "20.00× (20.00×)")

    def test_light_transport_time_counts_the_reuse_steps_beside_trace_time_alone(self):
        # baseline 3 x 11 ms; naive photon-trace 3 + 2 + 1 ms and dynamic-occlusion 3 x 0.5 ms.
        naive = self.cells("| walker |", "| naive |", "up to 5×")
        self.assertEqual(naive[5:7], ["4.40× (7.33×)", "5.50× (11.00×)"])
        # error_based: photon-trace 2 + 1.5 + 1 ms and dynamic-occlusion 3 x 2 ms: 33 / 10.5.
        error = self.cells("| walker |", "| error_based |", "up to 5×")
        self.assertEqual(error[5:7], ["3.14× (3.67×)", "7.33× (11.00×)"])

    def test_fig7_rows_hold_every_variant_and_naive_over_error_based(self):
        self.assertEqual(self.cells("| walker |", "| 0 | 100 |")[3:], ["100", "100", "100", "1.00×"])
        self.assertEqual(self.cells("| walker |", "| 250 | 100 |")[3:], ["100", "0", "0", "–"])

    def test_error_based_against_naive_in_rays_reused_and_near_frame_250(self):
        c = self.cells("| walker |", "2× (armadillo")
        # reused: 100 segments a frame less those re-traced: error_based 95 + 95 + 100, naive 80 + 90 + 100.
        self.assertEqual(c[2], "1.07× (1.19×)")
        self.assertEqual(c[4], "2.00× (2.00×)")  # traced: 30 / 15
        self.assertEqual(c[5], "1")
        self.assertEqual(c[6], "2.00× (2.00×)")  # frames 245 and 250: 10 / 5

    def test_errors_and_flicker_beside_their_floors_and_the_baseline(self):
        c = self.cells("| walker |", "| error_based |", "0.0440")
        self.assertEqual(c[3:6], ["0.0440", "0.0040", "1.100"])
        self.assertEqual(c[9:12], ["0.0500", "0.0100", "0.500"])


def make_aaps_run(root):
    """cornell-glass, A_t 19 and 2 for none, all and all_per_sample: known FLIP, floors, flicker, frame
    times and counters (one frame each)."""
    # (msaa, A_t) -> (flip, flicker, ms, noncontributing share, energy)
    cells = {("none", 19): (0.30, 0.10, 10, 0.30, 100), ("none", 2): (0.35, 0.20, 20, 0.60, 80),
             ("all", 2): (0.36, 0.15, 30, 0.65, 24), ("all_per_sample", 2): (0.32, 0.12, 40, 0.10, 95)}
    header = ["cell", "scene", "technique", "status", "param.msaa", "param.target_area",
              "pass.photon-trace.ms_median", "pass.rasterize.ms_median",
              "pass.task-update/quadtree.ms_median"]
    rows = []
    for (msaa, area), (flip, flicker, ms, share, energy) in cells.items():
        cid = f"cornell-glass__aaps__{msaa}_{area}"
        rows.append([cid, "cornell-glass", "aaps", "ok", msaa, str(area), ms / 2, ms / 2, ms / 10])
        d = os.path.join(root, "cells", cid)
        os.makedirs(d)
        write_csv(os.path.join(d, "frames.csv"), ["frame", "pass", "gpu_ms", "cpu_ms"],
                  [[12, "photon-trace", ms / 2, 0.1], [12, "rasterize", ms / 2, 0.1]])
        write_csv(os.path.join(d, "counters.csv"), ["frame", "name", "value"],
                  [[12, "noncontributing_share", share], [12, "caustic_energy", energy]])
        write_csv(os.path.join(d, "metrics.csv"),
                  ["frame", "path_class", "reference", "flip", "flip_floor", "rmse", "flicker", "flicker_floor"],
                  [[12, "caustics", "full", flip, 0.05, 0.01, "", ""],
                   [13, "caustics", "full", flip, 0.05, 0.01, flicker, 0.02]])
        with open(os.path.join(d, "cell.json"), "w") as f:
            json.dump({"status": "ok"}, f)
    write_csv(os.path.join(root, "summary.csv"), header, rows)
    with open(os.path.join(root, "run.json"), "w") as f:
        json.dump({"config": "resolution: [320, 160]\n", "overrides": [], "device": "test"}, f)


class ClaimsAapsTest(ClaimsCase):
    """AAPS's table (FLIP with its floor, flicker with its floor, time, counters) and the trends at the
    smallest target area: all's energy against none's, per-sample's cut of the non-contributing share
    and its cost, flicker per mode."""
    make, paper = make_aaps_run, aaps

    def test_table_rows_carry_floors_and_flicker(self):
        self.assertEqual(self.cells("| cornell-glass | all_per_sample | 2 |")[3:9],
                         ["0.32", "0.05", "0.01", "0.12", "0.02", "40"])

    def test_trends_at_the_smallest_target_area(self):
        self.assertIn("energy x0.3 of none", self.row("`all` at A_t = 2"))
        self.assertIn("): non-contributing /6, time x2", self.row("`all_per_sample` at A_t = 2"))
        self.assertIn("none 0.2, all 0.15, all_per_sample 0.12", self.row("flicker at A_t = 2"))

    def test_per_pass_times_at_the_smallest_target_area(self):
        self.assertIn("| photon-trace | rasterize | task-update/quadtree |",
                      self.row("| scene | msaa | A_t (px²) |", "photon-trace"))
        self.assertEqual(self.cells("| cornell-glass | all_per_sample | 2 |", "| 4 |")[3:], ["20", "20", "4"])
        self.assertNotIn("| cornell-glass | none | 19 | 5 |", self.text)  # only the smallest A_t

    def test_quality_against_target_area_needs_three_areas(self):
        self.assertNotIn("quality vs target area", self.text)

MATCH_HEADER = ["scene", "technique", "at", "target", "tolerance", "knob", "knob_value", "status", "probes",
                "cell", "wall_ms_median", "wall_ms_p5", "wall_ms_p95", "wall_ms_n", "rounds",
                "probe_wall_ms_median", "flip", "flip_floor", "seeds", "flip_seed_sd", "reason"]
PROBE_HEADER = ["scene", "technique", "knob", "role", "index", "knob_value", "cell", "status",
                "wall_ms_median", "wall_ms_p5", "wall_ms_p95", "flip", "flip_floor"]


def make_match_run(root, scene, default_technique, knob, target, matches, at="time"):
    """A matched run (match.csv, match_probes.csv, summary.csv and the cells' frames.csv) of one scene.
    `matches`: one dict per match.csv row: its technique (default_technique if absent), params (the found cell's), status, knob_value, ms
    (median, p5, p95), flip and floor, reason, and per-pass frame times {pass: [ms per frame]} of the
    found probe ("probe") and of each re-measurement round ("rounds": a list of such dicts), the found
    cell's scores per path class ("classes": {class: (flip, floor)}) and its seed cells' ("seeds": a
    list of such dicts); the claims must read the rounds' frames, not the probe's."""
    names = sorted({k for m in matches for k in m["params"]})
    header = ["cell", "scene", "technique", "status"] + [f"param.{n}" for n in names]
    summary, match_rows, probes = [], [], []
    for i, m in enumerate(matches):
        technique = m.get("technique", default_technique)
        # With seeds the found cell is seed 1 of its group, its seed cells the group's others (the run's ids).
        group = f"{scene}__{technique}__{i}"
        found = group + ("__seed1" if m.get("seeds") else "")
        cells = [(found, m.get("probe", {}), "probe", m.get("classes", {}))]
        cells += [(f"{found}__round{r + 1}", passes, "round", {})
                  for r, passes in enumerate(m.get("rounds", []))]
        cells += [(f"{group}__seed{s + 2}", {}, "seed", classes) for s, classes in enumerate(m.get("seeds", []))]
        for cid, passes, role, classes in cells:
            summary.append([cid, scene, technique, "ok"] + [m["params"].get(n, "") for n in names])
            d = os.path.join(root, "cells", cid)
            os.makedirs(d)
            write_csv(os.path.join(d, "frames.csv"), ["frame", "pass", "gpu_ms", "cpu_ms"],
                      [[f, p, ms, 0.1] for p, series in passes.items() for f, ms in enumerate(series)])
            write_csv(os.path.join(d, "metrics.csv"), ["frame", "path_class", "reference", "flip", "flip_floor"],
                      [[0, cls, "full", flip, floor] for cls, (flip, floor) in classes.items()])
            with open(os.path.join(d, "cell.json"), "w") as f:
                json.dump({"status": "ok", "seed_group": group if m.get("seeds") else cid}, f)
            probes.append({"scene": scene, "technique": technique, "knob": knob, "role": role, "index": "0",
                           "knob_value": m["knob_value"], "cell": cid, "status": "ok",
                           "wall_ms_median": m["ms"][0], "wall_ms_p5": "", "wall_ms_p95": "",
                           "flip": m["flip"], "flip_floor": m["floor"]})
        ms, p5, p95 = m["ms"]
        match_rows.append({"scene": scene, "technique": technique, "at": at, "target": str(target),
                           "tolerance": "0.1", "knob": knob, "knob_value": m["knob_value"],
                           "status": m["status"], "probes": "4", "cell": found, "wall_ms_median": ms,
                           "wall_ms_p5": p5, "wall_ms_p95": p95, "wall_ms_n": "10", "rounds": "2",
                           "probe_wall_ms_median": ms, "flip": m["flip"], "flip_floor": m["floor"], "seeds": "1",
                           "flip_seed_sd": "", "reason": m.get("reason", "")})
    write_csv(os.path.join(root, "summary.csv"), header, summary)
    for name, fields, rows in (("match.csv", MATCH_HEADER, match_rows),
                               ("match_probes.csv", PROBE_HEADER, probes)):
        with open(os.path.join(root, name), "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=fields)
            w.writeheader()
            w.writerows(rows)
    with open(os.path.join(root, "run.json"), "w") as f:
        json.dump({"config": "resolution: [160, 90]\n", "overrides": [], "device": "test"}, f)


def rewrite_match(root, changes):
    """match.csv with row i's fields updated from changes[i]."""
    path = os.path.join(root, "match.csv")
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    for i, fields in changes.items():
        rows[i].update(fields)
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=MATCH_HEADER)
        w.writeheader()
        w.writerows(rows)


# The probe's own frames: far from the rounds', so a claim that read them would show it.
PROBE_FRAMES = {"photon-trace": [900, 900], "splat": [900, 900], "rasterize": [900, 900]}


def make_paper2_match_run(root):
    """villa at 300 ms a frame: the baseline found 3000 paths, error_based 5000 (5/3 the paths, as Fig. 1);
    naive was unreachable. Rounds: the baseline's light transport (photon-trace) 170, 180 | 178, 190 ms a
    frame (median 179), splatting (splat + radiance-estimate) 100 + 40 a frame; error_based's
    dynamic-occlusion 20 and photon-trace 60, 62 | 58, 70 (sums 80, 82, 78, 90: median 81), splat 200 +
    36."""
    make_match_run(root, "villa", "path-verification", "photons", 300, [
        {"params": {"reuse": "none"}, "status": "matched", "knob_value": "3000", "ms": ("300", "290", "310"),
         "flip": "0.30", "floor": "0.02", "probe": PROBE_FRAMES,
         "rounds": [{"photon-trace": [170, 180], "splat": [100, 100], "radiance-estimate": [40, 40]},
                    {"photon-trace": [178, 190], "splat": [100, 100], "radiance-estimate": [40, 40]}]},
        {"params": {"reuse": "error_based"}, "status": "matched", "knob_value": "5000",
         "ms": ("305", "295", "318"), "flip": "0.20", "floor": "0.02", "probe": PROBE_FRAMES,
         "rounds": [{"dynamic-occlusion": [20, 20], "photon-trace": [60, 62], "splat": [200, 200],
                     "radiance-estimate": [36, 36]},
                    {"dynamic-occlusion": [20, 20], "photon-trace": [58, 70], "splat": [200, 200],
                     "radiance-estimate": [36, 36]}]},
        {"params": {"reuse": "naive"}, "status": "unreachable", "knob_value": "256000",
         "ms": ("120", "110", "130"), "flip": "0.25", "floor": "0.02",
         "reason": "the probes reached 80 to 120 ms"}])


class ClaimsPaper2EqualTimeTest(ClaimsCase):
    """Fig. 1 from a matched run: the paths each variant affords at one frame time (the paper's quantity),
    the light-transport and splat times over the rounds' frames, equal time held by the spreads, the FLIP
    order beside its floors, and an unmatched variant named with its reason."""
    make, paper = make_paper2_match_run, paper2

    def test_table_reads_the_rounds_frames(self):
        self.assertEqual(self.cells("| villa | none | matched |")[3:],
                         ["3000", "4", "300 [290, 310]", "179.0", "140.0", "0.3 (floor 0.02)"])
        self.assertEqual(self.cells("| villa | error_based | matched |")[6:8], ["81.0", "236.0"])

    def test_paths_at_equal_time_beside_the_paper(self):
        line = self.row("* villa, error_based against the baseline")
        self.assertIn("1.67× the paths (5000 / 3000; paper 1.67× (5M / 3M, villa); resolved: the tolerances "
                      "alone allow 0.82-1.22× with time proportional to paths)", line)
        self.assertIn("equal time held", line)
        self.assertIn("light transport 81.0 / 179.0 ms, splatting 236.0 / 140.0 ms", line)
        self.assertIn("error_based 0.2 (floor 0.02) is better than none 0.3 (floor 0.02): resolved", line)

    def test_a_paths_ratio_within_the_tolerances_is_unresolved(self):
        rewrite_match(self.dir, {1: {"knob_value": "3600"}})  # 1.2x, inside (1 + 0.1) / (1 - 0.1) = 1.22x
        line = [l for l in paper2.claims(Run(self.dir)).splitlines() if l.startswith("* villa, error_based")][0]
        self.assertIn("1.20× the paths (3600 / 3000; paper 1.67× (5M / 3M, villa); unresolved:", line)

    def test_an_unmatched_variant_is_named_with_its_reason(self):
        self.assertIn("naive unreachable (the probes reached 80 to 120 ms)",
                      self.row("* villa, naive against the baseline: no comparison"))

    def test_scores_within_the_floors_leave_the_order_unresolved_and_apart_times_are_not_equal_time(self):
        rewrite_match(self.dir, {0: {"flip": "0.205", "flip_floor": "0.06", "wall_ms_p5": "320",
                                     "wall_ms_p95": "330", "wall_ms_median": "325"},
                                 1: {"flip": "0.20", "flip_floor": "0.06"}})
        line = [l for l in paper2.claims(Run(self.dir)).splitlines()
                if l.startswith("* villa, error_based")][0]
        self.assertIn("is better than none 0.205 (floor 0.06): unresolved", line)
        self.assertIn("equal time not held", line)


def make_paper1_match_run(root, at="time"):
    """cornell-box, tiled, cluster-trivial and directional matched (at equal time: FLIP 0.30, 0.20, 0.25,
    floors 0.02; at equal quality the same rows with at = quality and FLIP 0.15). The rounds' splat +
    estimate + build: tiled 60, cluster-trivial 30, directional 10 ms a frame."""
    flips = {"time": ("0.30", "0.20", "0.25"), "quality": ("0.15", "0.15", "0.15")}[at]
    make_match_run(root, "cornell-box", "tiled", "photons", 300 if at == "time" else 0.15, [
        {"params": {}, "status": "matched", "knob_value": "4000", "ms": ("300", "290", "310"),
         "flip": flips[0], "floor": "0.02", "probe": PROBE_FRAMES,
         "rounds": [{"tile-bounds": [5, 5], "splat": [15, 15], "radiance-estimate": [40, 40]}]},
        {"technique": "cluster", "params": {"variant": "trivial"}, "status": "matched", "knob_value": "9000",
         "ms": ("150", "140", "160"), "flip": flips[1], "floor": "0.02", "probe": PROBE_FRAMES,
         "rounds": [{"cluster-build": [5, 5], "splat": [10, 10], "radiance-estimate": [15, 15]}]},
        {"technique": "directional", "params": {}, "status": "matched", "knob_value": "8000",
         "ms": ("148", "135", "170"), "flip": flips[2], "floor": "0.02", "probe": PROBE_FRAMES,
         "rounds": [{"cluster-build": [4, 4], "splat": [3, 3], "radiance-estimate": [1, 1], "blur": [2, 2]}]}],
        at=at)


class ClaimsPaper1EqualTimeTest(ClaimsCase):
    """Paper I makes no equal-time comparison: the claims say so and list the matched run's rows as what
    it did not measure, in the report's order with each order resolved or not; at equal quality, the
    paper's own time (splat + estimate + build) between the pairs it compares."""
    make, paper = make_paper1_match_run, paper1

    def test_equal_time_rows_in_flip_order_with_the_verdicts(self):
        self.assertIn("Paper I makes no equal-time or equal-cost comparison", self.text)
        table = [l for l in self.text.splitlines() if l.startswith("| cornell-box |") and "matched" in l]
        self.assertEqual([l.split("|")[2].strip() for l in table],
                         ["cluster-trivial", "directional", "tiled"])
        self.assertEqual(self.cells("| cornell-box | cluster-trivial | matched |")[3:],
                         ["9000", "150 [140, 160]", "30.0", "0.2 (floor 0.02)", "resolved against directional"])
        self.assertEqual(self.cells("| cornell-box | tiled | matched |")[5], "60.0")

    def test_equal_quality_gives_the_papers_time_ratios(self):
        shutil.rmtree(self.dir)
        os.makedirs(self.dir)
        make_paper1_match_run(self.dir, at="quality")
        with open(os.path.join(self.dir, "run.json"), "w") as f:
            json.dump({"config": "match: {at: quality, metric: flip, value: 0.15}\n", "overrides": []}, f)
        text = paper1.claims(Run(self.dir))
        self.assertIn("* cornell-box: tiled / cluster-trivial, splat + estimate + build at equal flip: 2.00×",
                      text)
        self.assertIn("* cornell-box: cluster-trivial / directional, splat + estimate + build at equal flip: "
                      "3.00×", text)
        # By time: directional 148 [135, 170] then cluster-trivial 150 [140, 160]: their spreads overlap.
        self.assertIn("unresolved against cluster-trivial", [l for l in text.splitlines()
                                                            if "| directional | matched |" in l][0])


class ClaimsWithoutAMatchTest(unittest.TestCase):
    """A run without match.csv: each paper's claims say whether it makes an equal-time comparison and
    that this run did not measure it."""

    def claims_text(self, make, paper):
        d = tempfile.mkdtemp(prefix="pb_claims_")
        try:
            make(d)
            return paper.claims(Run(d))
        finally:
            shutil.rmtree(d)

    def test_each_paper_says_what_it_compares_at_equal_time(self):
        text = self.claims_text(make_paper2_run, paper2)
        self.assertIn("Not measured: this run has no match.csv", text)
        self.assertIn("5/3 = 1.67× the paths", text)
        text = self.claims_text(make_aaps_run, aaps)
        self.assertIn("Not measured: this run has no match.csv", text)
        text = self.claims_text(make_run, paper1)
        self.assertIn("Paper I makes no equal-time or equal-cost comparison", text)


def make_aaps_match_run(root, caustics=(("0.30", "0.02"), ("0.25", "0.02"), ("0.29", "0.02")), seeds=()):
    """cornell-glass at 60 ms a frame: none at A_t 19, small_per_sample at 24, all_per_sample at 40; the
    combined image's FLIP in match.csv 0.45 for each (the indirect light AAPS does not render), the
    caustics class's `caustics` (flip, floor) per mode (none, small_per_sample, all_per_sample), and
    `seeds`: the modes' caustics FLIP at further seeds. AAPS's passes in the rounds: none photon-trace
    10 + rasterize 12 a frame, small_per_sample 8 + 15 + 1 (resolve)."""
    modes = [("none", "19", ("60", "57", "63"), {"photon-trace": [10, 10], "rasterize": [12, 12]}),
             ("small_per_sample", "24", ("61", "58", "64"),
              {"photon-trace": [8, 8], "rasterize": [15, 15], "resolve": [1, 1]}),
             ("all_per_sample", "40", ("59", "56", "62"),
              {"photon-trace": [6, 6], "rasterize": [17, 17], "resolve": [1, 1]})]
    make_match_run(root, "cornell-glass", "aaps", "target_area", 60, [
        {"params": {"msaa": msaa}, "status": "matched", "knob_value": area, "ms": ms, "flip": "0.45",
         "floor": "0.02", "probe": PROBE_FRAMES, "rounds": [dict(passes, gbuffer=[30, 30])],
         "classes": {"combined": ("0.45", "0.02"), "caustics": caustic},
         "seeds": [{"caustics": (seed[i], caustic[1])} for seed in seeds]}
        for i, ((msaa, area, ms, passes), caustic) in enumerate(zip(modes, caustics))])


class ClaimsAapsEqualTimeTest(ClaimsCase):
    """Figs. 40 and 43 at one budget: each mode's target area and FLIP at one frame time, AAPS's own time
    (the thesis's axis) over the rounds' frames, and the order against none with the thesis's
    break-even beside it."""
    make, paper = make_aaps_match_run, aaps

    def test_table_has_the_target_area_found_and_aaps_time(self):
        self.assertEqual(self.cells("| cornell-glass | small_per_sample | matched |")[3:],
                         ["24", "4", "61 [58, 64]", "24", "0.25 (floor 0.02)", "0.45 (floor 0.02)"])

    def test_small_per_sample_beats_none_at_this_budget_in_the_caustics_class_resolved(self):
        line = self.row("* cornell-glass, small_per_sample against none at 60 ms")
        self.assertIn("AAPS 24 / 22 ms", line)
        self.assertIn("small_per_sample 0.25 (floor 0.02) is better than none 0.3 (floor 0.02): resolved",
                      line)
        self.assertIn("thesis: small_per_sample beats none above 3 ms", line)

    def claims_of(self, **fixture):
        shutil.rmtree(self.dir)
        os.makedirs(self.dir)
        make_aaps_match_run(self.dir, **fixture)
        return aaps.claims(Run(self.dir))

    def test_a_difference_within_the_floors_is_unresolved(self):
        text = self.claims_of(caustics=(("0.20", "0.06"), ("0.25", "0.02"), ("0.205", "0.06")))
        line = [l for l in text.splitlines() if l.startswith("* cornell-glass, all_per_sample")][0]
        self.assertIn("none 0.2 (floor 0.06) is better than all_per_sample 0.205 (floor 0.06): unresolved",
                      line)

    def test_the_seeds_spread_in_the_caustics_class_can_leave_the_order_unresolved(self):
        # small_per_sample 0.25, 0.35 across seeds (sd 0.071), none 0.30, 0.30: 0.05 apart < 2 x 0.071.
        text = self.claims_of(seeds=(("0.30", "0.35", "0.29"),))
        line = [l for l in text.splitlines() if l.startswith("* cornell-glass, small_per_sample")][0]
        self.assertIn("small_per_sample 0.25 (floor 0.02) ±0.071 over seeds is better than none 0.3 (floor "
                      "0.02) ±0 over seeds: unresolved", line)


if __name__ == "__main__":
    unittest.main()
