"""AAPS and MSAA splatting (seed 004, van Casteren 2023) claims, measured on a run of configs/aaps.yaml.

The thesis's trends (digest seed004-aaps.md §2, §4), each set beside what the run measured:
  * quality stops improving at small target areas (Fig. 30: Pool's RMSE is lowest at A_t = 19 and rises
    below; "values below 10 ... should not be chosen");
  * coverage-only MSAA (`all`) dims the caustics and does not help FLIP (§5.1.1, Figs. 35-37);
  * per-sample MSAA (`all_per_sample`) cuts the share of splats that reach no pixel centre or sample
    ("a factor of 6.7 at the smallest target area" on Cornell, §5.1.2) at about twice the cost
    (Fig. 35: 14 ms -> 28 ms);
  * per-sample MSAA for small splats only (`small_per_sample`) improves FLIP beyond a time budget at
    little cost (Fig. 43: above ~3 ms on the RX 6900 XT).
At a fixed budget (Figs. 40 and 43, the thesis's comparisons at equal cost), from a matched run (match.csv;
configs/aaps-equal-time.yaml): each msaa mode's target area at one frame time, FLIP of the caustics class
with its floor (the thesis's whole image holds only direct light and caustics, against a reference of the
same paths) and of the combined image beside it, AAPS's own time there, and whether a mode beats `none`, resolved or not
(tools/pbtools/matching.py's rule), beside the thesis's break-evens (3 ms small_per_sample, 12 ms
all_per_sample, RX 6900 XT); a run without match.csv says so.
FLIP and RMSE are the caustics class against the full reference; time is the sum of the technique's own
passes (photon-trace, rasterize, resolve, apply, task-update), the median frame; shares and energies are
the counters' means over the measured frames. Per-pass medians at each scene's smallest target area stand
for Figs. 26/27 (the thesis's time breakdown). Cells are grouped by (scene, msaa, target_area); cells
of the culling and threshold sweeps are listed in their own tables.
"""

import math
from collections import defaultdict
from typing import Dict, List, Tuple

import numpy as np

from .. import matching
from ..rundata import Cell, Run
from .paper1 import (class_row, equal_time_held, knob_value, matched_pairs, matched_pass_ms, matched_rows,
                     missing_match, score_order)

TITLE = "Extending AAPS for higher quality caustic rendering (van Casteren, MSc thesis 2023)"

AAPS_PASSES = ("photon-trace", "rasterize", "resolve", "apply", "task-update")
MODES = ("none", "all", "all_per_sample", "small_per_sample")


# The thesis's comparisons at a fixed budget of AAPS execution time (RX 6900 XT): mode -> (the budget
# above which it beats `none` in FLIP, where it says so).
THESIS_BREAK_EVEN = {"small_per_sample": (3.0, "Fig. 43, §6.4"), "all_per_sample": (12.0, "Fig. 40, §6.4")}


class MissingCells(Exception):
    pass


def equal_time(run: Run) -> List[str]:
    """Figs. 40 and 43 at one budget, from a matched run (configs/aaps-equal-time.yaml): each msaa mode
    at one frame time (its target area the knob), FLIP of the caustics class beside its floor, and
    whether a mode beats `none` there, resolved or not."""
    out = ["## At a fixed time budget (Figs. 40, 43)",
           "(thesis, RX 6900 XT, FLIP of the whole image against AAPS's execution time as the target area "
           "is swept: per-sample MSAA for small splats only (`small_per_sample`) beats no AA (`none`) "
           "for budgets over 3 ms (Fig. 43, §6.4); per-sample MSAA on every splat (`all_per_sample`) "
           "only over 12 ms (Fig. 40, §6.4). Its comparisons at a fixed cost; it makes none at a fixed "
           "quality)", ""]
    mode, metric, rows = matched_rows(run, ("aaps",))
    if not rows:
        return out + missing_match(("aaps",), "configs/aaps-equal-time.yaml")
    if mode != "time":
        out += [f"This run matched at equal quality ({metric}): the thesis's comparison is at a fixed "
                "time; the modes' times at one error are below (the faster reaches it sooner).", ""]
    out += ["Each mode's target area found by the match for one frame time (AAPS's knob: a smaller area "
            "emits more photons); the achieved frame time over the re-measurement rounds, median [p5, "
            "p95], what the match holds equal; the thesis's x axis, AAPS's own passes (" +
            ", ".join(AAPS_PASSES) + "), as the median of those frames' sums; " + metric +
            f" of AAPS's caustics class against the caustics reference, with that reference's floor "
            "(the thesis's FLIP is of its whole image, direct light and caustics against a reference of "
            "the same paths: the caustics class is the part that differs), and the combined image's "
            "beside it (match.csv's: against the full reference, whose indirect diffuse light AAPS does "
            "not render).", "",
            f"| scene | msaa | status | A_t (px²) | probes | frame ms | AAPS ms | {metric} caustics | "
            f"{metric} combined |", "|---|---|---|---|---|---|---|---|---|"]
    by_scene: Dict[str, Dict[str, Dict[str, str]]] = defaultdict(dict)
    for row, cell in rows:
        msaa = str(cell.params.get("msaa", "none")) if cell is not None else "?"
        caustics = class_row(run, row, metric, "caustics")
        out.append(f"| {row['scene']} | {msaa} | {row['status']} | {knob_value(row)} | {row['probes']} | "
                   f"{matching.time_text(row) or '-'} | {fmt(matched_pass_ms(run, row, AAPS_PASSES), 3)} | "
                   f"{matching.score_text(caustics, metric) or '-'} | "
                   f"{matching.score_text(row, metric) or '-'} |")
        by_scene[row["scene"]][msaa] = caustics
    out.append("")
    modes = ("small_per_sample", "all_per_sample", "all")
    for scene, m, r, none, why in matched_pairs(by_scene, "none", modes):
        if why:
            out.append(f"* {scene}, {m} against none: no comparison, {why}")
            continue
        if mode == "time":
            budget, where = THESIS_BREAK_EVEN.get(m, (math.nan, ""))
            thesis = (f"thesis: {m} beats none above {budget:g} ms of AAPS time ({where})" if where
                      else "thesis: `all` dims the caustic and does not improve FLIP (§5.1.1)")
            out.append(f"* {scene}, {m} against none at {float(r['target']):g} ms a frame (AAPS "
                       f"{fmt(matched_pass_ms(run, r, AAPS_PASSES), 3)} / "
                       f"{fmt(matched_pass_ms(run, none, AAPS_PASSES), 3)} ms; equal time "
                       f"{equal_time_held(r, none)}): {score_order(r, none, metric, m, 'none')} "
                       f"({thesis}).")
        else:
            fast, slow = sorted((r, none), key=lambda x: float(x["wall_ms_median"] or "nan"))
            names = {id(r): m, id(none): "none"}
            out.append(f"* {scene}, {m} against none at {metric} {float(r['target']):g}: "
                       f"{names[id(fast)]} {matching.time_text(fast)} ms is faster than "
                       f"{names[id(slow)]} {matching.time_text(slow)} ms: "
                       f"{matching.order_verdict(fast, slow, metric, 'quality')}.")
    return out + [""]


def frame_ms(cell: Cell) -> float:
    """Median over frames of the technique's own passes (top level only)."""
    t = cell.pass_times()
    t = t[t["pass"].isin(AAPS_PASSES)]
    if t.empty:
        return math.nan
    return float(t.groupby("frame")["ms"].sum().median())


def counter(cell: Cell, name: str) -> float:
    means = cell.counter_means()
    return float(means[name]) if name in means.index else math.nan


def fmt(v: float, digits: int = 4) -> str:
    return "-" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.{digits}g}"


def param(cell: Cell, name: str, default: float) -> float:
    v = cell.params.get(name)
    return default if v is None else float(v)


def culled_sweep(cell: Cell) -> bool:
    return param(cell, "cull_solid_angle", 0.0) > 0


def is_default_sweep(cell: Cell) -> bool:
    """Cells of the target-area x msaa grid: no culling, the default small-splat threshold."""
    return not culled_sweep(cell) and param(cell, "msaa_threshold", 2.0) == 2.0


def per_pass_table(grid: Dict[Tuple[str, str, float], Cell]) -> List[str]:
    """Figs. 26/27: where a frame's time goes, per mode, at each scene's smallest target area."""
    smallest = {}
    for scene, _, area in grid:
        smallest[scene] = min(area, smallest.get(scene, area))
    # summary.csv's medians (Cell.pass_medians): the harness's own, over the measured frames.
    rows = {(scene, mode): grid[(scene, mode, area)].pass_medians()
            for scene, area in smallest.items() for mode in MODES if (scene, mode, area) in grid}
    if not rows:
        return []
    names = [n for n in AAPS_PASSES if any(n in r for r in rows.values())]
    names += sorted({n for r in rows.values() for n in r if n.startswith("task-update/")})
    out = ["## Per-pass time at the smallest target area (Figs. 26/27)", "",
           "Median ms over the measured frames; the task update's nested steps are inside its time.", "",
           "| scene | msaa | A_t (px²) | " + " | ".join(names) + " |",
           "|---|---|---|" + "---|" * len(names)]
    for (scene, mode), r in rows.items():
        out.append(f"| {scene} | {mode} | {fmt(smallest[scene])} | " +
                   " | ".join(fmt(r.get(n, math.nan), 3) for n in names) + " |")
    return out + [""]


def claims(run: Run) -> str:
    cells = [c for c in run.cells if c.technique == "aaps" and c.ok]
    if not cells:
        raise MissingCells("no successful aaps cells (run configs/aaps.yaml)")
    grid: Dict[Tuple[str, str, float], Cell] = {}
    for c in cells:
        if is_default_sweep(c):
            grid[(c.scene, str(c.params.get("msaa", "none")), float(c.params.get("target_area", 19)))] = c
    scenes = sorted({k[0] for k in grid})
    out: List[str] = [f"# Claims: {TITLE}", ""]

    out += ["## Per scene, msaa mode and target area", "",
            "FLIP and RMSE of the caustics class with the reference's floor (what the true image would "
            "score: a FLIP near its floor is unresolved); flicker between consecutive frames with its "
            "floor (the temporal instability per mode).", "",
            "| scene | msaa | A_t (px²) | FLIP | floor | RMSE | flicker | floor | ms/frame | "
            "non-contributing | per-sample splats | energy |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for key in sorted(grid):
        c = grid[key]
        out.append(f"| {key[0]} | {key[1]} | {fmt(key[2])} | {fmt(c.metric_mean('flip', 'caustics'))} | "
                   f"{fmt(c.metric_mean('flip_floor', 'caustics'))} | "
                   f"{fmt(c.metric_mean('rmse', 'caustics'))} | {fmt(c.metric_mean('flicker', 'caustics'))} | "
                   f"{fmt(c.metric_mean('flicker_floor', 'caustics'))} | {fmt(frame_ms(c))} | "
                   f"{fmt(counter(c, 'noncontributing_share'))} | {fmt(counter(c, 'splats_per_sample'))} | "
                   f"{fmt(counter(c, 'caustic_energy'))} |")
    out.append("")

    out += ["## Trends beside the thesis's", ""]
    for scene in scenes:
        areas = sorted({k[2] for k in grid if k[0] == scene}, reverse=True)
        none = [(a, grid[(scene, "none", a)]) for a in areas if (scene, "none", a) in grid]
        out.append(f"### {scene}")
        if len(none) >= 3:
            flips = [c.metric_mean("flip", "caustics") for _, c in none]
            best = int(np.nanargmin(flips))
            stops = best < len(none) - 1
            out.append(f"* quality vs target area (thesis: stops improving below ~19, Fig. 30): FLIP "
                       f"{', '.join(f'{fmt(a)}: {fmt(f)}' for (a, _), f in zip(none, flips))}; lowest at "
                       f"A_t = {fmt(none[best][0])} -> "
                       f"{'stops improving before the smallest A_t (as the thesis)' if stops else 'still improving at the smallest A_t (unlike the thesis)'}")
        small = areas[-1] if areas else None
        if small is not None and (scene, "none", small) in grid:
            n = grid[(scene, "none", small)]
            if (scene, "all", small) in grid:
                a = grid[(scene, "all", small)]
                e_ratio = counter(a, "caustic_energy") / counter(n, "caustic_energy")
                out.append(f"* `all` at A_t = {fmt(small)} (thesis: dimmer, FLIP not better): energy x"
                           f"{fmt(e_ratio, 3)} of none, FLIP {fmt(a.metric_mean('flip', 'caustics'))} vs "
                           f"{fmt(n.metric_mean('flip', 'caustics'))}")
            if (scene, "all_per_sample", small) in grid:
                s = grid[(scene, "all_per_sample", small)]
                cut = counter(n, "noncontributing_share") / counter(s, "noncontributing_share")
                cost = frame_ms(s) / frame_ms(n)
                out.append(f"* `all_per_sample` at A_t = {fmt(small)} (thesis: non-contributing /6.7 on "
                           f"Cornell, ~2x the time): non-contributing /{fmt(cut, 3)}, time x{fmt(cost, 3)}")
            modes = [m for m in MODES if (scene, m, small) in grid]
            out.append(f"* flicker at A_t = {fmt(small)} (the thesis shows fewer fireflies with per-sample "
                       f"MSAA, §5.1.2): " + ", ".join(
                           f"{m} {fmt(grid[(scene, m, small)].metric_mean('flicker', 'caustics'))}"
                           for m in modes))
            if (scene, "small_per_sample", small) in grid:
                s = grid[(scene, "small_per_sample", small)]
                cost = frame_ms(s) / frame_ms(n)
                out.append(f"* `small_per_sample` at A_t = {fmt(small)} (thesis: better FLIP beyond a time "
                           f"budget, little cost): FLIP {fmt(s.metric_mean('flip', 'caustics'))} vs "
                           f"{fmt(n.metric_mean('flip', 'caustics'))}, time x{fmt(cost, 3)}")
        out.append("")

    out += per_pass_table(grid)

    sweeps = defaultdict(list)
    for c in cells:
        if culled_sweep(c):
            sweeps["cull_solid_angle"].append(c)
    thresholds = defaultdict(list)
    for c in cells:
        if str(c.params.get("msaa", "none")) == "small_per_sample" and not culled_sweep(c):
            thresholds[(c.scene, param(c, "target_area", 19.0))].append(c)
    for group in thresholds.values():
        if len({param(c, "msaa_threshold", 2.0) for c in group}) > 1:
            sweeps["msaa_threshold"] += group
    for name, group in sweeps.items():
        thesis = ("Fig. 22: large time gains with little quality change until the lowest thresholds"
                  if name == "cull_solid_angle" else "Fig. 42: FLIP, RMSE and time against the threshold")
        out += [f"## Sweep of {name} ({thesis})", "", f"| scene | {name} | FLIP | RMSE | ms/frame | culled |",
                "|---|---|---|---|---|---|"]
        default = 0.0 if name == "cull_solid_angle" else 2.0
        for c in sorted(group, key=lambda c: (c.scene, param(c, name, default))):
            out.append(f"| {c.scene} | {fmt(param(c, name, default))} | {fmt(c.metric_mean('flip', 'caustics'))} | "
                       f"{fmt(c.metric_mean('rmse', 'caustics'))} | {fmt(frame_ms(c))} | "
                       f"{fmt(counter(c, 'photons_culled'))} |")
        out.append("")
    out += equal_time(run)
    return "\n".join(out) + "\n"
