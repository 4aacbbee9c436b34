"""The report's interactive image viewer: per scene, every metric frame's reference, each cell's output
and its FLIP map, copied under report/viewer/<scene>/ and handed to the template as plain values (the
page's script, templates/viewer.js, shows them under one zoom and pan; without scripts the section stays
hidden and the static image grids are the page's figures).

Sources are the harness's images/ files (frame_NNNN.png, reference_NNNN_<class>.png,
flip_NNNN_<class>.png), the class being each cell's primary one (rundata.Cell.primary_class).

Exposure: each output and reference image is also written at EXPOSURE_STOPS (-2, -1, +1, +2 EV) beside
the original (<name>_ev-2.png ...), so the page switches files instead of filtering pixels: the stops
are the PNG's sRGB values decoded to linear, scaled by 2^EV and encoded again. The PNG is the harness's
display image (already tone-mapped to 8 bits), so a + stop brightens the shadows and clips what was
near white, and a - stop darkens but cannot bring back highlights the PNG clipped. FLIP maps are error
colour maps and are never re-exposed.
"""

from __future__ import annotations

import math
import os
import shutil
from typing import Dict, List, Optional

import numpy as np

from .figures import slug
from .rundata import Run

MAX_KEYED_CELLS = 9  # keys 1-9 pick a cell; further cells are picked with their buttons
EXPOSURE_STOPS = (-2, -1, 1, 2)  # EV; 0 is the original file


def srgb_to_linear(c: np.ndarray) -> np.ndarray:
    """IEC 61966-2-1's sRGB decoding, c in [0, 1]."""
    return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(c: np.ndarray) -> np.ndarray:
    c = np.clip(c, 0.0, 1.0)
    return np.where(c <= 0.0031308, c * 12.92, 1.055 * np.power(c, 1 / 2.4) - 0.055)


def exposed(rgb: np.ndarray, ev: float) -> np.ndarray:
    """An 8-bit-range sRGB image (floats in [0, 1]) at `ev` stops: linear x 2^ev, clipped, re-encoded."""
    return linear_to_srgb(srgb_to_linear(rgb) * 2.0 ** ev)


def write_stops(report_dir: str, rel_path: str) -> Dict[str, str]:
    """{"-2": path, ..., "0": rel_path, ..., "2": path}: the image at rel_path (under report_dir) written
    again at each EXPOSURE_STOPS beside it."""
    import matplotlib.image
    src = os.path.join(report_dir, rel_path)
    img = matplotlib.image.imread(src)
    if img.dtype == np.uint8:
        img = img.astype(np.float32) / 255.0
    alpha = img[..., 3:4] if img.ndim == 3 and img.shape[2] == 4 else None
    rgb = img[..., :3] if img.ndim == 3 else np.repeat(img[..., None], 3, axis=2)
    stem, ext = os.path.splitext(rel_path)
    out = {"0": rel_path}
    for ev in EXPOSURE_STOPS:
        pixels = exposed(rgb, ev)
        if alpha is not None:
            pixels = np.concatenate([pixels, alpha], axis=2)
        name = f"{stem}_ev{ev:+d}{ext}"
        # Quantised as the original was, so +0 EV would give the same bytes back.
        pixels = np.round(pixels * 255.0).astype(np.uint8)
        matplotlib.image.imsave(os.path.join(report_dir, name), pixels)
        out[str(ev)] = name
    return {k: out[k] for k in sorted(out, key=int)}


def scene_view(run: Run, scene: str, report_dir: str) -> Optional[dict]:
    """{slug, stops, cells: [{label, key}], frames: [{frame, reference, reference_stops, cells: [{image,
    image_stops, flip, score}]}]}, with the images copied to report_dir/viewer/<slug>/ (and their
    exposure stops written beside them, "<ev>": path); None when the scene has no metric frame."""
    cells = run.cells_of(scene)
    frames = sorted({f for c in cells for (kind, f, _, ext) in c.images()
                     if kind == "reference" and ext == "png"})
    if not frames:
        return None
    folder = os.path.join("viewer", slug(scene))
    os.makedirs(os.path.join(report_dir, folder), exist_ok=True)

    def copied(path: Optional[str], name: str) -> Optional[str]:
        if not path:
            return None
        shutil.copyfile(path, os.path.join(report_dir, folder, name))
        return f"{folder}/{name}"

    frame_views = []
    for f in frames:
        reference = None
        layers = []
        for i, c in enumerate(cells):
            imgs = c.images()
            cls = c.primary_class()
            ref = imgs.get(("reference", f, cls, "png"))
            if reference is None and ref:
                reference = copied(ref, f"reference_{f:04d}.png")
            score = math.nan
            if cls is not None:
                mf, mv = c.metric_series("flip", cls)
                hits = [v for g, v in zip(mf, mv) if g == f]
                score = float(hits[0]) if hits else math.nan
            image = copied(imgs.get(("frame", f, None, "png")), f"cell{i}_frame_{f:04d}.png")
            layers.append({
                "image": image, "image_stops": write_stops(report_dir, image) if image else None,
                "flip": copied(imgs.get(("flip", f, cls, "png")), f"cell{i}_flip_{f:04d}.png"),
                "score": f"{score:.4f}" if math.isfinite(score) else ""})
        if reference is not None:
            frame_views.append({"frame": f, "reference": reference,
                                "reference_stops": write_stops(report_dir, reference), "cells": layers})
    if not frame_views:
        return None
    labels = [{"label": run.label(c), "key": str(i + 1) if i < MAX_KEYED_CELLS else ""}
              for i, c in enumerate(cells)]
    return {"slug": slug(scene), "stops": sorted([0, *EXPOSURE_STOPS]), "cells": labels,
            "frames": frame_views}


def views(run: Run, report_dir: str) -> List[dict]:
    out = []
    for scene in run.scenes():
        v = scene_view(run, scene, report_dir)
        if v:
            out.append(v)
    return out
