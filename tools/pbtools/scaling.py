"""How each cost grows with its work (photonbench scaling RUN_DIR [RUN_DIR...]).

A sizing question before a benchmark one: which pass of a technique grows linearly with its budget,
which worse, and where a fixed cost (lavapipe's dispatch and fences, the harness's own work)
flattens a curve. The runs given are pooled; cells that differ in one numeric parameter only (a
budget knob swept in the config) or in the run's pixel count only (the same config run again with
`--set resolution=[W,H]`) form a series. Each pass's median time is fitted against the work on
log-log axes by least squares: time = a * work^slope, so slope 1 is linear, 0 a fixed cost, 2
quadratic. The interval is the slope's 95% t-interval over the series' points (n - 2 degrees of
freedom; none for two points). The slopes of the lowest and the highest pair of points are given
too: a curve that a fixed cost flattens has a low first slope and a steeper last one.

The harness's own cost comes from each cell's `stages_ms` (cell.json: plan, startup, setup,
frames, scoring, teardown): the share of the cell process outside its frame loop, and, inside the
loop, the harness's work between the timed passes (summary.csv's harness_overhead_pct of the
measured frames).

Writes OUT/scaling.csv (one row per series and pass), OUT/harness.csv (one row per cell) and one
log-log figure per series (OUT/scaling-<scene>-<technique>-<work>.png and .svg).
"""

import argparse
import hashlib
import math
import os
import re
import sys
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np
import pandas as pd
from scipy import stats as sstats

from .figures import slug
from .rundata import WHOLE_FRAME_PASS, Cell, Run, RunError

PIXELS = "pixels"  # the work variable of a resolution series
MIN_POINTS = 3  # a knob's series needs this many distinct amounts of work to be fitted
MIN_RUNS = 2  # a pixel series this many resolutions (each a run: a slope without an interval)
MIN_SPAN = 3.0  # ... spanning at least this factor
STAGES = ("plan", "startup", "setup", "frames", "scoring", "teardown")


def fit_loglog(work: Sequence[float], ms: Sequence[float], level: float = 0.95) -> dict:
    """Least squares of log(ms) on log(work). Returns slope, its interval (lo, hi; NaN for two
    points), the first and last pairs' slopes and n. Points with a non-positive value are
    dropped (a log has no place for them)."""
    x = np.asarray(work, dtype=float)
    y = np.asarray(ms, dtype=float)
    keep = (x > 0) & (y > 0) & np.isfinite(x) & np.isfinite(y)
    x, y = np.log(x[keep]), np.log(y[keep])
    order = np.argsort(x, kind="stable")
    x, y = x[order], y[order]
    n = len(x)
    out = {"n": n, "slope": math.nan, "lo": math.nan, "hi": math.nan,
           "slope_first": math.nan, "slope_last": math.nan, "intercept": math.nan}
    if n < 2 or np.ptp(x) == 0:
        return out
    slope, intercept = np.polyfit(x, y, 1)
    out.update(slope=float(slope), intercept=float(intercept))
    ux = np.unique(x)  # repeated amounts (seeds, replicate runs) enter the pairs as their mean
    uy = np.array([y[x == v].mean() for v in ux])
    if len(ux) >= 2:
        out["slope_first"] = float((uy[1] - uy[0]) / (ux[1] - ux[0]))
        out["slope_last"] = float((uy[-1] - uy[-2]) / (ux[-1] - ux[-2]))
    if n > 2:
        residual = y - (slope * x + intercept)
        s2 = float(residual @ residual) / (n - 2)
        se = math.sqrt(s2 / float(((x - x.mean()) ** 2).sum()))
        t = float(sstats.t.ppf(0.5 + level / 2, n - 2))
        out.update(lo=float(slope - t * se), hi=float(slope + t * se))
    return out


def _pixels(run: Run) -> Optional[float]:
    """The run's pixel count: run.json's `resolution`, or (runs recorded before it was) the last
    `--set resolution=[W,H]` override, else the config text's `resolution: [W, H]`."""
    resolution = run.info.get("resolution")
    if isinstance(resolution, list) and len(resolution) == 2:
        return float(resolution[0]) * float(resolution[1])
    pattern = r"resolution\s*[=:]\s*\[\s*(\d+)\s*,\s*(\d+)\s*\]"
    for text in reversed([str(o) for o in run.info.get("overrides") or []]):
        m = re.match(pattern, text.strip())
        if m:
            return float(m.group(1)) * float(m.group(2))
    m = re.search(r"^" + pattern, str(run.info.get("config") or ""), re.MULTILINE)
    return float(m.group(1)) * float(m.group(2)) if m else None


def _numeric(v) -> Optional[float]:
    if isinstance(v, bool):
        return None
    if isinstance(v, (int, float)) and math.isfinite(float(v)):
        return float(v)
    return None


def _pass_times(cell: Cell) -> Dict[str, float]:
    times = dict(cell.pass_medians())
    wall = cell.value("wall_ms_median")
    if not math.isnan(wall):
        times[WHOLE_FRAME_PASS] = wall
    return times


def series(runs: Sequence[Run]) -> List[dict]:
    """The series the runs hold: {scene, technique, work, fixed, points: [(amount, cell)]}, where
    `work` is a parameter's name or PIXELS and `fixed` the other parameters (text)."""
    entries: List[Tuple[Cell, Optional[float], str]] = []
    for run in runs:
        pixels = _pixels(run)
        for cell in run.cells:
            if cell.ok and cell.match_round is None:
                entries.append((cell, pixels, run.path))
    groups: Dict[tuple, List[Tuple[float, Cell]]] = {}
    for cell, pixels, run_path in entries:
        params = {k: v for k, v in cell.params.items()}
        seed = cell.value("seed")
        for name, value in params.items():
            amount = _numeric(value)
            if amount is None or amount <= 0:
                continue
            rest = tuple(sorted((k, repr(v)) for k, v in params.items() if k != name))
            # Runs of one resolution pool; a run whose resolution is unknown stays on its own.
            key = (cell.scene, cell.technique, name, rest, pixels or run_path, seed)
            groups.setdefault(key, []).append((amount, cell))
        if pixels:
            rest = tuple(sorted((k, repr(v)) for k, v in params.items()))
            key = (cell.scene, cell.technique, PIXELS, rest, None, seed)
            groups.setdefault(key, []).append((pixels, cell))
    out = []
    for (scene, technique, work, rest, pixels, _), points in groups.items():
        amounts = sorted({a for a, _ in points})
        least = MIN_RUNS if work == PIXELS else MIN_POINTS
        if len(amounts) < least or amounts[-1] / amounts[0] < MIN_SPAN:
            continue
        out.append({"scene": scene, "technique": technique, "work": work,
                    "pixels": pixels if isinstance(pixels, float) else math.nan,
                    "fixed": ", ".join(f"{k}={v}" for k, v in rest),
                    "points": sorted(points, key=lambda p: p[0])})
    out.sort(key=lambda s: (s["scene"], s["technique"], s["work"], s["fixed"]))
    return out


def _by_pass(s: dict) -> Dict[str, List[Tuple[float, float]]]:
    """A series' points per pass: name -> [(work, median ms)]."""
    out: Dict[str, List[Tuple[float, float]]] = {}
    for amount, cell in s["points"]:
        for name, ms in _pass_times(cell).items():
            out.setdefault(name, []).append((amount, ms))
    return out


def scaling_table(runs: Sequence[Run], all_series: Optional[List[dict]] = None) -> pd.DataFrame:
    rows = []
    for s in series(runs) if all_series is None else all_series:
        for name, pts in sorted(_by_pass(s).items()):
            fit = fit_loglog([a for a, _ in pts], [m for _, m in pts])
            if fit["n"] < 2:
                continue
            rows.append({"scene": s["scene"], "technique": s["technique"], "work": s["work"],
                         "pixels": s["pixels"], "fixed": s["fixed"], "pass": name, "n": fit["n"],
                         "work_min": min(a for a, _ in pts), "work_max": max(a for a, _ in pts),
                         "ms_min": min(m for _, m in pts), "ms_max": max(m for _, m in pts),
                         "slope": fit["slope"], "slope_lo": fit["lo"], "slope_hi": fit["hi"],
                         "slope_first": fit["slope_first"], "slope_last": fit["slope_last"]})
    return pd.DataFrame(rows, columns=["scene", "technique", "work", "pixels", "fixed", "pass", "n",
                                       "work_min", "work_max", "ms_min", "ms_max", "slope",
                                       "slope_lo", "slope_hi", "slope_first", "slope_last"])


def harness_table(runs: Sequence[Run]) -> pd.DataFrame:
    """Per cell: each stage's wall ms, the share of the cell process outside the frame loop
    (1 - frames / all stages) and the harness's share inside it (harness_overhead_pct / 100)."""
    rows = []
    for run in runs:
        for cell in run.cells:
            stages = cell.json.get("stages_ms") or {}
            if not stages:
                continue
            row = {"run": run.name, "cell": cell.id, "scene": cell.scene,
                   "technique": cell.technique}
            for name in STAGES:
                row[f"{name}_ms"] = float(stages.get(name, math.nan))
            total = sum(float(v) for v in stages.values())
            frames = float(stages.get("frames", math.nan))
            row.update(total_ms=total,
                       outside_frames_share=(1 - frames / total) if total > 0 else math.nan,
                       in_frames_share=cell.value("harness_overhead_pct") / 100)
            rows.append(row)
    return pd.DataFrame(rows)


def scaling_figures(runs: Sequence[Run], out_dir: str, max_passes: int = 8,
                    all_series: Optional[List[dict]] = None) -> List[str]:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = []
    for s in series(runs) if all_series is None else all_series:
        by_pass = _by_pass(s)
        # The whole frame and the costliest passes at the largest work: the rest would crowd it.
        names = sorted(by_pass, key=lambda n: -max(m for _, m in by_pass[n]))
        names = [WHOLE_FRAME_PASS] * (WHOLE_FRAME_PASS in by_pass) + \
            [n for n in names if n != WHOLE_FRAME_PASS and "/" not in n][:max_passes - 1]
        fig, ax = plt.subplots(figsize=(6.4, 4.2), constrained_layout=True)
        for name in names:
            pts = sorted(by_pass[name])
            x = np.array([a for a, _ in pts])
            y = np.array([m for _, m in pts])
            fit = fit_loglog(x, y)
            label = f"{name}: slope {fit['slope']:.2f}"
            if not math.isnan(fit["lo"]):
                label += f" [{fit['lo']:.2f}, {fit['hi']:.2f}]"
            line, = ax.plot(x, y, "o", ms=4, label=label,
                            lw=2 if name == WHOLE_FRAME_PASS else 1)
            if not math.isnan(fit["slope"]):
                xs = np.geomspace(x.min(), x.max(), 32)
                ax.plot(xs, np.exp(fit["intercept"]) * xs ** fit["slope"], "-",
                        color=line.get_color(), lw=2 if name == WHOLE_FRAME_PASS else 1)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(f"{s['work']} (work)")
        ax.set_ylabel("wall median per frame [ms]")
        at = "" if math.isnan(s["pixels"]) else f" at {s['pixels']:.0f} px"
        # The other parameters are in scaling.csv's `fixed` (a technique's whole list does not fit).
        ax.set_title(f"{s['scene']}: {s['technique']}{at}", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7, loc="upper left")
        stem = os.path.join(out_dir, f"scaling-{slug(s['scene'])}-{slug(s['technique'])}-"
                                     f"{slug(s['work'])}")
        if not math.isnan(s["pixels"]):
            stem += f"-{s['pixels']:.0f}px"
        if s["fixed"]:
            stem += "-" + hashlib.sha1(s["fixed"].encode()).hexdigest()[:6]
        for ext in ("png", "svg"):
            fig.savefig(f"{stem}.{ext}", dpi=110)
        plt.close(fig)
        written.append(stem + ".png")
    return written


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(
        prog="photonbench scaling",
        description="Each pass's time against its work on log-log axes, with fitted slopes and "
                    "their intervals, and the harness's own share of each cell (module docstring).")
    ap.add_argument("runs", nargs="+", metavar="RUN_DIR")
    ap.add_argument("--out", help="output folder (default: FIRST_RUN/scaling)")
    a = ap.parse_args(argv)
    try:
        runs = [Run(p) for p in a.runs]
    except RunError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    out = a.out or os.path.join(runs[0].path, "scaling")
    os.makedirs(out, exist_ok=True)
    all_series = series(runs)  # read once: the table and the figures draw the same series
    table = scaling_table(runs, all_series)
    harness = harness_table(runs)
    table.to_csv(os.path.join(out, "scaling.csv"), index=False, float_format="%.6g")
    harness.to_csv(os.path.join(out, "harness.csv"), index=False, float_format="%.6g")
    figures = scaling_figures(runs, out, all_series=all_series)
    if table.empty:
        print("scaling: no series (cells differing in one numeric parameter, or runs differing in "
              f"resolution only, with {MIN_POINTS}+ amounts over {MIN_SPAN:g}x)", file=sys.stderr)
    else:
        whole = table[table["pass"] == WHOLE_FRAME_PASS]
        for _, r in (whole if not whole.empty else table).iterrows():
            interval = ("" if math.isnan(r["slope_lo"])
                        else f" [{r['slope_lo']:.2f}, {r['slope_hi']:.2f}]")
            at = "" if math.isnan(r["pixels"]) else f" at {r['pixels']:.0f} px"
            print(f"{r['scene']:16s} {r['technique']:22s} {r['work']:12s} "
                  f"{r['work_min']:g}..{r['work_max']:g}{at}: frame slope {r['slope']:.2f}{interval} "
                  f"(first {r['slope_first']:.2f}, last {r['slope_last']:.2f})")
    if not harness.empty:
        print(f"cell processes outside their frame loop: median "
              f"{100 * harness['outside_frames_share'].median():.1f}% of their time; the harness "
              f"between timed passes: median {100 * harness['in_frames_share'].median():.2f}% of "
              f"the measured frames ({len(harness)} cells)")
    print(f"scaling: {len(table)} rows, {len(figures)} figures in {out}")
    return 0
