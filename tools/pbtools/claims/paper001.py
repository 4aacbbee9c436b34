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
  * **lag at equal rays**: where a technique's budget is swept (configs/paper001-lag.yaml sweeps
    path-verification's photons), each other cell beside the sweep's cell whose rays over the event's
    whole window (the same frames for every cell, so a budget that does not depend on the lag) are
    nearest to its own by ratio, with the ratio and the two cells of the sweep that bracket it (no
    interpolation: a lag is a count of frames).

Scored every frame over the events' windows (the config's metrics_every: 1); the indirect class where the
cell scores it, else the combined image.

And on a run of configs/paper001.yaml (frame 0 of static scenes, where every IIM texel is gathered):
  * **Table 14.2**: the final gather's time per texel (the `gather` pass over the `texels_gathered`
    counter, frame 0), the hemi-plane at each size against the cosine rays, per scene and its triangles,
    with the rays-over-raster ratio beside the thesis's (16.7 ms for 1,024 rays against 0.75-1.59 ms a
    hemi-plane: 10.5x-22x); per round (the seed axis' rounds) and the median over the rounds, on the
    pass's time and on the process CPU time it took (lavapipe draws on the CPU here);
  * **Fig. 14.4**: the indirect FLIP of IIMs at each `aim_texels` beside its floor.

And for the screen-space caustics (Ch. 12; techniques/screen-caustics):
  * on a run of configs/screen-caustics-culling.yaml, Eq. 12.1's filter over the culled grid (the
    thesis's occlusion queries) against the full screen (`grid: 1`), cells alike but for `grid`: per
    scene the active cells, the `filter` pass's GPU time, the `grid` pass's GPU time and its read-back's
    CPU time, grid + filter, each the median (quartiles) over the rounds' frames pooled; the ratio
    culled / full of the pooled medians (and per round); whether the images are the same, where the run
    scored frames;
  * on a run of configs/screen-caustics-equal-time.yaml (match.csv), screen-caustics beside aaps at one
    frame time: each one's knob as found, its probes, the frame time (median [p5, p95]), FLIP of the
    caustics class and of the combined image beside the reference's floor, and whether each order is
    resolved (tools/pbtools/matching.py's rule; "not resolved" when the difference is within the floors).
"""

import math
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from .. import matching
from ..rundata import Cell, Run, format_param
from .paper1 import class_row, knob_value, matched_pairs, matched_rows

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
    # Never outside the band: the change, if any, is not resolved from the noise and the floor (a lag
    # of 0 here says nothing about how fast the technique follows).
    return {"settled": settled, "band": band, "settle_frame": int(frames[first]), "unresolved": len(outside) == 0}


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


def rays_sum(cell: Cell, first: int, last: int) -> Optional[float]:
    """Rays the cell traced over frames [first, last]: whichever of RAYS_COUNTERS it reports."""
    return next((r for r in (counter_sum(cell, c, first, last) for c in RAYS_COUNTERS) if r is not None),
                None)


def retracing_frames(cell: Cell, first: int, last: int) -> Optional[int]:
    """Frames from `first` until the cell's last frame of [first, last] that re-traced a path (0: none
    re-traced from `first` on); None when it reports no re-traced paths, or when it still re-traces at
    `last` (its work has not settled in the window)."""
    c = cell.counters
    if c is None or c.empty or PATHS_COUNTER not in set(c["name"]):
        return None
    rows = c[(c["name"] == PATHS_COUNTER) & (c["frame"] >= first) & (c["frame"] <= last)]
    busy = rows[rows["value"] > 0]["frame"]
    if not len(busy):
        return 0
    return None if int(busy.max()) >= last else int(busy.max()) - first + 1


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
                if not len(wf):  # the event lies outside the frames the run scored
                    continue
                wfl = np.array([floor_by_frame.get(f, np.nan) for f in wf]) if floor_by_frame else None
                s = settle(wf, wv, wfl)
                row = {"scene": scene, "cell": cell, "event": name, "start": start, "stop": stop,
                       "class": cls, "scored": len(wf), "settle": s}
                end = s["settle_frame"] if s else hi
                row["paths_retraced"] = counter_sum(cell, PATHS_COUNTER, start, end)
                row["rays"] = rays_sum(cell, start, end)
                row["window_rays"] = rays_sum(cell, lo, hi)
                row["retracing"] = retracing_frames(cell, start, hi)
                row["retracing_known"] = counter_sum(cell, PATHS_COUNTER, start, hi) is not None
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


def lag_of(row: dict) -> Optional[int]:
    return None if row["settle"] is None else row["settle"]["settle_frame"] - row["start"]


def lag_text(row: dict) -> str:
    lag = lag_of(row)
    if lag is None:
        return "not settled"
    return f"{lag} (never left the band)" if row["settle"]["unresolved"] else str(lag)


def equal_rays_pairs(rows: List[dict]):
    """(row of a cell, the other technique's rows ordered by their rays, its nearest row in rays) for
    every cell with rays over its window and every other technique of the same event with two or more
    such cells (a sweep of its budget): nearest by the ratio of the rays over the event's window."""
    events: Dict[Tuple[str, str], Dict[str, List[dict]]] = {}
    for r in rows:
        if r["window_rays"]:
            events.setdefault((r["scene"], r["event"]), {}).setdefault(r["cell"].technique, []).append(r)
    for by_technique in events.values():
        for technique, own in by_technique.items():
            for other, sweep in by_technique.items():
                if other == technique or len(sweep) < 2:
                    continue
                sweep = sorted(sweep, key=lambda r: r["window_rays"])
                for r in own:
                    nearest = min(sweep, key=lambda s: abs(math.log(s["window_rays"] / r["window_rays"])))
                    yield r, sweep, nearest


def equal_rays_lines(run: Run, rows: List[dict]) -> List[str]:
    pairs = list(equal_rays_pairs(rows))
    if not pairs:
        return []
    out = ["", "### At equal rays", "",
           "Each cell beside the cell of another technique's budget sweep whose rays over the event's "
           "window (from the event's first frame to the window's last, the same frames for every cell) "
           "are nearest to its own (nearest by their ratio; no interpolation: a lag is a count of frames), "
           "with the ratio of the two and the sweep's cells that bracket it.", "",
           "| scene | event | cell | rays over the window | lag, frames | nearest in rays | its rays over the "
           "window | rays ratio (nearest / cell) | its lag, frames | the sweep's bracketing cells: lag (rays) |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for r, sweep, nearest in pairs:
        below = [s for s in sweep if s["window_rays"] <= r["window_rays"]]
        above = [s for s in sweep if s["window_rays"] >= r["window_rays"]]
        if below and above:
            ends = [below[-1]] + ([above[0]] if above[0] is not below[-1] else [])
            bracket = "; ".join(f"{cell_label(run, s['cell'])}: {lag_text(s)} ({fmt(s['window_rays'])})"
                                for s in ends)
        else:
            bracket = "none: every cell of the sweep traced " + ("more" if not below else "fewer")
        out.append(f"| {r['scene']} | {r['event']} | {cell_label(run, r['cell'])} | {fmt(r['window_rays'])} | "
                   f"{lag_text(r)} | {cell_label(run, nearest['cell'])} | {fmt(nearest['window_rays'])} | "
                   f"{nearest['window_rays'] / r['window_rays']:.2f} | {lag_text(nearest)} | {bracket} |")
    return out


def retracing_text(row: dict) -> str:
    if not row["retracing_known"]:
        return "–"
    return "still at the window's end" if row["retracing"] is None else str(row["retracing"])


def lag_section(run: Run) -> str:
    rows = lag_rows(run)
    out = ["## Lag after a change (B11: popping against lag)", ""]
    if not rows:
        out.append("No cell of the run scores a scene with a scripted event (" + ", ".join(EVENTS) +
                   ") every frame; run configs/paper001.yaml.")
        return "\n".join(out) + "\n"
    out += ["| scene | event (frames) | cell | class | scored frames | settled FLIP | band | lag, frames | "
            "lag, s | paths re-traced | rays traced | re-tracing, frames |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        s = r["settle"]
        lag = lag_of(r)
        out.append(
            f"| {r['scene']} | {r['event']} ({r['start']}–{r['stop']}) | {cell_label(run, r['cell'])} | "
            f"{r['class']} | {r['scored']} | {fmt(s and s['settled'], 3)} | {fmt(s and s['band'], 3)} | "
            f"{lag_text(r)} | {'–' if lag is None else f'{lag / 30:.2f}'} | "
            f"{fmt(r['paths_retraced'])} | {fmt(r['rays'])} | {retracing_text(r)} |")
    out += ["", "Lag: frames from the event's first frame until every later score of the window stays within "
            "the band of its settled value (the mean of its last quarter; a series that never left the band "
            "has a change too small to resolve, and a lag of 0 that says nothing); the band is the larger of 3 "
            "standard deviations of that quarter about its fitted line and the FLIP floor (scores closer than the floor "
            "are not resolved). Work: the counters summed from the event to the settled frame (to the "
            "window's end when not settled). Seconds at the scenes' 30 fps. Re-tracing: frames from the "
            "event until the technique re-traced its last path in the window, the lag of its work (a cache "
            "that probes a share of its paths a frame, such as selective emission's one photon a group a "
            "frame, keeps re-tracing after its image has settled; 'still at the window's end' when it "
            "re-traced at the window's last frame)."]
    out += equal_rays_lines(run, rows)
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


SCREEN_CAUSTICS = "screen-caustics"
AAPS = "aaps"
GRID_DEFAULT = 10  # techniques/screen-caustics: `grid`'s default
FULL_SCREEN = 1  # grid 1: one cell, every diffuse pixel filtered (no culling)
CULLING_PASSES = ("grid", "filter")


def grid_of(cell: Cell) -> int:
    v = cell.params.get("grid", GRID_DEFAULT)
    return int(float(v)) if v not in ("", None) else GRID_DEFAULT


def pooled(cells: Sequence[Cell], name: str, clock: str) -> np.ndarray:
    """One pass's times on one clock over every measured frame of `cells` (the rounds' frames pooled)."""
    parts = [c.pass_samples(name, clock)[1] for c in cells]
    return np.concatenate(parts) if parts else np.zeros(0)


def pooled_totals(cells: Sequence[Cell]) -> np.ndarray:
    """Per frame, grid and filter each on the clock it ran on (the harness's rule: the larger of its GPU
    and CPU times; the grid's CPU time holds the read-back that waits for its dispatch), summed."""
    parts = [c.pass_sums(CULLING_PASSES).to_numpy(float) for c in cells]
    return np.concatenate(parts) if parts else np.zeros(0)


def median_quartiles(values: np.ndarray, digits: int = 2) -> str:
    if not len(values):
        return "–"
    q1, med, q3 = np.percentile(values, [25, 50, 75])
    return f"{med:.{digits}f} ({q1:.{digits}f}–{q3:.{digits}f})"


def counter_values(cells: Sequence[Cell], name: str) -> np.ndarray:
    parts = [c.counters[c.counters["name"] == name]["value"].dropna().to_numpy(float) for c in cells
             if c.counters is not None and not c.counters.empty]
    return np.concatenate(parts) if parts else np.zeros(0)


def active_text(cells: Sequence[Cell], grid: int) -> str:
    active = counter_values(cells, "cells_active")
    if not len(active):
        return "–"
    skipped = counter_values(cells, "cells_skipped")
    total = int(active[0] + skipped[0]) if len(skipped) else grid * grid
    return f"{format_param(float(np.median(active)))} of {total}"


def by_seed(cells: Sequence[Cell]) -> Dict[str, Cell]:
    return {c.text("seed"): c for c in cells}


# OpenEXR header attributes that say when the file was written, not what it holds.
EXR_TIME_ATTRIBUTES = {b"capDate", b"utcOffset"}


def exr_parts(path: str) -> Tuple[Dict[bytes, bytes], bytes]:
    """An OpenEXR file's header attributes (name -> type and value) and everything after the header
    (the chunk offsets and the pixel chunks). A header starts with the magic number and version (8
    bytes), then attributes as name NUL type NUL size (int32, little-endian) value, ending at an empty
    name."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] != b"\x76\x2f\x31\x01":
        raise ValueError(f"{path}: not an OpenEXR file")
    attributes, at = {}, 8
    while data[at:at + 1] != b"\x00":
        name_end = data.index(b"\x00", at)
        type_end = data.index(b"\x00", name_end + 1)
        size = int.from_bytes(data[type_end + 1:type_end + 5], "little")
        attributes[data[at:name_end]] = data[name_end + 1:type_end + 5 + size]
        at = type_end + 5 + size
    return attributes, data[at + 1:]


def same_pixels(a: str, b: str) -> bool:
    """Whether two EXRs of one writer hold the same pixels: the same header but for the time it was
    written, and the same chunks (a deterministic lossless compressor gives equal chunks for equal
    pixels, and different chunks only for different ones)."""
    (ha, ca), (hb, cb) = exr_parts(a), exr_parts(b)
    strip = lambda h: {k: v for k, v in h.items() if k not in EXR_TIME_ATTRIBUTES}  # noqa: E731
    return strip(ha) == strip(hb) and ca == cb


def images_verdict(culled: Sequence[Cell], full: Sequence[Cell]) -> str:
    """Whether the EXR images both settings wrote (cells of one seed, the same frame and class) hold the
    same pixels (same_pixels)."""
    full_by_seed = by_seed(full)
    same = differ = 0
    for seed, c in by_seed(culled).items():
        f = full_by_seed.get(seed)
        if f is None:
            continue
        theirs = {k: v for k, v in f.images().items() if k[0] == "frame" and k[3] == "exr"}
        for key, path in c.images().items():
            if key in theirs:
                if same_pixels(path, theirs[key]):
                    same += 1
                else:
                    differ += 1
    if same + differ == 0:
        return "not recorded (no scored frame: no images to compare)"
    if differ:
        return f"differ: {differ} of {same + differ} images"
    return f"identical, pixel for pixel ({same} images)"


def culling_groups(run: Run, scene: str) -> List[Tuple[str, Dict[int, List[Cell]]]]:
    """(what tells the group apart, grid -> cells) of screen-caustics cells of `scene` alike but for
    `grid` and the seed, where the group holds the full screen and a culled grid."""
    cells = [c for c in run.cells_of(scene) if c.ok and c.technique == SCREEN_CAUSTICS
             and c.match_round is None and len(c.pass_samples("filter")[0])]
    swept = [p for p in run.swept_params(cells) if p != "grid"] if len(cells) > 1 else []
    groups: Dict[tuple, Dict[int, List[Cell]]] = {}
    for c in cells:
        key = tuple(sorted((k, format_param(v)) for k, v in c.params.items() if k != "grid"))
        groups.setdefault(key, {}).setdefault(grid_of(c), []).append(c)
    out = []
    for key, by_grid in groups.items():
        if FULL_SCREEN in by_grid and any(g != FULL_SCREEN for g in by_grid):
            out.append((", ".join(f"{k} {v}" for k, v in key if k in swept), by_grid))
    return out


def culling_section(run: Run) -> str:
    """Ch. 12's occlusion queries: the filter over the culled grid against the full screen."""
    found = [(scene, label, by_grid) for scene in run.scenes() for label, by_grid in culling_groups(run, scene)]
    if not found:
        return ""
    out = ["## Eq. 12.1's filter over the culled grid against the full screen (Ch. 12)", "",
           "The thesis culls the filter with occlusion queries on a 10 x 10 screen grid; `grid: 1` is one "
           "cell, every diffuse pixel filtered. Medians (quartiles) over every measured frame of the "
           "rounds, pooled.", "",
           "| scene | grid | rounds | frames | active cells | `filter` GPU ms | `grid` GPU ms | "
           "`grid` read-back CPU ms | grid + filter ms |", "|---|---|---|---|---|---|---|---|---|"]
    notes = []
    for scene, label, by_grid in found:
        name = f"{scene} ({label})" if label else scene
        for grid in sorted(by_grid, reverse=True):
            cells = by_grid[grid]
            totals = pooled_totals(cells)
            grid_text = "1 (full screen)" if grid == FULL_SCREEN else f"{grid} x {grid}"
            out.append(f"| {name} | {grid_text} | {len(cells)} | {len(totals)} | {active_text(cells, grid)} | "
                       f"{median_quartiles(pooled(cells, 'filter', 'gpu'))} | "
                       f"{median_quartiles(pooled(cells, 'grid', 'gpu'))} | "
                       f"{median_quartiles(pooled(cells, 'grid', 'cpu'))} | {median_quartiles(totals)} |")
        full = by_grid[FULL_SCREEN]
        full_total = pooled_totals(full)
        for grid in sorted(g for g in by_grid if g != FULL_SCREEN):
            culled = by_grid[grid]
            culled_total = pooled_totals(culled)
            ratio = (float(np.median(culled_total)) / float(np.median(full_total))
                     if len(culled_total) and len(full_total) else math.nan)
            rounds = []
            full_by_seed = by_seed(full)
            for seed, c in by_seed(culled).items():
                if seed not in full_by_seed:
                    continue
                a, b = pooled_totals([c]), pooled_totals([full_by_seed[seed]])
                if len(a) and len(b):
                    rounds.append(float(np.median(a)) / float(np.median(b)))
            per_round = (f"; per round {min(rounds):.2f}–{max(rounds):.2f}" if len(rounds) > 1 else "")
            notes.append(f"* {name}, {grid} x {grid} against the full screen: culled / full, grid + filter "
                         f"(the pooled medians' ratio) {fmt(ratio, 2)}{per_round}; images: "
                         f"{images_verdict(culled, full)}.")
    out += [""] + notes + ["", "grid + filter: per frame, each pass on the clock it ran on (the larger of "
                           "its GPU and CPU times, the harness's rule; the grid's CPU time is the read-back "
                           "of its flags, which waits for its dispatch), summed. Images: the EXRs both "
                           "settings wrote at a scored frame (cells of one seed), their pixel chunks "
                           "compared byte for byte (the header's write time aside)."]
    return "\n".join(out) + "\n"


def equal_time_section(run: Run) -> str:
    """screen-caustics beside aaps at one frame time, from a matched run
    (configs/screen-caustics-equal-time.yaml)."""
    mode, metric, rows = matched_rows(run, (SCREEN_CAUSTICS, AAPS))
    if not any(row["technique"] == SCREEN_CAUSTICS for row, _ in rows):
        return ""
    at = "time" if mode == "time" else f"quality ({metric})"
    name = "FLIP" if metric == "flip" else metric
    out = [f"## Screen-space caustics beside AAPS at equal {at}", "",
           "Each technique's budget knob as the match found it, the probes it took, the achieved frame time "
           "(median [p5, p95] over the found setting's re-measurement rounds), and " + name + " of the "
           "caustics class and of the combined image, each with the reference's floor (what the true "
           "image would score: a difference under it is not resolved).", "",
           f"| scene | technique | status | knob found | probes | frame ms | {name} caustics | "
           f"{name} combined |", "|---|---|---|---|---|---|---|---|"]
    by_scene: Dict[str, Dict[str, dict]] = {}
    classes: Dict[str, Dict[str, dict]] = {}
    for row, _ in rows:
        caustics = class_row(run, row, metric, "caustics")
        knob = f"{row['knob']} = {knob_value(row)}" if row.get("knob_value") else "–"
        out.append(f"| {row['scene']} | `{row['technique']}` | {row['status']} | {knob} | {row['probes']} | "
                   f"{matching.time_text(row) or '–'} | {matching.score_text(caustics, metric) or '–'} | "
                   f"{matching.score_text(row, metric) or '–'} |")
        by_scene.setdefault(row["scene"], {})[row["technique"]] = row
        classes.setdefault(row["scene"], {})[row["technique"]] = caustics
    out.append("")
    for scene, _, aaps, sc, why in matched_pairs(by_scene, SCREEN_CAUSTICS, (AAPS,)):
        if why:
            out.append(f"* {scene}: no comparison, {why}.")
            continue
        out.append(f"* {scene}, caustics: "
                   f"{score_order_text(classes[scene][SCREEN_CAUSTICS], classes[scene][AAPS], metric, mode)}")
        out.append(f"* {scene}, combined: {score_order_text(sc, aaps, metric, mode)}")
    return "\n".join(out) + "\n"


def score_order_text(a: dict, b: dict, metric: str, mode: str) -> str:
    """Which of two match rows scores better, the difference beside the floors, and whether the order
    holds against the reference's noise (matching.order_verdict's rule)."""
    va, vb = (float(r.get(metric) or "nan") for r in (a, b))
    if math.isnan(va) or math.isnan(vb):
        return f"{metric} not scored"
    better, worse = (a, b) if va <= vb else (b, a)
    verdict = matching.order_verdict(better, worse, metric, "time")
    verdict = {"unresolved": "not resolved"}.get(verdict, verdict)
    floors = " / ".join(fmt(float(r.get(f"{metric}_floor") or "nan"), 3) for r in (better, worse))
    note = "" if mode == "time" else " (a quality match: the times differ, not the scores)"
    return (f"`{better['technique']}` {fmt(min(va, vb), 3)} against `{worse['technique']}` "
            f"{fmt(max(va, vb), 3)}, a difference of {fmt(abs(va - vb), 3)} beside the floors {floors}: "
            f"{verdict}{note}.")


def claims(run: Run) -> str:
    parts = [gather_section(run), resolution_section(run), culling_section(run), equal_time_section(run)]
    if any(run.cells_of(scene) for scene in EVENTS):
        parts.append(lag_section(run))
    parts = [p for p in parts if p]
    if not parts:
        raise MissingCells(f"no cell of {TECHNIQUE} on frame 0, none on {', '.join(EVENTS)}, no "
                           f"{SCREEN_CAUSTICS} cells alike but for grid and no match of it: run "
                           "configs/paper001.yaml, configs/paper001-lag.yaml, "
                           "configs/screen-caustics-culling.yaml or configs/screen-caustics-equal-time.yaml")
    return f"# {TITLE}\n\n" + "\n".join(parts)
