"""The report's interactive image viewer: per scene, every metric frame's reference, each cell's output
and its FLIP map, copied under report/viewer/<scene>/ and handed to the template as plain values (the
page's script, templates/viewer.js, shows them under one zoom and pan; without scripts the section stays
hidden and the static image grids are the page's figures).

Sources are the harness's images/ files (frame_NNNN.png, reference_NNNN_<class>.png,
flip_NNNN_<class>.png), the class being each cell's primary one (rundata.Cell.primary_class).
"""

from __future__ import annotations

import math
import os
import shutil
from typing import List, Optional

from .figures import slug
from .rundata import Run

MAX_KEYED_CELLS = 9  # keys 1-9 pick a cell; further cells are picked with their buttons


def scene_view(run: Run, scene: str, report_dir: str) -> Optional[dict]:
    """{slug, cells: [{label, key}], frames: [{frame, reference, cells: [{image, flip, score}]}]}, with
    the images copied to report_dir/viewer/<slug>/; None when the scene has no metric frame."""
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
            layers.append({
                "image": copied(imgs.get(("frame", f, None, "png")), f"cell{i}_frame_{f:04d}.png"),
                "flip": copied(imgs.get(("flip", f, cls, "png")), f"cell{i}_flip_{f:04d}.png"),
                "score": f"{score:.4f}" if math.isfinite(score) else ""})
        if reference is not None:
            frame_views.append({"frame": f, "reference": reference, "cells": layers})
    if not frame_views:
        return None
    labels = [{"label": run.label(c), "key": str(i + 1) if i < MAX_KEYED_CELLS else ""}
              for i, c in enumerate(cells)]
    return {"slug": slug(scene), "cells": labels, "frames": frame_views}


def views(run: Run, report_dir: str) -> List[dict]:
    out = []
    for scene in run.scenes():
        v = scene_view(run, scene, report_dir)
        if v:
            out.append(v)
    return out
