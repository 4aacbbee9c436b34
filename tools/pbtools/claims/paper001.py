"""Seed 001 (Larsen, "Real-time Photon Mapping", DTU thesis 2004) claims, measured on a run of
configs/paper001.yaml (digest shared/research/seed001-003.md, part B).

The thesis judged its images by eye and gave no figure for its central trade: a progressive, object-space
cache of indirect light spends each frame's budget where the scene changed, so it lags behind a change
(B11: "popping vs lag"; selective emission "detects small changes slowly"). This module puts a number on
that lag, for any technique of the run:

  * **lag**: on a scene with a scripted event (walker: the figure stops at 3 s and 10 s; two-rooms: the
    right room's lights go out at 2.0-2.1 s), the frames from the event until the indirect FLIP has
    settled: the first frame from which every later score of the window (to the next event or the end)
    stays within a band of the window's settled value. The settled value is the mean of the window's
    last quarter (at least 4 scored frames); the band is the larger of three standard deviations of that
    quarter about its fitted line and the score's noise floor there (what the true image would score
    against the same reference: a change below it is not resolved). A window without 8 scored frames, or
    whose last quarter still trends (its fitted line moves by more than the band across it), is reported
    as not settled, never as 0.
    Beside each lag, the work the technique did until it settled: paths re-traced and rays traced
    (counters `paths_retraced`, and `rays_traced` or `selective_rays`, where the technique has them,
    summed from the event to the settled frame), so that two techniques' lags are read at the work
    each spent.

Scored every frame over the events' windows (the config's metrics_every: 1); the indirect class where the
cell scores it, else the combined image.

And on a run of configs/paper001.yaml (frame 0 of static scenes, where every IIM texel is gathered):
  * **Table 14.2**: the final gather's time per texel (the `gather` pass over the `texels_gathered`
    counter, frame 0), the hemi-plane at each size against the cosine rays, per scene and its triangles,
    with the rays-over-raster ratio beside the thesis's (16.7 ms for 1,024 rays against 0.75-1.59 ms a
    hemi-plane: 10.5x-22x); per round (the seed axis' rounds) and the median over the rounds, on the
    pass's time and on the process CPU time it took (lavapipe draws on the CPU here);
  * **Fig. 14.4**: the indirect FLIP of IIMs at each `aim_texels` beside its floor.
"""

import math
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..rundata import Cell, Run

TITLE = "Real-time Photon Mapping (Larsen, DTU thesis 2004; seed 001)"

# Scripted events per scene: (name, first frame of the event, last frame of the event), at the scenes'
# 30 fps (scenes/walker.yaml: stops at 3 s and 10 s; scenes/two-rooms.yaml: the power track fades from
# 2.0 to 2.1 s).
EVENTS: Dict[str, List[Tuple[str, int, int]]] = {
    "walker": [("the figure stops at the stand", 90, 90), ("the figure stops at the door", 300, 300)],
    "two-rooms": [("the right room's lights go out", 60, 63)],
}
# The work a cell did in a window: paths re-traced, and rays traced (path-verification's `rays_traced`,
# selective photon emission's `selective_rays`; a cell reports one or the other).
PATHS_COUNTER = "paths_retraced"
RAYS_COUNTERS = ("rays_traced", "selective_rays")
MIN_WINDOW = 8  # scored frames a window needs for a lag
TAIL_SHARE = 0.25
MIN_TAIL = 4
NOISE_SIGMAS = 3.0


TECHNIQUE = "illumination-maps"
# Triangles of the Table 14.2 scenes (scenes/cornell-bumpy-*.yaml say how they are made).
TRIANGLES = {"cornell-box": 34, "cornell-bumpy-13k": 12832, "cornell-bumpy-133k": 133160}
# Table 14.2: (render size, polygons) -> ms a gather; and 1,024 rays in an 8,000-polygon scene.
THESIS_TABLE_142 = {(8, 34): 0.75, (16, 34): 0.76, (32, 34): 0.78, (8, 13000): 0.90, (16, 13000): 0.91,
                    (32, 13000): 0.97, (8, 133000): 1.55, (16, 133000): 1.57, (32, 133000): 1.59}
THESIS_RAYS_MS = 16.7
# The technique's defaults for the parameters that name a gather (techniques/illumination-maps).
DEFAULTS = {"gather": "raster", "hemi_size": 16, "sum_precision": "8bit", "gather_rays": 1024,
            "aim_texels": 5}


class MissingCells(Exception):
    pass


def settle(frames: np.ndarray, values: np.ndarray, floors: Optional[np.ndarray]) -> Optional[dict]:
    """The settled value, the band and the first settled frame of one window's series (frames sorted);
    None when the window is too short to tell or its tail still trends (a lag would be a guess)."""
    n = len(frames)
    if n < MIN_WINDOW:
        return None
    tail_n = max(MIN_TAIL, int(math.ceil(n * TAIL_SHARE)))
    tf, tv = frames[-tail_n:].astype(float), values[-tail_n:]
    slope, intercept = np.polyfit(tf, tv, 1)
    noise = float(np.std(tv - (slope * tf + intercept), ddof=2)) if tail_n > 2 else 0.0
    floor = float(np.nanmedian(floors[-tail_n:])) if floors is not None and len(floors) else 0.0
    band = max(NOISE_SIGMAS * noise, floor if math.isfinite(floor) else 0.0)
    if abs(slope) * (tf[-1] - tf[0]) > band:
        return None  # the tail still trends: what it settles to is not yet known
    settled = float(np.mean(tv))
    outside = np.nonzero(np.abs(values - settled) > band)[0]
    first = 0 if len(outside) == 0 else int(outside[-1]) + 1
    if first >= n - tail_n:
        return None  # it left the band inside the tail itself
    return {"settled": settled, "band": band, "settle_frame": int(frames[first])}


def window_of(events: Sequence[Tuple[str, int, int]], i: int, last_frame: int) -> Tuple[int, int]:
    """Frames [event start, next event start) or to the last frame."""
    end = events[i + 1][1] - 1 if i + 1 < len(events) else last_frame
    return events[i][1], end


def score_class(cell: Cell) -> str:
    return "indirect" if "indirect" in cell.metric_classes() else cell.primary_class() or "combined"


def counter_sum(cell: Cell, name: str, first: int, last: int) -> Optional[float]:
    c = cell.counters
    if c is None or c.empty or name not in set(c["name"]):
        return None
    rows = c[(c["name"] == name) & (c["frame"] >= first) & (c["frame"] <= last)]
    return float(rows["value"].sum()) if len(rows) else None


def lag_rows(run: Run) -> List[dict]:
    rows = []
    for scene, events in EVENTS.items():
        for cell in run.cells_of(scene):
            if not cell.ok:
                continue
            cls = score_class(cell)
            frames, values = cell.metric_series("flip", cls)
            if not len(frames):
                continue
            floor_by_frame = dict(zip(*cell.metric_series("flip_floor", cls)))
            for i, (name, start, stop) in enumerate(events):
                lo, hi = window_of(events, i, int(frames.max()))
                keep = (frames >= lo) & (frames <= hi)
                wf, wv = frames[keep], values[keep]
                wfl = np.array([floor_by_frame.get(f, np.nan) for f in wf]) if floor_by_frame else None
                s = settle(wf, wv, wfl)
                row = {"scene": scene, "cell": cell, "event": name, "start": start, "stop": stop,
                       "class": cls, "scored": len(wf), "settle": s}
                end = s["settle_frame"] if s else hi
                row["paths_retraced"] = counter_sum(cell, PATHS_COUNTER, start, end)
                row["rays"] = next((r for r in (counter_sum(cell, c, start, end) for c in RAYS_COUNTERS)
                                    if r is not None), None)
                rows.append(row)
    return rows


def fmt(v: Optional[float], digits: int = 0) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "–"
    return f"{v:,.{digits}f}"


def cell_label(run: Run, cell: Cell) -> str:
    """The technique and the parameters its cells of the scene sweep (the rest are the same)."""
    alike = [c for c in run.cells_of(cell.scene) if c.technique == cell.technique]
    swept = run.swept_params(alike) if len(alike) > 1 else []
    params = ", ".join(f"{k} {cell.params.get(k)}" for k in swept)
    return f"`{cell.technique}`" + (f" ({params})" if params else "")


def lag_section(run: Run) -> str:
    rows = lag_rows(run)
    out = ["## Lag after a change (B11: popping against lag)", ""]
    if not rows:
        out.append("No cell of the run scores a scene with a scripted event (" + ", ".join(EVENTS) +
                   ") every frame; run configs/paper001.yaml.")
        return "\n".join(out) + "\n"
    out += ["| scene | event (frames) | cell | class | scored frames | settled FLIP | band | lag, frames | "
            "lag, s | paths re-traced | rays traced |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        s = r["settle"]
        lag = None if s is None else s["settle_frame"] - r["start"]
        out.append(
            f"| {r['scene']} | {r['event']} ({r['start']}–{r['stop']}) | {cell_label(run, r['cell'])} | "
            f"{r['class']} | {r['scored']} | {fmt(s and s['settled'], 3)} | {fmt(s and s['band'], 3)} | "
            f"{'not settled' if s is None else lag} | {'–' if lag is None else f'{lag / 30:.2f}'} | "
            f"{fmt(r['paths_retraced'])} | {fmt(r['rays'])} |")
    out += ["", "Lag: frames from the event's first frame until every later score of the window stays within "
            "the band of its settled value (the mean of its last quarter); the band is the larger of 3 "
            "standard deviations of that quarter about its fitted line and the FLIP floor (scores closer than the floor "
            "are not resolved). Work: the counters summed from the event to the settled frame (to the "
            "window's end when not settled). Seconds at the scenes' 30 fps."]
    return "\n".join(out) + "\n"


def setting(cell: Cell, name: str):
    v = cell.params.get(name, DEFAULTS[name])
    if v in ("", None) or (isinstance(v, float) and math.isnan(v)):
        v = DEFAULTS[name]
    return int(float(v)) if isinstance(DEFAULTS[name], int) else str(v)


def gather_label(cell: Cell) -> str:
    if setting(cell, "gather") == "rays":
        return f"rays, {setting(cell, 'gather_rays')}"
    return f"hemi-plane {setting(cell, 'hemi_size')} px, {setting(cell, 'sum_precision')}"


def per_texel_ms(cell: Cell, clock: str) -> Optional[float]:
    """The gather pass's time over the texels it gathered, at the first measured frame."""
    frames, ms = cell.pass_samples("gather", clock)
    c = cell.counters
    if not len(frames) or c is None or c.empty:
        return None
    texels = c[(c["name"] == "texels_gathered") & (c["frame"] == frames[0])]["value"]
    if not len(texels) or float(texels.iloc[0]) <= 0:
        return None
    return float(ms[0]) / float(texels.iloc[0])


def round_median(cells: Sequence[Cell], clock: str) -> Tuple[Optional[float], List[float]]:
    values = [v for v in (per_texel_ms(c, clock) for c in cells) if v is not None]
    return (float(np.median(values)) if values else None), values


def gather_section(run: Run) -> str:
    out = ["## Table 14.2: the final gather per texel, hemi-plane against rays", ""]
    rows = []
    for scene in run.scenes():
        groups: Dict[str, List[Cell]] = {}
        for cell in run.cells_of(scene):
            default_texels = setting(cell, "aim_texels") == DEFAULTS["aim_texels"]
            if (cell.ok and cell.technique == TECHNIQUE and default_texels
                    and per_texel_ms(cell, "auto") is not None):
                groups.setdefault(gather_label(cell), []).append(cell)
        if groups:
            rows.append((scene, groups))
    if not rows:
        return ""
    out += ["| scene (triangles) | gather | ms a texel (median of rounds) | rounds | process CPU ms a texel | "
            "rays' time / this | thesis ms (its render size, polygons) |", "|---|---|---|---|---|---|---|"]
    for scene, groups in rows:
        tri = TRIANGLES.get(scene)
        rays_key = next((k for k in groups if k.startswith("rays")), None)
        rays_ms = round_median(groups[rays_key], "auto")[0] if rays_key else None
        for label in sorted(groups, key=lambda k: (k.startswith("rays"), k)):
            med, values = round_median(groups[label], "auto")
            cpu, _ = round_median(groups[label], "process")
            ratio = "–"
            if rays_ms and med and not label.startswith("rays"):
                ratio = f"{rays_ms / med:.2f}×"
            thesis = "–"
            if label.startswith("rays"):
                thesis = f"{THESIS_RAYS_MS} (1,024 rays, 8,000)"
            elif tri is not None:
                size = setting(groups[label][0], "hemi_size")
                polys = min(THESIS_TABLE_142, key=lambda k: (k[0] != size, abs(math.log(k[1] / tri))))
                if polys[0] == size:
                    thesis = f"{THESIS_TABLE_142[polys]} ({size}, {polys[1]:,})"
            out.append(f"| {scene} ({'–' if tri is None else f'{tri:,}'}) | {label} | {fmt(med, 3)} | "
                       f"{', '.join(f'{v:.3f}' for v in values)} | {fmt(cpu, 3)} | {ratio} | {thesis} |")
    out += ["", "Per texel: frame 0's `gather` pass (every texel of a static scene is gathered there) over its "
            "`texels_gathered`. The thesis's ratio of 1,024 rays to a hemi-plane is 10.5x-22x (a 2004 GPU "
            "against a CPU); here both run on the CPU (lavapipe draws the hemi-planes), so the ratio says "
            "what the hemi-plane costs a software rasteriser, not what it costs a GPU."]
    return "\n".join(out) + "\n"


def resolution_section(run: Run) -> str:
    """Cells alike but for aim_texels, where a scene has two or more values of it: the FLIP mean over
    each value's cells (the rounds) beside the floor."""
    groups: Dict[Tuple[str, str, int], List[Cell]] = {}
    for scene in run.scenes():
        for c in run.cells_of(scene):
            if c.ok and c.technique == TECHNIQUE:
                groups.setdefault((scene, gather_label(c), setting(c, "aim_texels")), []).append(c)
    values: Dict[Tuple[str, str], List[int]] = {}
    for scene, label, texels in groups:
        values.setdefault((scene, label), []).append(texels)
    swept = {k: sorted(v) for k, v in values.items() if len(v) >= 2}
    if not swept:
        return ""
    out = ["## Fig. 14.4: IIM resolution", "",
           "| scene | gather | aim_texels | FLIP (indirect), mean of rounds | rounds | its floor |",
           "|---|---|---|---|---|---|"]
    for (scene, label), texel_values in sorted(swept.items()):
        for texels in texel_values:
            cells = groups[(scene, label, texels)]
            cls = score_class(cells[0])
            flips = [c.metric_mean("flip", cls) for c in cells]
            floors = [c.metric_mean("flip_floor", cls) for c in cells]
            out.append(f"| {scene} | {label} | {texels} | {fmt(float(np.nanmean(flips)), 3)} | {len(cells)} | "
                       f"{fmt(float(np.nanmean(floors)), 3)} |")
    out += ["", "The thesis judged 5 against about 50 texels by eye (Mach banding on the ceiling at 5)."]
    return "\n".join(out) + "\n"


def claims(run: Run) -> str:
    parts = [gather_section(run), resolution_section(run)]
    if any(run.cells_of(scene) for scene in EVENTS):
        parts.append(lag_section(run))
    parts = [p for p in parts if p]
    if not parts:
        raise MissingCells(f"no cell of {TECHNIQUE} on frame 0 and none on {', '.join(EVENTS)}: run "
                           "configs/paper001.yaml or configs/paper001-lag.yaml")
    return f"# {TITLE}\n\n" + "\n".join(parts)
