"""Each figure's drawn data against the CSV it came from (read here with the csv module, independently
of the tools' own reader), plus the Pareto front and the failure/warning markers."""

import csv
import math
import os
import unittest

from common import TempRuns

from pbtools import figures as F
from pbtools import images as I
from pbtools import style
from pbtools.rundata import Run


def read_csv(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def by_gid(fig, gid):
    for ax in fig.axes:
        for artist in list(ax.lines) + list(ax.patches) + list(ax.texts) + list(ax.images):
            if artist.get_gid() == gid:
                return artist
    return None


def gids(fig, prefix):
    out = []
    for ax in fig.axes:
        for artist in list(ax.lines) + list(ax.patches) + list(ax.texts):
            g = artist.get_gid()
            if g and g.startswith(prefix):
                out.append(g)
    return out


class FigureDataTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.tmp = TempRuns()
        cls.run_dir = cls.tmp.make("run", seed=7)
        cls.rd = Run(cls.run_dir)
        cls.summary = read_csv(os.path.join(cls.run_dir, "summary.csv"))
        cls.styles = style.TechniqueStyle(cls.rd.techniques())

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_quality_vs_time_points_are_the_summary_values(self):
        for scene in ("cornell-box", "pillars"):
            fig = F.quality_vs_time(self.rd, scene, self.styles)
            for metric in ("flip", "ssim", "psnr"):
                for tech in ("direct", "tiled", "cluster"):
                    expected = sorted((float(r["wall_ms_median"]), float(r[f"{metric}_mean"]))
                                      for r in self.summary
                                      if r["scene"] == scene and r["technique"] == tech and r["status"] == "ok")
                    line = by_gid(fig.fig, f"points:{tech}:{metric}")
                    self.assertIsNotNone(line, (scene, tech, metric))
                    drawn = sorted(map(tuple, line.get_xydata()))
                    self.assertEqual(len(drawn), len(expected))
                    for (dx, dy), (ex, ey) in zip(drawn, expected):
                        self.assertAlmostEqual(dx, ex, places=9)
                        self.assertAlmostEqual(dy, ey, places=9)
            # Failed cells are not points but are named on the figure.
            self.assertIsNone(by_gid(fig.fig, "points:broken:flip"))
            note = [t.get_text() for t in fig.fig.texts if t.get_gid() == "failed-note"]
            self.assertEqual(len(note), 1)
            self.assertIn("broken", note[0])
            style.close(fig.fig)

    def test_pareto_front_drawn_is_the_non_dominated_set(self):
        fig = F.quality_vs_time(self.rd, "cornell-box", self.styles)
        ok = [r for r in self.summary if r["scene"] == "cornell-box" and r["status"] == "ok"]
        pts = [(float(r["wall_ms_median"]), float(r["flip_mean"])) for r in ok]
        # Brute force: a point is on the front if no other point is at least as fast and as accurate
        # and strictly better in one.
        front = sorted(p for p in pts if not any(
            q[0] <= p[0] and q[1] <= p[1] and (q[0] < p[0] or q[1] < p[1]) for q in pts))
        drawn = sorted(map(tuple, by_gid(fig.fig, "pareto:flip").get_xydata()))
        self.assertEqual(len(drawn), len(front))
        for d, e in zip(drawn, front):
            self.assertAlmostEqual(d[0], e[0], places=9)
            self.assertAlmostEqual(d[1], e[1], places=9)
        style.close(fig.fig)

    def test_pareto_front_function(self):
        x = [1, 2, 3, 4, 2.5, 5]
        y = [0.5, 0.3, 0.35, 0.1, 0.3, 0.1]  # index 2 dominated by 1; 4 ties 1 in y but slower; 5 by 3
        self.assertEqual(F.pareto_front(x, y, True), [0, 1, 3])
        # Larger is better (SSIM): the front keeps points that raise the similarity as time grows.
        self.assertEqual(F.pareto_front([1, 2, 3], [0.9, 0.8, 0.95], False), [0, 2])
        self.assertEqual(F.pareto_front([1, math.nan, 3], [0.9, 0.99, 0.95], False), [0, 2])

    def test_stacked_bars_are_the_pass_medians(self):
        fig = F.pass_breakdown(self.rd, "pillars", self.styles)
        n_checked = n_other = 0
        for r in self.summary:
            if r["scene"] != "pillars":
                continue
            left = 0.0
            for col, text in r.items():
                if not (col.startswith("pass.") and col.endswith(".ms_median")) or "/" in col or not text:
                    continue
                name = col[len("pass."):-len(".ms_median")]
                bar = by_gid(fig.fig, f"bar:{r['cell']}:{name}")
                self.assertIsNotNone(bar, (r["cell"], name))
                self.assertAlmostEqual(bar.get_width(), float(text), places=9)
                self.assertAlmostEqual(bar.get_x(), left, places=9)  # stacked in order
                left += float(text)
                n_checked += 1
            # The rest of the median frame ("other") completes the bar whenever passes leave a rest.
            other = by_gid(fig.fig, f"bar:{r['cell']}:other")
            frame = float(r["wall_ms_median"] or "nan")
            if frame - left > 1e-9:
                self.assertIsNotNone(other, r["cell"])
                self.assertAlmostEqual(left + other.get_width(), frame, places=9)
                n_other += 1
            else:
                self.assertIsNone(other, r["cell"])
            if r["status"] != "ok":
                self.assertIsNotNone(by_gid(fig.fig, f"failed:{r['cell']}"), r["cell"])
        self.assertGreater(n_checked, 30)
        self.assertGreater(n_other, 0)
        style.close(fig.fig)

    def test_timeline_is_frames_csv_with_failure_and_warning_frames(self):
        fig = F.timeline(self.rd, "pillars", self.styles)
        for r in self.summary:
            if r["scene"] != "pillars":
                continue
            path = os.path.join(self.run_dir, "cells", r["cell"], "frames.csv")
            rows = [x for x in read_csv(path) if x["pass"] == "frame"] if os.path.exists(path) else []
            line = by_gid(fig.fig, f"time:{r['cell']}")
            if not rows:
                self.assertIsNone(line)
                continue
            # A pass's time is the larger of its two clocks (where it ran), as in summary.csv.
            expected = [(int(x["frame"]), max(float(v) for v in (x["gpu_ms"], x["cpu_ms"]) if v)) for x in rows]
            drawn = [(int(a), b) for a, b in line.get_xydata()]
            self.assertEqual([d[0] for d in drawn], [e[0] for e in expected])
            for d, e in zip(drawn, expected):
                self.assertAlmostEqual(d[1], e[1], places=9)
            metrics = [x for x in read_csv(os.path.join(self.run_dir, "cells", r["cell"], "metrics.csv"))
                       if x["path_class"] == "combined"]
            flip = by_gid(fig.fig, f"flip:{r['cell']}")
            self.assertEqual([tuple(p) for p in flip.get_xydata()],
                             [(float(x["frame"]), float(x["flip"])) for x in metrics])
        failed = read_csv(os.path.join(self.run_dir, "summary.csv"))
        trivial = next(x["cell"] for x in failed if x["scene"] == "pillars" and x["param.variant"] == "trivial")
        marker = by_gid(fig.fig, f"failure:{trivial}")
        self.assertEqual(marker.get_xdata()[0], 13)  # cell.json failed_frame
        warned = next(x["cell"] for x in failed if x["scene"] == "pillars" and x["param.photons"] == "200000")
        self.assertEqual(sorted(int(g.split(":")[-1]) for g in gids(fig.fig, f"warning:{warned}:")), [5, 17])
        style.close(fig.fig)

    def test_sweep_curve_is_summary_against_parameter(self):
        figs = {f.stem: f for f in F.sweep_curves(self.rd, "cornell-box", self.styles)}
        self.assertEqual(sorted(figs), ["sweep_cornell-box_photons", "sweep_cornell-box_variant"])
        fig = figs["sweep_cornell-box_photons"]
        rows = sorted((int(r["param.photons"]), float(r["wall_ms_median"]), float(r["flip_mean"]))
                      for r in self.summary if r["scene"] == "cornell-box" and r["technique"] == "tiled")
        time = by_gid(fig.fig, "sweep:photons:time:tiled").get_xydata()
        flip = by_gid(fig.fig, "sweep:photons:flip:tiled").get_xydata()
        self.assertEqual([tuple(p) for p in time], [(float(a), b) for a, b, _ in rows])
        self.assertEqual([tuple(p) for p in flip], [(float(a), c) for a, _, c in rows])
        # Categorical sweep: the failed setting is marked, not dropped.
        variant = F.sweep_curves(self.rd, "pillars", self.styles)
        v = next(f for f in variant if f.stem.endswith("variant"))
        failed_cell = next(r["cell"] for r in self.summary if r["scene"] == "pillars"
                           and r["param.variant"] == "trivial")
        self.assertTrue(gids(v.fig, f"failed:{failed_cell}"))
        for f in list(figs.values()) + variant:
            style.close(f.fig)

    def test_image_grid_crop(self):
        fig = I.image_grid(self.rd, "cornell-box", crop=(10, 20, 30, 12))
        self.assertEqual(fig.rows[0][4:], [10, 20, 30, 12])
        # Panels: reference + every cell of the scene, failed ones included.
        self.assertEqual(len(fig.rows), 1 + len(self.rd.cells_of("cornell-box")))
        self.assertIn("FAILED", [r[1][:6] for r in fig.rows])
        style.close(fig.fig)
        # Fractions of the image; and the automatic crop stays inside the image.
        self.assertEqual(I.resolve_crop((0.5, 0.5, 0.25, 0.25), 96, 54, []), (48, 27, 24, 14))
        x, y, w, h = I.resolve_crop(None, 96, 54, [])
        self.assertTrue(0 <= x and x + w <= 96 and 0 <= y and y + h <= 54)

    def test_auto_crop_finds_the_brightest_error(self):
        import numpy as np
        m = np.zeros((40, 80, 3))
        m[30:38, 60:76] = 1.0
        x, y, w, h = I.resolve_crop(None, 80, 40, [m])
        self.assertEqual((w, h), (20, 10))
        self.assertTrue(x <= 60 and x + w >= 76 and y <= 30 and y + h >= 38)


def _text_boxes(fig, prefix):
    """{gid: display box} of the texts whose gid starts with prefix, as drawn."""
    import matplotlib.text
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    boxes = {}
    for ax in fig.axes:
        for t in ax.texts:
            if (t.get_gid() or "").startswith(prefix):
                boxes[(id(ax), t.get_gid())] = (ax, matplotlib.text.Text.get_window_extent(t, renderer))
    return boxes


def _overlapping(boxes):
    """The pairs of boxes that share an area (in display coordinates, across all axes)."""
    items = list(boxes.items())
    out = []
    for i, (ka, (axa, a)) in enumerate(items):
        for kb, (axb, b) in items[i + 1:]:
            if min(a.x1, b.x1) - max(a.x0, b.x0) > 0 and min(a.y1, b.y1) - max(a.y0, b.y0) > 0:
                out.append((ka[1], kb[1]))
    return out


class LabelsDoNotOverlapTest(unittest.TestCase):
    """Two settings of one technique whose points nearly coincide (direct at two shadow map sizes,
    tiled at three close photon counts): their labels in the quality-against-time plot and their
    column titles in the image grid are placed apart, never printed over each other."""

    @classmethod
    def setUpClass(cls):
        cls.tmp = TempRuns()
        settings = {"direct": [{"shadow_map_size": 256}, {"shadow_map_size": 1024}],
                    "tiled": [{"photons": p, "radius": 0.05} for p in (100000, 101000, 102000)]}
        cls.rd = Run(cls.tmp.make("run", seed=3, settings=settings, scenes=["cornell-box"],
                                  techniques=["direct", "tiled", "cluster"]))
        cls.styles = style.TechniqueStyle(cls.rd.techniques())

    @classmethod
    def tearDownClass(cls):
        cls.tmp.cleanup()

    def test_setting_labels_name_what_tells_the_cells_apart(self):
        labels = sorted(self.rd.label(c) for c in self.rd.cells_of("cornell-box") if c.technique == "direct")
        self.assertEqual(labels, ["direct (shadow_map_size=1024)", "direct (shadow_map_size=256)"])

    def test_point_labels_neither_overlap_nor_leave_their_axes(self):
        fig = F.quality_vs_time(self.rd, "cornell-box", self.styles).fig
        boxes = _text_boxes(fig, "point-label:")
        # direct's 2 and tiled's 3 cells labelled in each of the three metric panels (cluster's
        # variants too, where the fixture gives it more than one cell)
        self.assertGreaterEqual(len(boxes), 3 * 5)
        self.assertEqual(_overlapping(boxes), [])
        for ax, box in boxes.values():
            frame = ax.get_window_extent()
            self.assertTrue(frame.x0 - 0.5 <= box.x0 and box.x1 <= frame.x1 + 0.5
                            and frame.y0 - 0.5 <= box.y0 and box.y1 <= frame.y1 + 0.5, box)
        style.close(fig)

    def test_image_grid_titles_do_not_overlap(self):
        fig = I.image_grid(self.rd, "cornell-box").fig
        boxes = _text_boxes(fig, "panel-")
        titles = [g for _, g in boxes if g.startswith("panel-setting:")]
        self.assertGreaterEqual(len(titles), 5)  # each direct and tiled cell's setting is printed
        self.assertEqual(_overlapping(boxes), [])
        style.close(fig)


if __name__ == "__main__":
    unittest.main()
