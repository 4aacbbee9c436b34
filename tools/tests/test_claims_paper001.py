"""photonbench claims --paper 001 (seed 001, Larsen 2004): the lag after a scripted event, on hand-made
runs whose answers are known: a FLIP series that falls from a high value to a plateau at a chosen frame,
with the plateau's noise and the floor chosen so that the band, and so the settled frame, can be worked
out by hand."""

import csv
import json
import os
import shutil
import struct
import tempfile
import unittest

import numpy as np

import common  # noqa: F401  (import paths for pbtools)
from fixture import write_exr
from pbtools.claims import paper001
from pbtools.rundata import Run


def write_csv(path, header, rows):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)


def make_run(root, cells):
    """cells: [(scene, technique, {frame: flip}, floor, {counter: per-frame value, or {frame: value}}
    [, {param: value}])]."""
    params = sorted({k for c in cells if len(c) > 5 for k in c[5]})
    rows = []
    for i, (scene, technique, flips, floor, counters, *rest) in enumerate(cells):
        cid = f"{scene}__{technique}__{i:02d}"
        rows.append([cid, scene, technique, "ok"] + [(rest[0] if rest else {}).get(k, "") for k in params])
        d = os.path.join(root, "cells", cid)
        os.makedirs(d)
        frames = sorted(flips)
        write_csv(os.path.join(d, "frames.csv"), ["frame", "pass", "gpu_ms", "cpu_ms"],
                  [[f, "frame", "", 10.0] for f in frames])
        write_csv(os.path.join(d, "metrics.csv"), ["frame", "path_class", "reference", "flip", "flip_floor"],
                  [[f, "indirect", "full", flips[f], floor] for f in frames])
        write_csv(os.path.join(d, "counters.csv"), ["frame", "name", "value"],
                  [[f, n, v.get(f, 0) if isinstance(v, dict) else v] for n, v in counters.items() for f in frames])
        with open(os.path.join(d, "cell.json"), "w") as fh:
            json.dump({"status": "ok"}, fh)
    write_csv(os.path.join(root, "summary.csv"),
              ["cell", "scene", "technique", "status"] + [f"param.{k}" for k in params], rows)
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

    def test_a_change_within_the_band_is_not_a_lag_of_zero(self):
        # A fall of 0.005 at frame 62, under the floor 0.01: the series never leaves the band of its
        # settled value, so its lag of 0 says the change is not resolved, not that it was followed at
        # once; a fall of 0.05 is followed in 2 frames.
        small = {f: 0.2 if f < 62 else 0.195 for f in range(56, 148)}
        large = {f: 0.25 if f < 62 else 0.2 for f in range(56, 148)}
        text = self.claims([("two-rooms", "small", small, 0.01, {}), ("two-rooms", "large", large, 0.01, {})])
        self.assertEqual(self.row(text, "`small`")[7], "0 (never left the band)")
        self.assertEqual(self.row(text, "`large`")[7], "2")

    def test_walker_windows_end_at_the_next_event(self):
        # Two events, 90 and 300: the first window is frames 90..299, the second 300..359; a step down at
        # 100 and one at 310 each settle within their own window (a first window running on to the end
        # would settle to the second window's level instead).
        flips = {f: (0.4 if f < 100 else 0.1) if f < 300 else (0.8 if f < 310 else 0.6)
                 for f in range(80, 360)}
        text = self.claims([("walker", "cache", flips, 0.01, {})])
        self.assertEqual(self.row(text, "the figure stops at the stand")[7], "10")
        self.assertEqual(self.row(text, "the figure stops at the door")[7], "10")

    def test_retracing_is_the_frames_until_the_last_path_re_traced(self):
        # Lights out at frame 60, window 60..147: a cache probing a share of its paths re-traces until
        # frame 99 (40 frames from 60 on), one that follows at once stops after frame 60 (1), one that
        # re-traces every frame never stops in the window, one that re-traced only before the event is
        # 0, and a technique without the counter has no figure.
        series = falling(56, 147, 64, 0.5, 0.2, 0.002)
        text = self.claims([
            ("two-rooms", "probing", series, 0.01, {"paths_retraced": {f: 5 for f in range(56, 100)}}),
            ("two-rooms", "at-once", series, 0.01, {"paths_retraced": {f: 5 for f in range(56, 61)}}),
            ("two-rooms", "always", series, 0.01, {"paths_retraced": 3}),
            ("two-rooms", "before", series, 0.01, {"paths_retraced": {f: 5 for f in range(56, 60)}}),
            ("two-rooms", "fresh", series, 0.01, {})])
        self.assertEqual(self.row(text, "`probing`")[11], "40")
        self.assertEqual(self.row(text, "`at-once`")[11], "1")
        self.assertEqual(self.row(text, "`always`")[11], "still at the window's end")
        self.assertEqual(self.row(text, "`before`")[11], "0")
        self.assertEqual(self.row(text, "`fresh`")[11], "–")

    def test_an_event_outside_the_scored_frames_has_no_row(self):
        # walker scored over frames 86..141 only: the stop at the door (frame 300) has no row.
        flips = {f: 0.3 for f in range(86, 142)}
        text = self.claims([("walker", "cache", flips, 0.01, {})])
        self.row(text, "the figure stops at the stand")
        self.assertNotIn("the figure stops at the door", text)

    def test_a_run_without_event_scenes_is_refused(self):
        d = tempfile.mkdtemp(prefix="pb_claims001_")
        self.addCleanup(shutil.rmtree, d)
        make_run(d, [("cornell-box", "direct", {0: 0.1}, 0.01, {})])
        with self.assertRaises(paper001.MissingCells):
            paper001.claims(Run(d))

    def test_equal_rays_picks_the_sweeps_cell_nearest_in_rays_over_the_window(self):
        # The lights go out at frame 60; the window is frames 60..147 (88 frames). illumination-maps
        # traces 1,000 rays a frame (88,000 over the window) and settles at 80 (lag 20);
        # path-verification's sweep traces 500, 1,100 and 3,000 a frame (44,000, 96,800 and 264,000)
        # and settles at 64, 70 and 67. The nearest by ratio is 1,100 a frame (1.10 against 2.00 for
        # 500): its lag is 10, bracketed by the 500 cell's 4. Rays to the settled frame would pick the
        # 3,000 cell (8 frames x 3,000 = 24,000 against illumination-maps' 21 x 1,000, 1.14; the
        # 1,100 cell's 11 x 1,100 = 12,100 is 1.74 apart).
        cells = [("two-rooms", "illumination-maps", falling(56, 147, 80, 0.5, 0.2, 0.002), 0.01,
                  {"selective_rays": 1000}, {"photons": 20000})]
        for rays, settle_at, photons in ((500, 64, 5000), (1100, 70, 10000), (3000, 67, 20000)):
            cells.append(("two-rooms", "path-verification", falling(56, 147, settle_at, 0.5, 0.2, 0.002),
                          0.01, {"rays_traced": rays}, {"photons": photons}))
        text = self.claims(cells)
        row = self.row(text, "| two-rooms | the right room's lights go out | `illumination-maps` | 88,000 |")
        self.assertEqual(row[4], "20")
        self.assertEqual(row[5], "`path-verification` (photons 10000)")
        self.assertEqual(row[6], "96,800")
        self.assertEqual(row[7], "1.10")
        self.assertEqual(row[8], "10")
        self.assertEqual(row[9], "`path-verification` (photons 5000): 4 (44,000); "
                                 "`path-verification` (photons 10000): 10 (96,800)")
        # One cell of each technique: no sweep, no equal-rays table.
        self.assertNotIn("At equal rays", self.claims(cells[:2]))


def exr(rgb, written):
    """An uncompressed OpenEXR of `rgb` (fixture.write_exr) whose header also says when it was written
    (capDate, as the harness's writer records it)."""
    d = tempfile.mkdtemp(prefix="pb_exr_")
    try:
        write_exr(os.path.join(d, "x.exr"), rgb)
        with open(os.path.join(d, "x.exr"), "rb") as f:
            data = f.read()
    finally:
        shutil.rmtree(d)
    date = written.encode()
    attribute = b"capDate\0string\0" + struct.pack("<i", len(date)) + date
    return data[:8] + attribute + data[8:]


def make_culling_run(root, cells):
    """A run of screen-caustics cells: [(scene, grid, seed, {pass: [(gpu_ms, cpu_ms) per frame]},
    (cells_active, cells_skipped), {image name: bytes})]."""
    rows = []
    for i, (scene, grid, seed, passes, (active, skipped), images) in enumerate(cells):
        cid = f"{scene}__screen-caustics__{i:02d}"
        rows.append([cid, scene, "screen-caustics", "ok", seed, grid, "divide"])
        d = os.path.join(root, "cells", cid)
        os.makedirs(os.path.join(d, "images"))
        frames = range(8, 8 + len(next(iter(passes.values()))))
        write_csv(os.path.join(d, "frames.csv"), ["frame", "pass", "gpu_ms", "cpu_ms"],
                  [[f, name, gpu, cpu] for name, times in passes.items() for f, (gpu, cpu) in zip(frames, times)])
        write_csv(os.path.join(d, "counters.csv"), ["frame", "name", "value"],
                  [[f, n, v] for f in frames for n, v in (("cells_active", active), ("cells_skipped", skipped))])
        for name, data in images.items():
            with open(os.path.join(d, "images", name), "wb") as fh:
                fh.write(data)
        with open(os.path.join(d, "cell.json"), "w") as fh:
            json.dump({"status": "ok"}, fh)
    write_csv(os.path.join(root, "summary.csv"),
              ["cell", "scene", "technique", "status", "seed", "param.grid", "param.area_scaling"], rows)
    with open(os.path.join(root, "run.json"), "w") as f:
        json.dump({"config": "name: screen-caustics-culling\n", "overrides": [], "device": "test"}, f)


class Paper001ScreenCausticsTest(unittest.TestCase):
    def culling_text(self, images_culled=None, images_full=None, with_full=True):
        # ring, two rounds of three frames. 10 x 10: the filter 30, 34, 32 | 36, 38, 40 ms on the GPU
        # (pooled median 35, quartiles 32.5 and 37.5), the grid 0.1 GPU and 2.0 CPU (its read-back):
        # grid + filter, each pass on its larger clock, 32, 36, 34 | 38, 40, 42 (median 37, quartiles
        # 34.5 and 39.5). Full screen: the filter 50 | 54, the grid 0.1 GPU and 1.0 CPU: 51 | 55.
        # Culled / full: 37 / 53 = 0.70; per round 34 / 51 = 0.67 and 40 / 55 = 0.73.
        def passes(filters, grid_cpu):
            return {"grid": [(0.1, grid_cpu)] * len(filters), "filter": [(ms, 0.05) for ms in filters]}

        cells = [("ring", 10, 1, passes([30, 34, 32], 2.0), (58, 42), images_culled or {}),
                 ("ring", 10, 2, passes([36, 38, 40], 2.0), (58, 42), {})]
        if with_full:
            cells += [("ring", 1, 1, passes([50, 50, 50], 1.0), (1, 0), images_full or {}),
                      ("ring", 1, 2, passes([54, 54, 54], 1.0), (1, 0), {})]
        d = tempfile.mkdtemp(prefix="pb_claims001_")
        self.addCleanup(shutil.rmtree, d)
        make_culling_run(d, cells)
        return paper001.claims(Run(d))

    def test_culled_grid_against_the_full_screen(self):
        text = self.culling_text()
        row = Paper001LagTest.row(self, text, "| ring | 10 x 10 |")
        self.assertEqual(row[2:], ["2", "6", "58 of 100", "35.00 (32.50–37.50)", "0.10 (0.10–0.10)",
                                   "2.00 (2.00–2.00)", "37.00 (34.50–39.50)"])
        full = Paper001LagTest.row(self, text, "| ring | 1 (full screen) |")
        self.assertEqual(full[4], "1 of 1")
        self.assertEqual(full[8], "53.00 (51.00–55.00)")
        line = next(l for l in text.splitlines() if l.startswith("* ring, 10 x 10 against the full screen"))
        self.assertIn("culled / full, grid + filter (the pooled medians' ratio) 0.70; per round 0.67–0.73", line)
        self.assertIn("images: not recorded", line)

    def test_images_of_one_seed_compared(self):
        # Written a second apart (the header's capDate differs), with the same pixels or one pixel
        # apart; a PNG (not compared) differs throughout.
        dark, lit = np.zeros((2, 3, 3)), np.zeros((2, 3, 3))
        lit[1, 2] = 0.5
        culled = {"frame_0008_caustics.exr": exr(lit, "2026:12:07 03:49:53"),
                  "frame_0008.exr": exr(dark, "2026:12:07 03:49:53"), "frame_0008.png": b"a"}
        same = self.culling_text(culled, {"frame_0008_caustics.exr": exr(lit, "2026:12:07 03:49:54"),
                                          "frame_0008.exr": exr(dark, "2026:12:07 03:49:54"),
                                          "frame_0008.png": b"b"})
        self.assertIn("images: identical, pixel for pixel (2 images)", same)
        differ = self.culling_text(culled, {"frame_0008_caustics.exr": exr(dark, "2026:12:07 03:49:54"),
                                            "frame_0008.exr": exr(dark, "2026:12:07 03:49:54")})
        self.assertIn("images: differ: 1 of 2 images", differ)

    def test_no_full_screen_no_section(self):
        with self.assertRaises(paper001.MissingCells):
            self.culling_text(with_full=False)

    def match_text(self, aaps_caustics, aaps_floor, aaps_status="matched"):
        from test_claims import make_match_run
        d = tempfile.mkdtemp(prefix="pb_claims001_")
        self.addCleanup(shutil.rmtree, d)
        make_match_run(d, "cornell-glass", "screen-caustics", "photons", 200, [
            {"params": {}, "status": "matched", "knob_value": "10000", "ms": ("169.6", "97.4", "208.5"),
             "flip": "0.423", "floor": "0.098", "classes": {"caustics": (0.378, 0.098)}},
            {"technique": "aaps", "params": {}, "status": aaps_status, "knob_value": "6.72",
             "reason": "" if aaps_status == "matched" else "4 probes, none within 15% of the target",
             "ms": ("188.8", "114.5", "387.4"), "flip": "0.424", "floor": "0.098",
             "classes": {"caustics": (aaps_caustics, aaps_floor)}}])
        return paper001.claims(Run(d))

    def test_equal_time_beside_aaps(self):
        text = self.match_text(0.358, 0.098)
        sc = Paper001LagTest.row(self, text, "| cornell-glass | `screen-caustics` |")
        self.assertEqual(sc[2:], ["matched", "photons = 10000", "4", "169.6 [97.4, 208.5]",
                                  "0.378 (floor 0.098)", "0.423 (floor 0.098)"])
        aaps = Paper001LagTest.row(self, text, "| cornell-glass | `aaps` |")
        self.assertEqual(aaps[3], "photons = 6.72")  # the fixture names one knob for both
        self.assertEqual(aaps[6], "0.358 (floor 0.098)")
        # 0.020 apart against floors of 0.098: the order is the reference's noise as far as it tells.
        self.assertIn("* cornell-glass, caustics: `aaps` 0.358 against `screen-caustics` 0.378, a difference "
                      "of 0.020 beside the floors 0.098 / 0.098: not resolved.", text)
        self.assertIn("* cornell-glass, combined: `screen-caustics` 0.423 against `aaps` 0.424", text)
        # Far apart against small floors: resolved.
        text = self.match_text(0.100, 0.010)
        self.assertIn("* cornell-glass, caustics: `aaps` 0.100 against `screen-caustics` 0.378, a difference "
                      "of 0.278 beside the floors 0.010 / 0.098: resolved.", text)
        # A side that did not match holds no equal time: no order.
        text = self.match_text(0.100, 0.010, "not_converged")
        self.assertIn("| cornell-glass | `aaps` | not_converged |", text)
        self.assertIn("* cornell-glass: no comparison, aaps not_converged (4 probes, none within 15% of the "
                      "target).", text)
        self.assertNotIn("* cornell-glass, caustics:", text)


if __name__ == "__main__":
    unittest.main()
