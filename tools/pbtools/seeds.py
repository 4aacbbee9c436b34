"""Temporal and seed stability of a run, for the report and the claims (stats.py holds the rules).

Temporal: per cell, the flicker metric (metrics.csv's `flicker`, harness/src/metrics/flicker.h: the
RMS of the technique's frame difference minus the reference's, relative to the reference's level)
averaged over the frame pairs with its floor, and the popping frames of its FLIP series
(stats.popping_frames).

Seeds (`photonbench run --seeds K`): the K cells of one seed group (cell.json `seed_group`; a run
without a seed axis has groups of one) are the same scene, technique and parameters with seeds
seed .. seed + K - 1. Per group and metric: the spread of the per-seed means across seeds (mean, std,
min, max), and from the harness's RUN/seeds/<group>/seeds.json (run/seed_stats.h) the per-pixel
Z-test of the mean image against the reference and the relative standard deviation images.
"""

from __future__ import annotations

import json
import math
import os
from collections import OrderedDict
from typing import Dict, List, Optional, Sequence

from . import stats
from .rundata import FULL_REFERENCE, Cell, Run

SPREAD_METRICS = ("flip", "ssim", "psnr", "flicker")


def seed_group(cell: Cell) -> str:
    # A match run's round re-measures its found cell with the same seed: a group of its own (runs
    # recorded before rounds had their own group name the found cell's in cell.json).
    if cell.match_round is not None:
        return cell.id
    return str(cell.json.get("seed_group") or cell.id)


def seed_of(cell: Cell) -> Optional[int]:
    seed = cell.json.get("seed")
    return int(seed) if isinstance(seed, (int, float)) and not isinstance(seed, bool) else None


def groups(run: Run) -> "OrderedDict[str, List[Cell]]":
    """seed group -> its cells in seed order (run order for cells without a seed)."""
    out: "OrderedDict[str, List[Cell]]" = OrderedDict()
    for c in run.cells:
        out.setdefault(seed_group(c), []).append(c)
    for cells in out.values():
        cells.sort(key=lambda c: (seed_of(c) is None, seed_of(c) or 0, c.index))
    return out


def has_seed_axis(run: Run) -> bool:
    return any(len(cells) > 1 for cells in groups(run).values())


def per_seed_means(cells: Sequence[Cell], metric: str, path_class: Optional[str] = None,
                   reference: str = FULL_REFERENCE) -> List[float]:
    """One value per complete cell: its metric's mean over the metric frames (NaN-free)."""
    values = [c.metric_mean(metric, path_class, reference) for c in cells if c.ok]
    return [v for v in values if math.isfinite(v)]


def spread_rows(run: Run, metrics: Sequence[str] = SPREAD_METRICS) -> List[dict]:
    """Per seed group of two or more cells and metric (combined class, full reference): the
    spread across seeds of the per-seed means."""
    rows = []
    for group, cells in groups(run).items():
        if len(cells) < 2:
            continue
        first = cells[0]
        for m in metrics:
            s = stats.spread(per_seed_means(cells, m))
            if s is None:
                continue
            rows.append({"group": group, "scene": first.scene,
                         "label": run.label(first, with_seed=False),
                         "metric": m, "seeds": s.n, "mean": s.mean, "std": s.std, "min": s.min,
                         "max": s.max})
    return rows


def z_tests(run: Run) -> List[dict]:
    """The harness's per-pixel Z-tests (RUN/seeds/<group>/seeds.json), one row per group, frame and
    class, with the relative standard deviation image when it exists."""
    rows = []
    for group, cells in groups(run).items():
        path = os.path.join(run.path, "seeds", group, "seeds.json")
        if len(cells) < 2 or not os.path.isfile(path):
            continue
        with open(path, encoding="utf-8") as f:
            record = json.load(f)
        for frame in record.get("frames", []):
            z = frame.get("z_test") or {}
            image = os.path.join(run.path, "seeds", group,
                                 f"stddev_{int(frame['frame']):04d}_{frame['path_class']}.png")
            rows.append({"group": group, "scene": cells[0].scene,
                         "label": run.label(cells[0], with_seed=False),
                         "frame": int(frame["frame"]), "path_class": frame["path_class"],
                         "seeds": len(record.get("seeds", [])), "p_value": z.get("p_value", math.nan),
                         "rejected": z.get("rejected"), "tested": z.get("tested"),
                         "alpha": z.get("alpha"), "equal": z.get("equal"),
                         "stddev_image": image if os.path.isfile(image) else None})
    return rows


def temporal_rows(run: Run, k: float = stats.POPPING_K) -> List[dict]:
    """Per cell (combined class, full reference): mean flicker and its floor over the frame pairs,
    and the frames whose FLIP pops."""
    rows = []
    for c in run.cells:
        frames, flip = c.metric_series("flip")
        if not len(frames):
            continue
        pops = stats.popping_frames(frames, flip, k)
        rows.append({"cell": c.id, "scene": c.scene, "label": run.label(c), "seed": seed_of(c),
                     "metric_frames": len(frames), "flicker": c.metric_mean("flicker"),
                     "flicker_floor": c.metric_mean("flicker_floor"), "pops": len(pops),
                     "popping_frames": pops})
    return rows
