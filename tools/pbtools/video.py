"""photonbench video RUN_DIR: the videos of a run whose config has a `video:` block.

The harness saves the output of every `every`-th measured frame of the chosen cells after the frame's
timed region (cells/<cell>/video/frame_NNNN.png, display-encoded as the metric frames' PNGs are, and
video/video.json: the animation's fps, `every`, the crop window and the frames). This encodes them with
Debian's `ffmpeg` command, frames composed with numpy and piped to it as raw RGB:

  RUN/videos/<scene>/<cell>.webm           the cell's frames (VP9), at fps / every: the animation's speed
  RUN/videos/<scene>/side_by_side.webm     all the scene's captured cells in a grid, each panel labelled
                                           with the technique (and setting) and that frame's wall-clock
                                           time from frames.csv
  RUN/videos/<scene>/<cell>_metrics.webm   at the metric frames: output, reference and FLIP map side by
                                           side (the harness's images/ files), labelled with the FLIP score
  RUN/videos/<scene>/<cell>_crop.png       a lossless animated PNG of the crop window, enlarged by an
                                           integer factor with nearest-neighbour pixels: flicker as it is,
                                           which a lossy codec can hide or invent
  RUN/videos/videos.json                   what was written (the report embeds it)

Without ffmpeg on PATH it says so and writes nothing; that is not an error (exit 0). A run without
captured frames is bad input (exit 2): add `video: {every: 1}` to its config.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
from typing import Dict, Iterable, List, Optional

import numpy as np

from . import images as I
from .figures import slug
from .rundata import Cell, Run, RunError, WHOLE_FRAME_PASS

MANIFEST = "videos.json"
LABEL_PX = 16  # height of the label bar above a panel
GRID_COLUMNS = 4  # panels per row of the side-by-side video
CROP_TARGET_PX = 256  # the animated crop is enlarged to about this width
VP9_CRF = 32  # constant quality (0 best .. 63); VP9's recommended range for 240-360p is 31-37


class NoFfmpeg(Exception):
    pass


def ffmpeg() -> Optional[str]:
    return shutil.which("ffmpeg")


def video_dir(cell: Cell) -> str:
    return os.path.join(cell.dir, "video")


def captured(cell: Cell) -> Optional[dict]:
    """The cell's video/video.json with `paths` (frame -> PNG) added; None if it captured nothing."""
    index_path = os.path.join(video_dir(cell), "video.json")
    if not os.path.isfile(index_path):
        return None
    with open(index_path, encoding="utf-8") as f:
        index = json.load(f)
    paths = {}
    for frame in index.get("frames", []):
        path = os.path.join(video_dir(cell), f"frame_{int(frame):04d}.png")
        if os.path.isfile(path):
            paths[int(frame)] = path
    index["paths"] = paths
    return index if paths else None


def frame_times_ms(cell: Cell) -> Dict[int, float]:
    """frame -> the whole frame's wall-clock time (frames.csv's "frame" row, cpu_ms)."""
    frames, ms = cell.pass_samples(WHOLE_FRAME_PASS, clock="cpu")
    return {int(f): float(m) for f, m in zip(frames, ms)}


def rgb8(path: str) -> np.ndarray:
    img = I.load(path)
    if img.ndim == 2:
        img = np.repeat(img[..., None], 3, axis=2)
    return np.clip(np.round(img[..., :3] * 255.0), 0, 255).astype(np.uint8)


def label_bar(width: int, left: str, right: str = "", height: int = LABEL_PX) -> np.ndarray:
    """A dark bar of width x height pixels with `left` and `right` written in it (matplotlib's Agg
    renderer and its bundled DejaVu font: nothing else to install)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    dpi = 100
    fig = Figure(figsize=(width / dpi, height / dpi), dpi=dpi, facecolor="#202020")
    canvas = FigureCanvasAgg(fig)
    size_pt = (height - 5) * 72 / dpi
    fig.text(3 / width, 0.5, left, color="white", fontsize=size_pt, va="center", ha="left")
    if right:
        fig.text(1 - 3 / width, 0.5, right, color="#ffd966", fontsize=size_pt, va="center", ha="right",
                 bbox={"facecolor": "#202020", "edgecolor": "none", "pad": 1})
    canvas.draw()
    bar = np.asarray(canvas.buffer_rgba())[..., :3]
    return np.ascontiguousarray(bar[:height, :width])


def labelled(img: np.ndarray, left: str, right: str = "") -> np.ndarray:
    return np.vstack([label_bar(img.shape[1], left, right), img])


def grid(panels: List[np.ndarray], columns: int = GRID_COLUMNS) -> np.ndarray:
    """Panels of one size in rows of `columns`, the last row padded with black."""
    columns = max(1, min(columns, len(panels)))
    rows = []
    for r in range(0, len(panels), columns):
        row = panels[r:r + columns]
        row += [np.zeros_like(panels[0])] * (columns - len(row))
        rows.append(np.hstack(row))
    return np.vstack(rows)


def even(img: np.ndarray) -> np.ndarray:
    """Padded with black to even sides: 4:2:0 chroma (what browsers play) halves both."""
    h, w = img.shape[:2]
    return np.pad(img, ((0, h % 2), (0, w % 2), (0, 0)))


def encode(frames: Iterable[np.ndarray], fps: float, out: str, lossless_apng: bool = False) -> int:
    """Pipes the frames (H x W x 3 uint8, one size) to ffmpeg; returns how many were written."""
    exe = ffmpeg()
    if exe is None:
        raise NoFfmpeg()
    it = iter(frames)
    first = next(it, None)
    if first is None:
        return 0
    if not lossless_apng:
        first = even(first)
    h, w = first.shape[:2]
    args = [exe, "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24", "-s", f"{w}x{h}",
            "-framerate", f"{fps:.6g}", "-i", "-"]
    if lossless_apng:
        args += ["-c:v", "apng", "-pix_fmt", "rgb24", "-plays", "0", "-f", "apng"]
    else:
        args += ["-c:v", "libvpx-vp9", "-pix_fmt", "yuv420p", "-crf", str(VP9_CRF), "-b:v", "0",
                 "-deadline", "good", "-cpu-used", "4", "-row-mt", "1", "-f", "webm"]
    tmp = out + ".part"
    proc = subprocess.Popen(args + [tmp], stdin=subprocess.PIPE, stderr=subprocess.PIPE)
    count = 0
    try:
        proc.stdin.write(first.tobytes())
        count += 1
        for img in it:
            img = img if lossless_apng else even(img)
            if img.shape[:2] != (h, w):
                raise ValueError(f"{out}: frame {count} is {img.shape[1]}x{img.shape[0]}, not {w}x{h}")
            proc.stdin.write(img.tobytes())
            count += 1
    finally:
        proc.stdin.close()
        err = proc.stderr.read().decode(errors="replace")
        proc.wait()
    if proc.returncode != 0:
        raise RunError(f"ffmpeg failed on {out}: {err.strip()}")
    os.replace(tmp, out)
    return count


def _metric_frames(cell: Cell):
    """(frame, output, reference, FLIP map, FLIP score) of every metric frame with all three PNGs."""
    cls = cell.primary_class()
    if cls is None:
        return []
    imgs = cell.images()
    mf, mv = cell.metric_series("flip", cls)
    scores = {int(f): float(v) for f, v in zip(mf, mv)}
    out = []
    for (kind, frame, c, ext), path in sorted(imgs.items(), key=lambda kv: kv[0][1]):
        if kind != "frame" or c is not None or ext != "png":
            continue
        ref, flip = imgs.get(("reference", frame, cls, "png")), imgs.get(("flip", frame, cls, "png"))
        if ref and flip:
            out.append((frame, path, ref, flip, scores.get(frame, math.nan)))
    return out


def _rate(fps: float, frames: List[int]) -> float:
    """Frames `gap` apart in the animation shown at its speed: fps / the median gap, at least 1."""
    if len(frames) < 2:
        return 1.0
    gap = float(np.median(np.diff(sorted(frames))))
    return max(1.0, min(fps, fps / max(gap, 1.0)))


def encode_run(run_dir: str, log=print) -> dict:
    """Writes RUN/videos/ (module docstring); returns the manifest. Raises NoFfmpeg without ffmpeg
    and RunError for a run with no captured frames."""
    run = Run(run_dir)
    scenes = []
    any_captured = False
    for scene in run.scenes():
        cells = [(c, captured(c)) for c in run.cells_of(scene)]
        cells = [(c, idx) for c, idx in cells if idx]
        if not cells:
            continue
        any_captured = True
        if ffmpeg() is None:
            raise NoFfmpeg()
        out_dir = os.path.join(run.path, "videos", slug(scene))
        os.makedirs(out_dir, exist_ok=True)
        entry = {"scene": scene, "slug": slug(scene), "cells": [], "side_by_side": None}
        all_frames = sorted({f for _, idx in cells for f in idx["paths"]})
        fps = float(cells[0][1].get("fps", 30.0))
        every = int(cells[0][1].get("every", 1))
        rate = fps / max(every, 1)
        for c, idx in cells:
            label = run.label(c)
            frames = sorted(idx["paths"])
            item = {"cell": c.id, "label": label, "technique": c.technique, "frames": len(frames),
                    "fps": rate}
            name = f"{slug(c.id)}.webm"
            encode((rgb8(idx["paths"][f]) for f in frames), rate, os.path.join(out_dir, name))
            item["video"] = name
            x, y, w, h = (int(v) for v in idx.get("crop", [0, 0, 0, 0]))
            first = rgb8(idx["paths"][frames[0]])
            if w <= 0 or h <= 0 or x + w > first.shape[1] or y + h > first.shape[0]:
                x, y, w, h = first.shape[1] // 4, first.shape[0] // 4, first.shape[1] // 2, first.shape[0] // 2
            scale = max(1, min(8, CROP_TARGET_PX // max(w, 1)))
            crop_name = f"{slug(c.id)}_crop.png"
            encode((np.repeat(np.repeat(rgb8(idx["paths"][f])[y:y + h, x:x + w], scale, 0), scale, 1)
                    for f in frames), rate, os.path.join(out_dir, crop_name), lossless_apng=True)
            item.update({"crop": crop_name, "crop_window": [x, y, w, h], "crop_scale": scale})
            metric = _metric_frames(c)
            if metric:
                metric_name = f"{slug(c.id)}_metrics.webm"

                def companion(rows=metric, label=label):
                    for frame, out, ref, flip, score in rows:
                        s = "" if not math.isfinite(score) else f"FLIP {score:.4f}"
                        yield np.hstack([labelled(rgb8(out), label, f"frame {frame}"),
                                         labelled(rgb8(ref), "reference"),
                                         labelled(rgb8(flip), "FLIP map", s)])
                encode(companion(), _rate(fps, [m[0] for m in metric]),
                       os.path.join(out_dir, metric_name))
                item.update({"metrics": metric_name, "metric_frames": len(metric)})
            entry["cells"].append(item)
            log(f"video: {scene}: {label}: {len(frames)} frames at {rate:g} fps")

        times = {c.id: frame_times_ms(c) for c, _ in cells}
        size = rgb8(cells[0][1]["paths"][min(cells[0][1]["paths"])]).shape[:2]

        def side_by_side():
            for f in all_frames:
                panels = []
                for c, idx in cells:
                    label = run.label(c)
                    if f in idx["paths"]:
                        ms = times[c.id].get(f)
                        right = f"{ms:.1f} ms" if ms is not None and math.isfinite(ms) else ""
                        panels.append(labelled(rgb8(idx["paths"][f]), label, right))
                    else:
                        panels.append(labelled(np.full(size + (3,), 64, np.uint8), label, "no frame"))
                yield grid(panels)
        encode(side_by_side(), rate, os.path.join(out_dir, "side_by_side.webm"))
        entry["side_by_side"] = "side_by_side.webm"
        entry["frames"] = len(all_frames)
        entry["fps"] = rate
        scenes.append(entry)
    if not any_captured:
        raise RunError(f"{run.path}: no cell captured video frames (cells/<cell>/video/); add "
                       "`video: {every: 1}` to the config and run it again")
    manifest = {"scenes": scenes}
    with open(os.path.join(run.path, "videos", MANIFEST), "w", encoding="utf-8") as f:
        json.dump(manifest, f, indent=2)
    return manifest


def has_captures(run: Run) -> bool:
    return any(os.path.isfile(os.path.join(video_dir(c), "video.json")) for c in run.cells)


def load_manifest(run_dir: str) -> Optional[dict]:
    path = os.path.join(run_dir, "videos", MANIFEST)
    if not os.path.isfile(path):
        return None
    with open(path, encoding="utf-8") as f:
        return json.load(f)


NO_FFMPEG = ("ffmpeg is not on PATH (scripts/setup.sh installs Debian's ffmpeg): the captured frames "
             "are kept, no videos were written")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="photonbench video",
                                 description="Encode the frames a run's `video:` block captured into "
                                             "RUN_DIR/videos/ (WebM VP9 and animated PNG, via ffmpeg).")
    ap.add_argument("run_dir", metavar="RUN_DIR")
    a = ap.parse_args(argv)
    try:
        manifest = encode_run(a.run_dir)
    except NoFfmpeg:
        print(f"video: {NO_FFMPEG}", file=sys.stderr)
        return 0
    except RunError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    n = sum(1 + len(s["cells"]) for s in manifest["scenes"])
    print(f"video: {n} videos in {os.path.join(os.path.abspath(a.run_dir), 'videos')}")
    return 0
