"""video: the captured frames of a run encoded by ffmpeg, checked with ffprobe (codec, size, frame
count, rate), the animated crop decoded back pixel for pixel, the report embedding them, and a run
without ffmpeg on PATH skipping the videos with exit 0."""

import io
import json
import os
import shutil
import subprocess
import unittest
from contextlib import redirect_stderr, redirect_stdout

import numpy as np

from common import TempRuns

import fixture
from pbtools import report as R
from pbtools import video as V
from pbtools.rundata import Run

HAVE_FFMPEG = shutil.which("ffmpeg") is not None and shutil.which("ffprobe") is not None
FPS, EVERY, FRAMES = 30.0, 2, 24
CROP = [10, 6, 20, 12]


def frame_image(cell_index: int, frame: int, w: int, h: int) -> np.ndarray:
    """A frame that differs from every other (a moving bar over a cell-specific gradient)."""
    img = np.zeros((h, w, 3))
    img[..., 0] = np.linspace(0, 1, w)[None, :]
    img[..., 1] = (cell_index + 1) / 8.0
    img[:, (frame * 3) % w, 2] = 1.0
    return img


def add_captures(run_dir: str) -> dict:
    """What the harness's `video: {every: 2, crop: CROP}` leaves: video/frame_NNNN.png of every
    second measured frame and video/video.json, for every cell; returns cell -> frames."""
    run = Run(run_dir)
    warmup = run.info["config"]["frames"]["warmup"]
    w, h = run.info["config"]["resolution"]
    frames = list(range(warmup, warmup + FRAMES, EVERY))
    out = {}
    for i, cell in enumerate(run.cells):
        d = os.path.join(cell.dir, "video")
        os.makedirs(d, exist_ok=True)
        for f in frames:
            fixture.save_png(os.path.join(d, f"frame_{f:04d}.png"), frame_image(i, f, w, h))
        with open(os.path.join(d, "video.json"), "w") as fh:
            json.dump({"fps": FPS, "every": EVERY, "width": w, "height": h, "crop": CROP,
                       "frames": frames}, fh)
        out[cell.id] = frames
    return out


def probe(path: str) -> dict:
    text = subprocess.run(
        ["ffprobe", "-v", "error", "-count_frames", "-select_streams", "v:0", "-show_entries",
         "stream=codec_name,width,height,nb_read_frames,r_frame_rate", "-of", "json", path],
        check=True, capture_output=True, text=True).stdout
    return json.loads(text)["streams"][0]


def decode_rgb(path: str, w: int, h: int) -> np.ndarray:
    raw = subprocess.run(["ffmpeg", "-v", "error", "-i", path, "-f", "rawvideo", "-pix_fmt", "rgb24",
                          "-"], check=True, capture_output=True).stdout
    return np.frombuffer(raw, np.uint8).reshape(-1, h, w, 3)


@unittest.skipUnless(HAVE_FFMPEG, "ffmpeg/ffprobe not installed (scripts/setup.sh installs ffmpeg)")
class VideoTest(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        cls.runs = TempRuns()
        cls.run_dir = cls.runs.make("run", frames=FRAMES, scenes=["cornell-box"],
                                    techniques=["direct", "tiled"],
                                    settings={"tiled": [{"photons": 50000, "radius": 0.05}]})
        cls.captured = add_captures(cls.run_dir)
        with redirect_stdout(io.StringIO()):
            cls.manifest = V.encode_run(cls.run_dir, log=lambda _: None)
        cls.scene = cls.manifest["scenes"][0]
        cls.folder = os.path.join(cls.run_dir, "videos", cls.scene["slug"])
        cls.loaded = Run(cls.run_dir)

    @classmethod
    def tearDownClass(cls):
        cls.runs.cleanup()

    def test_cell_videos_are_vp9_with_every_captured_frame_at_the_animation_speed(self):
        w, h = self.loaded.info["config"]["resolution"]
        self.assertEqual(len(self.scene["cells"]), 2)
        for item in self.scene["cells"]:
            p = probe(os.path.join(self.folder, item["video"]))
            self.assertEqual(p["codec_name"], "vp9")
            self.assertEqual((p["width"], p["height"]), (w, h))
            self.assertEqual(int(p["nb_read_frames"]), len(self.captured[item["cell"]]))
            self.assertEqual(p["r_frame_rate"], f"{int(FPS / EVERY)}/1")

    def test_side_by_side_has_every_cell_and_a_label_bar(self):
        w, h = self.loaded.info["config"]["resolution"]
        p = probe(os.path.join(self.folder, "side_by_side.webm"))
        self.assertEqual(p["codec_name"], "vp9")
        self.assertEqual((p["width"], p["height"]), (2 * w, h + V.LABEL_PX))
        self.assertEqual(int(p["nb_read_frames"]), FRAMES // EVERY)

    def test_metric_companion_shows_output_reference_and_flip_map(self):
        w, h = self.loaded.info["config"]["resolution"]
        for item in self.scene["cells"]:
            cell = self.loaded.cell(item["cell"])
            metric_frames = {f for (kind, f, c, ext) in cell.images()
                             if kind == "reference" and ext == "png"}
            p = probe(os.path.join(self.folder, item["metrics"]))
            self.assertEqual((p["width"], p["height"]), (3 * w, h + V.LABEL_PX))
            self.assertEqual(int(p["nb_read_frames"]), len(metric_frames))

    def test_crop_is_lossless_and_exactly_the_window(self):
        x, y, w, h = CROP
        for i, item in enumerate(self.scene["cells"]):
            scale = item["crop_scale"]
            self.assertEqual(item["crop_window"], CROP)
            p = probe(os.path.join(self.folder, item["crop"]))
            self.assertEqual(p["codec_name"], "apng")
            decoded = decode_rgb(os.path.join(self.folder, item["crop"]), w * scale, h * scale)
            frames = self.captured[item["cell"]]
            self.assertEqual(len(decoded), len(frames))
            cell_index = [c.id for c in self.loaded.cells].index(item["cell"])
            for k, f in enumerate(frames):
                full = V.rgb8(os.path.join(self.loaded.cell(item["cell"]).dir, "video",
                                           f"frame_{f:04d}.png"))
                self.assertTrue(np.array_equal(decoded[k][::scale, ::scale], full[y:y + h, x:x + w]),
                                f"crop frame {f} of cell {cell_index} differs from the window")

    def test_report_embeds_the_videos(self):
        with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()):
            index = R.build(self.run_dir)
        html = open(index, encoding="utf-8").read()
        base = os.path.dirname(index)
        srcs = [s for s in __import__("re").findall(r'src="([^"]+)"', html) if "videos/" in s]
        self.assertIn(f"videos/{self.scene['slug']}/side_by_side.webm", srcs)
        self.assertEqual(len(srcs), 1 + 3 * len(self.scene["cells"]))
        for s in srcs:
            self.assertTrue(os.path.isfile(os.path.join(base, s)), s)


class NoFfmpegTest(unittest.TestCase):
    def test_without_ffmpeg_it_says_so_and_exits_0(self):
        runs = TempRuns()
        try:
            run_dir = runs.make("run", frames=8, scenes=["cornell-box"], techniques=["direct"])
            add_captures(run_dir)
            old = os.environ["PATH"]
            os.environ["PATH"] = runs.path()  # a folder without ffmpeg
            err = io.StringIO()
            try:
                with redirect_stderr(err), redirect_stdout(io.StringIO()):
                    status = V.main([run_dir])
                    index = R.build(run_dir)
            finally:
                os.environ["PATH"] = old
            self.assertEqual(status, 0)
            self.assertIn("ffmpeg is not on PATH", err.getvalue())
            self.assertFalse(os.path.exists(os.path.join(run_dir, "videos")))
            self.assertIn("ffmpeg is not on PATH", open(index, encoding="utf-8").read())
        finally:
            runs.cleanup()

    def test_a_run_without_captures_is_bad_input(self):
        runs = TempRuns()
        try:
            run_dir = runs.make("run", frames=8, scenes=["cornell-box"], techniques=["direct"])
            err = io.StringIO()
            with redirect_stderr(err):
                self.assertEqual(V.main([run_dir]), 2)
            self.assertIn("video: {every: 1}", err.getvalue())
        finally:
            runs.cleanup()


if __name__ == "__main__":
    unittest.main()
