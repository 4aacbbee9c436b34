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
    Beside each lag, the work the technique did in the window: paths re-traced and rays traced
    (counters `paths_retraced`, `rays_traced` where the technique has them, summed over the window's
    frames), so that two techniques' lags are read at the work each spent.

Scored every frame over the events' windows (the config's metrics_every: 1); the indirect class where the
cell scores it, else the combined image.
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
WORK_COUNTERS = ("paths_retraced", "rays_traced")
MIN_WINDOW = 8  # scored frames a window needs for a lag
TAIL_SHARE = 0.25
MIN_TAIL = 4
NOISE_SIGMAS = 3.0


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
                for counter in WORK_COUNTERS:
                    row[counter] = counter_sum(cell, counter, start, end)
                rows.append(row)
    return rows


def fmt(v: Optional[float], digits: int = 0) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "–"
    return f"{v:,.{digits}f}"


def cell_label(cell: Cell) -> str:
    params = ", ".join(f"{k} {v}" for k, v in sorted(cell.params.items()) if v not in ("", None))
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
            f"| {r['scene']} | {r['event']} ({r['start']}–{r['stop']}) | {cell_label(r['cell'])} | "
            f"{r['class']} | {r['scored']} | {fmt(s and s['settled'], 3)} | {fmt(s and s['band'], 3)} | "
            f"{'not settled' if s is None else lag} | {'–' if lag is None else f'{lag / 30:.2f}'} | "
            f"{fmt(r['paths_retraced'])} | {fmt(r['rays_traced'])} |")
    out += ["", "Lag: frames from the event's first frame until every later score of the window stays within "
            "the band of its settled value (the mean of its last quarter); the band is the larger of 3 "
            "standard deviations of that quarter about its fitted line and the FLIP floor (scores closer than the floor "
            "are not resolved). Work: the counters summed from the event to the settled frame (to the "
            "window's end when not settled). Seconds at the scenes' 30 fps."]
    return "\n".join(out) + "\n"


def claims(run: Run) -> str:
    if not any(run.cells_of(scene) for scene in EVENTS):
        raise MissingCells(f"no cell on {', '.join(EVENTS)}: run configs/paper001.yaml")
    return f"# {TITLE}\n\n" + lag_section(run)
