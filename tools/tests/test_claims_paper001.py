"""photonbench claims --paper 001 (seed 001, Larsen 2004): the lag after a scripted event, on hand-made
runs whose answers are known: a FLIP series that falls from a high value to a plateau at a chosen frame,
with the plateau's noise and the floor chosen so that the band, and so the settled frame, can be worked
out by hand."""

import csv
import json
import os
import shutil
import tempfile
import unittest

import numpy as np

import common  # noqa: F401  (import paths for pbtools)
from pbtools.claims import paper001
from pbtools.rundata import Run


def write_csv(path, header, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)


def make_run(root, cells):
    """cells: [(scene, technique, {frame: flip}, floor, {counter: per-frame value})]."""
    rows = []
    for i, (scene, technique, flips, floor, counters) in enumerate(cells):
        cid = f"{scene}__{technique}__{i:02d}"
        rows.append([cid, scene, technique, "ok"])
        d = os.path.join(root, "cells", cid)
        os.makedirs(d)
        frames = sorted(flips)
        write_csv(os.path.join(d, "frames.csv"), ["frame", "pass", "gpu_ms", "cpu_ms"],
                  [[f, "frame", "", 10.0] for f in frames])
        write_csv(os.path.join(d, "metrics.csv"), ["frame", "path_class", "reference", "flip", "flip_floor"],
                  [[f, "indirect", "full", flips[f], floor] for f in frames])
        write_csv(os.path.join(d, "counters.csv"), ["frame", "name", "value"],
                  [[f, n, v] for n, v in counters.items() for f in frames])
        with open(os.path.join(d, "cell.json"), "w") as fh:
            json.dump({"status": "ok"}, fh)
    write_csv(os.path.join(root, "summary.csv"), ["cell", "scene", "technique", "status"], rows)
    with open(os.path.join(root, "run.json"), "w") as f:
        json.dump({"config": "name: paper001\n", "overrides": [], "device": "test"}, f)


def falling(first, last, settle_at, high, plateau, noise):
    """FLIP `high` until the event, a linear fall to `plateau` reached at frame settle_at, then the
    plateau with alternating +-noise."""
    out = {}
    for f in range(first, last + 1):
        if f <= 60:
            out[f] = high
        elif f < settle_at:
            out[f] = high + (plateau - high) * (f - 60) / (settle_at - 60)
        else:
            out[f] = plateau + (noise if f % 2 else -noise)
    return out


def make_gather_run(root, cells):
    """cells: [(scene, {param: value}, gather ms at frame 0, texels gathered, flip)]."""
    params = sorted({k for _, p, _, _, _ in cells for k in p})
    rows = []
    for i, (scene, p, ms, texels, flip) in enumerate(cells):
        cid = f"{scene}__illumination-maps__{i:02d}"
        rows.append([cid, scene, "illumination-maps", "ok"] + [p.get(k, "") for k in params])
        d = os.path.join(root, "cells", cid)
        os.makedirs(d)
        write_csv(os.path.join(d, "frames.csv"), ["frame", "pass", "gpu_ms", "cpu_ms", "process_cpu_ms"],
                  [[0, "gather", "", ms, ms / 2], [0, "frame", "", ms + 5, ms]])
        write_csv(os.path.join(d, "counters.csv"), ["frame", "name", "value"], [[0, "texels_gathered", texels]])
        write_csv(os.path.join(d, "metrics.csv"), ["frame", "path_class", "reference", "flip", "flip_floor"],
                  [[0, "indirect", "full", flip, 0.02]])
        with open(os.path.join(d, "cell.json"), "w") as fh:
            json.dump({"status": "ok"}, fh)
    write_csv(os.path.join(root, "summary.csv"),
              ["cell", "scene", "technique", "status"] + [f"param.{k}" for k in params], rows)
    with open(os.path.join(root, "run.json"), "w") as f:
        json.dump({"config": "name: paper001\n", "overrides": [], "device": "test"}, f)


class Paper001GatherTest(unittest.TestCase):
    def test_time_per_texel_is_the_median_over_rounds_with_the_rays_ratio(self):
        # Three rounds each: the hemi-plane at 16 px takes 20, 40, 30 ms for 100 texels (0.2, 0.4, 0.3 ms
        # a texel: median 0.3), the rays 60, 100, 80 (median 0.8): rays / hemi-plane 2.67x. Fig. 14.4's
        # 50-texel cell is not Table 14.2's.
        raster = {"gather": "raster", "hemi_size": 16}
        rays = {"gather": "rays"}
        cells = [("cornell-bumpy-13k", raster, ms, 100, 0.3) for ms in (20, 40, 30)]
        cells += [("cornell-bumpy-13k", rays, ms, 100, 0.3) for ms in (60, 100, 80)]
        cells += [("cornell-box", {"gather": "rays", "aim_texels": 5}, 10, 100, 0.25),
                  ("cornell-box", {"gather": "rays", "aim_texels": 50}, 900, 3000, 0.12)]
        d = tempfile.mkdtemp(prefix="pb_claims001_")
        self.addCleanup(shutil.rmtree, d)
        make_gather_run(d, cells)
        text = paper001.claims(Run(d))
        row = Paper001LagTest.row(self, text, "| cornell-bumpy-13k (12,832) | hemi-plane 16 px, 8bit |")
        self.assertEqual(row[2], "0.300")
        self.assertEqual(row[3], "0.200, 0.400, 0.300")
        self.assertEqual(row[4], "0.150")  # process CPU: half the wall time here
        self.assertEqual(row[5], "2.67×")
        self.assertEqual(row[6], "0.91 (16, 13,000)")  # the thesis's row for that size and scene
        self.assertEqual(Paper001LagTest.row(self, text, "| cornell-bumpy-13k (12,832) | rays, 1024 |")[2], "0.800")
        self.assertEqual(Paper001LagTest.row(self, text, "| cornell-box | rays, 1024 | 50 |")[3], "0.120")
        self.assertEqual(Paper001LagTest.row(self, text, "| cornell-box | rays, 1024 | 5 |")[3], "0.250")
        # Only a sweep of aim_texels is Fig. 14.4's: the 13k scene's cells, all at 5, are not.
        self.assertNotIn("| cornell-bumpy-13k | rays, 1024 | 5 |", text)
        # Table 14.2 holds the default resolution only: 0.1 ms a texel, not the median with 50's 0.3.
        self.assertEqual(Paper001LagTest.row(self, text, "| cornell-box (34) | rays, 1024 |")[2], "0.100")


class Paper001LagTest(unittest.TestCase):
    def claims(self, cells):
        d = tempfile.mkdtemp(prefix="pb_claims001_")
        self.addCleanup(shutil.rmtree, d)
        make_run(d, cells)
        return paper001.claims(Run(d))

    def row(self, text, *needles):
        for line in text.splitlines():
            if all(n in line for n in needles):
                return [c.strip() for c in line.split("|")[1:-1]]
        self.fail(f"no line with {needles} in:\n{text}")

    def test_lag_is_the_frames_until_the_series_stays_in_the_band(self):
        # two-rooms' lights go out at frame 60; the cache's FLIP falls from 0.5 and reaches the plateau
        # 0.2 at frame 80; the plateau's noise (+-0.002) is under the floor 0.01, so the band is the floor;
        # the fall enters it at frame 80 - 20 x 0.01 / 0.3 = 79.33, so frame 80 is the first inside.
        text = self.claims([("two-rooms", "slow-cache", falling(56, 147, 80, 0.5, 0.2, 0.002), 0.01,
                             {"paths_retraced": 3, "rays_traced": 100}),
                            ("two-rooms", "fast-cache", falling(56, 147, 64, 0.5, 0.2, 0.002), 0.01,
                             {"paths_retraced": 40, "selective_rays": 900})])
        slow = self.row(text, "`slow-cache`")
        self.assertEqual(slow[7], "20")  # lag, frames
        self.assertEqual(slow[8], "0.67")  # s at 30 fps
        self.assertEqual(slow[5], "0.200")  # settled
        self.assertEqual(slow[6], "0.010")  # band: the floor
        self.assertEqual(slow[9], "63")  # 3 paths a frame over frames 60..80
        self.assertEqual(slow[10], "2,100")
        fast = self.row(text, "`fast-cache`")
        self.assertEqual(fast[7], "4")
        self.assertEqual(fast[9], "200")  # 40 x frames 60..64
        self.assertEqual(fast[10], "4,500")  # selective emission's rays, 900 x 5 frames

    def test_noise_above_the_floor_widens_the_band(self):
        # Plateau noise +-0.05 over the window's last 22 frames: its standard deviation about the fitted
        # line is 0.05 x sqrt(22 / 20) = 0.0524 (two fitted parameters), the band 3 x that = 0.157, which
        # swamps the floor 0.01. The fall from 0.5 to 0.2 (0.015 a frame) enters it when
        # 0.3 - 0.015 k <= 0.157, k = 9.5: frame 70, lag 10.
        text = self.claims([("two-rooms", "noisy", falling(56, 147, 80, 0.5, 0.2, 0.05), 0.01, {})])
        row = self.row(text, "`noisy`")
        self.assertEqual(row[6], "0.157")
        self.assertEqual(row[7], "10")
        self.assertEqual(row[9], "–")  # no counters: no work figure

    def test_a_series_still_falling_at_the_end_is_not_settled(self):
        flips = {f: 0.5 - 0.004 * max(0, f - 60) for f in range(56, 148)}  # falls to the last frame
        text = self.claims([("two-rooms", "drifting", flips, 0.01, {})])
        self.assertEqual(self.row(text, "`drifting`")[7], "not settled")
        # A drift whose last quarter stays within the band of its mean (0.0007 a frame over its 21
        # frames: 0.0074 either side, under the floor 0.01) but moves its fitted line by more than the
        # band (0.0147): still not settled.
        slow = {f: 0.5 - 0.0007 * max(0, f - 60) for f in range(56, 148)}
        text = self.claims([("two-rooms", "creeping", slow, 0.01, {})])
        self.assertEqual(self.row(text, "`creeping`")[7], "not settled")

    def test_walker_windows_end_at_the_next_event(self):
        # Two events, 90 and 300: the first window is frames 90..299, the second 300..359; a step down at
        # 100 and one at 310 each settle within their own window (a first window running on to the end
        # would settle to the second window's level instead).
        flips = {f: (0.4 if f < 100 else 0.1) if f < 300 else (0.8 if f < 310 else 0.6)
                 for f in range(80, 360)}
        text = self.claims([("walker", "cache", flips, 0.01, {})])
        self.assertEqual(self.row(text, "the figure stops at the stand")[7], "10")
        self.assertEqual(self.row(text, "the figure stops at the door")[7], "10")

    def test_a_run_without_event_scenes_is_refused(self):
        d = tempfile.mkdtemp(prefix="pb_claims001_")
        self.addCleanup(shutil.rmtree, d)
        make_run(d, [("cornell-box", "direct", {0: 0.1}, 0.01, {})])
        with self.assertRaises(paper001.MissingCells):
            paper001.claims(Run(d))


if __name__ == "__main__":
    unittest.main()
