"""Reflective-shadow-map photons (seed 000, the thesis behind Ray Tracing Gems ch. 24) claims, measured on
a run of configs/rsm-photons.yaml.

The thesis judged its stages by eye (digest seed000-rsm-photons.md §4: side-by-side and difference
images, no error metric); the run scores them. Per scene:
  * the stage ablation: the raw splat (filters none), the temporal filter alone, the a-trous filter alone,
    both (the thesis's chain), the variants the config adds (no detail clip, the direction term, another
    n_tile, the tracer's sampling, gathering instead of splatting) and `direct` (no indirect light), each
    with FLIP, SSIM, PSNR and flicker of the combined and the indirect class beside its noise floor (what
    the true image would score against these references); a FLIP under 4x its floor is unresolved;
  * per-stage times grouped as the thesis's Fig. 1.2 (RSM, photon tracing, the screen-space estimate,
    filters) as shares of their sum (the thesis's Total) and the sum as a share of the whole frame, beside
    the thesis's own shares (Conference room and Sponza, 1 M photons at 1080p, §8.2-8.3);
  * splatting against gathering (§6.3-6.4, Table 6.1): the estimate's time, gathering over splatting, and
    the two cells' scores;
  * the thesis's statements where it makes one, each with what the measurement says.
A cell's stage is read from its parameters (temporal, spatial, estimate, detail_clip, direction_term,
n_tile, sampler; a parameter the cell does not set has the technique's default). Times are the harness's
rule for a pass's time (the larger of its GPU and CPU times: where it ran), the mean over the measured
frames; with `process` CPU time recorded (lavapipe's fenced timing) the shares on it are given too, since
on a shared machine a pass's wall time includes waiting for a core.
"""

import math
from collections import OrderedDict
from typing import Dict, List, Optional, Tuple

import numpy as np

from .. import floors
from ..rundata import Cell, Run

TITLE = ("Real-time global illumination with photon mapping: reflective-shadow-map photons, screen-space "
         "splatting and filtering (seed 000, the thesis behind Ray Tracing Gems ch. 24)")
TECHNIQUE = "rsm-photons"
NO_GI = "direct"

# The technique's defaults for the parameters that name a cell's stage (techniques/rsm-photons).
DEFAULTS = {"temporal": True, "spatial": True, "estimate": "splat", "detail_clip": True,
            "direction_term": False, "n_tile": 3.2, "sampler": "wavelet"}
FILTER_STAGES = OrderedDict([((False, False), "filters none"), ((True, False), "temporal only"),
                             ((False, True), "spatial only"), ((True, True), "both")])
# Fig. 1.2's groups: the top-level passes of each (the filters group includes the G-buffer read-back and
# the bilinear upsampling, §6.2.1: "at the start of the temporal pass").
GROUPS = OrderedDict([("RSM", ("rsm",)), ("photon tracing", ("photon-trace",)),
                      ("estimate", ("estimate",)), ("filters", ("filters",))])
WHOLE_FRAME = "frame"
# The thesis's RSM, PT, SSIE, F in ms (1 M photons, 4 iterations, 1080p; §8.2 and §8.3).
THESIS_TIMES = OrderedDict([("Conference room", (0.6, 0.7, 4.1, 3.0)), ("Sponza", (1.8, 1.6, 8.0, 3.6))])
# Table 6.1: SSIE ms, splatting (ellipsoid test) and gathering.
THESIS_TABLE_61 = OrderedDict([("Sponza, 500,000 photons", (1.3, 6.6)),
                               ("Conference room, 100,000 photons", (0.9, 7.4))])
METRICS = (("flip", 3), ("ssim", 3), ("psnr", 2), ("flicker", 3))
CLASSES = ("combined", "indirect")
RESOLVED = floors.RESOLVE_FACTOR  # a score resolved at this many times its floor (floors.py)


class MissingCells(Exception):
    pass


def setting(cell: Cell, name: str):
    """The cell's value of a stage parameter, its default where the cell does not set it."""
    v = cell.params.get(name, DEFAULTS[name])
    if isinstance(DEFAULTS[name], bool) and isinstance(v, str):
        return v.strip().lower() in ("true", "1", "yes")
    if isinstance(DEFAULTS[name], bool):
        return bool(v)
    if isinstance(DEFAULTS[name], float):
        return float(v)
    return str(v)


def stage_label(cell: Cell) -> str:
    """"both", "temporal only", ..., then each non-default variant: "both, estimate gather"."""
    if cell.technique != TECHNIQUE:
        return f"`{cell.technique}` (no indirect light)" if cell.technique == NO_GI else f"`{cell.technique}`"
    label = FILTER_STAGES[(setting(cell, "temporal"), setting(cell, "spatial"))]
    extras = []
    if setting(cell, "estimate") != DEFAULTS["estimate"]:
        extras.append(f"estimate {setting(cell, 'estimate')}")
    if not setting(cell, "detail_clip"):
        extras.append("no detail clip")
    if setting(cell, "direction_term"):
        extras.append("direction term")
    if setting(cell, "n_tile") != DEFAULTS["n_tile"]:
        extras.append(f"n_tile {setting(cell, 'n_tile'):g}")
    if setting(cell, "sampler") != DEFAULTS["sampler"]:
        extras.append(f"sampler {setting(cell, 'sampler')}")
    return ", ".join([label] + extras)


def stage_order(cell: Cell) -> Tuple[int, int, int, str]:
    """The ablation's order: the technique's cells before `direct`, the filter stages as listed in
    FILTER_STAGES, each stage's default before its variants."""
    if cell.technique != TECHNIQUE:
        return (1, 0, 0, cell.technique)
    stage = list(FILTER_STAGES).index((setting(cell, "temporal"), setting(cell, "spatial")))
    label = stage_label(cell)
    return (0, stage, int("," in label), label)


def fmt(v: Optional[float], digits: int = 3) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return "-"
    return f"{v:.{digits}f}" if digits > 0 and abs(v) < 1e4 else f"{v:,.0f}"


def with_floor(cell: Cell, metric: str, path_class: str, digits: int) -> str:
    """"0.162 (0.031)": the metric's mean over the scored frames and its floor's; FLIP under 4x its
    floor marked unresolved."""
    value = cell.metric_mean(metric, path_class)
    if math.isnan(value):
        return "-"
    floor = cell.metric_mean(metric + "_floor", path_class)
    text = f"{fmt(value, digits)} ({fmt(floor, digits)})"
    if metric == "flip" and floors.resolved(metric, value, floor) is False:
        text += " unresolved"
    return text


def group_means(cell: Cell, clock: str = "auto") -> Dict[str, float]:
    """Mean ms per frame of each Fig. 1.2 group and of the whole frame, over the measured frames."""
    t = cell.pass_times(clock)
    frames = np.unique(t["frame"].to_numpy()) if len(t) else np.zeros(0)
    out = {}
    for group, passes in list(GROUPS.items()) + [(WHOLE_FRAME, (WHOLE_FRAME,))]:
        rows = t[t["pass"].isin(passes)]
        out[group] = float(rows["ms"].sum() / len(frames)) if len(frames) and len(rows) else math.nan
    return out


def shares(times: Dict[str, float]) -> Tuple[Dict[str, float], float]:
    """Each group's share of the groups' sum (the thesis's Total), and that sum's share of the frame."""
    total = sum(v for g, v in times.items() if g in GROUPS and not math.isnan(v))
    out = {g: times[g] / total if total > 0 and not math.isnan(times[g]) else math.nan for g in GROUPS}
    frame = times.get(WHOLE_FRAME, math.nan)
    return out, (total / frame if total > 0 and frame > 0 else math.nan)


def percent(v: float) -> str:
    if math.isnan(v):
        return "-"
    return f"{100 * v:.1f}%" if v < 0.01 else f"{100 * v:.0f}%"


def estimate_ratio(gather: Cell, splat: Cell, clock: str) -> float:
    g, s = group_means(gather, clock)["estimate"], group_means(splat, clock)["estimate"]
    return g / s if s > 0 else math.nan


def ablation_table(cells: List[Cell]) -> List[str]:
    out = ["| cell | " + " | ".join(f"{c} {m.upper() if m != 'flicker' else m} (floor)"
                                    for c in CLASSES for m, _ in METRICS) + " |",
           "|---|" + "---|" * (len(CLASSES) * len(METRICS))]
    for c in cells:
        out.append(f"| {stage_label(c)} | " + " | ".join(with_floor(c, m, cls, d) for cls in CLASSES
                                                         for m, d in METRICS) + " |")
    return out


def times_table(cells: List[Cell], clock: str) -> List[str]:
    out = ["| cell | frame ms | " + " | ".join(f"{g} ms (share)" for g in GROUPS) +
           " | the four / frame |", "|---|---|" + "---|" * len(GROUPS) + "---|"]
    for c in cells:
        times = group_means(c, clock)
        share, of_frame = shares(times)
        out.append(f"| {stage_label(c)} | {fmt(times[WHOLE_FRAME], 1)} | " +
                   " | ".join(f"{fmt(times[g], 1)} ({percent(share[g])})" for g in GROUPS) +
                   f" | {percent(of_frame)} |")
    for name, ms in THESIS_TIMES.items():
        total = sum(ms)
        out.append(f"| thesis: {name} (RTX 2080 Ti) | - | " +
                   " | ".join(f"{v} ({percent(v / total)})" for v in ms) + " | - |")
    return out


def find(cells: List[Cell], label: str) -> Optional[Cell]:
    for c in cells:
        if stage_label(c) == label:
            return c
    return None


def resolved(cell: Cell, path_class: str = "indirect") -> bool:
    flip, floor = cell.metric_mean("flip", path_class), cell.metric_mean("flip_floor", path_class)
    return floors.resolved("flip", flip, floor) is True


def versus(a: Cell, b: Cell, metric: str, path_class: str = "indirect") -> str:
    """Whether a's score is better or worse than b's (lower is better for FLIP and flicker), and
    "(unresolved)" where the order may be the reference's noise: floors.comparison_resolved for a
    metric with a floor model, the worst-case rule for flicker (the two differ by no more than their
    floors together)."""
    va, vb = a.metric_mean(metric, path_class), b.metric_mean(metric, path_class)
    fa, fb = a.metric_mean(metric + "_floor", path_class), b.metric_mean(metric + "_floor", path_class)
    if math.isnan(va) or math.isnan(vb):
        return "not measured"
    if va == vb:
        return "equal"
    order = "better" if va < vb else "worse"
    if metric in floors.FLOOR_METRICS:
        held = floors.comparison_resolved(metric, va, fa, vb, fb)
    else:
        held = None if math.isnan(fa) or math.isnan(fb) else abs(va - vb) > fa + fb
    return order + (" (unresolved)" if held is False else "")


def flip_and_flicker(a: Cell, b: Cell) -> str:
    """How a's indirect FLIP and flicker compare with b's: "indirect FLIP better, flicker worse"."""
    return f"indirect FLIP {versus(a, b, 'flip')}, flicker {versus(a, b, 'flicker')}"


def statements(cells: List[Cell]) -> List[str]:
    """The thesis's statements and what this scene's cells measure for each."""
    out = []
    none, temporal, spatial, both = (find(cells, s) for s in FILTER_STAGES.values())

    def scores(c: Cell) -> str:
        flip, floor = c.metric_mean("flip", "indirect"), c.metric_mean("flip_floor", "indirect")
        return (f"indirect FLIP {fmt(flip)} (floor {fmt(floor)}{'' if resolved(c) else ', unresolved'}), "
                f"PSNR {fmt(c.metric_mean('psnr', 'indirect'), 2)} dB, flicker "
                f"{fmt(c.metric_mean('flicker', 'indirect'))} (floor "
                f"{fmt(c.metric_mean('flicker_floor', 'indirect'))})")

    if none is not None and temporal is not None:
        f0, f1 = none.metric_mean("flicker", "indirect"), temporal.metric_mean("flicker", "indirect")
        out.append("* §7.2 (the temporal filter accumulates the frames' stratified photon sets; without it "
                   "\"extreme variance in the irradiance values between frames\"): filters none "
                   f"{scores(none)}; temporal only {scores(temporal)}: indirect flicker x{fmt(f1 / f0, 2)} "
                   f"({versus(temporal, none, 'flicker')})")
    if none is not None and spatial is not None:
        out.append("* §7.3 (the edge-avoiding a-trous filter removes the noise the splat leaves): spatial "
                   f"only {scores(spatial)}: indirect FLIP {versus(spatial, none, 'flip')} "
                   "than filters none")
    if both is not None:
        others = [c for c in (temporal, spatial) if c is not None]
        orders = [versus(both, o, "flip") for o in others]
        best = all(o.startswith("better") for o in orders)
        held = "" if all("unresolved" not in o for o in orders) else " (unresolved)"
        out.append(f"* the thesis's chain, both filters: {scores(both)}; "
                   f"{'the lowest' if best else 'not the lowest'} indirect FLIP of the filter stages{held}")
        clip = find(cells, "both, no detail clip")
        if clip is not None:
            out.append("* §7.3.1, Fig. 7.2 (the scaling coefficients alone blur the detail away; the "
                       "variance-clipped details keep it but bring noise back where photons are sparse): "
                       f"without the details {scores(clip)}; with them {flip_and_flicker(both, clip)}")
        direction = find(cells, "both, direction term")
        if direction is not None:
            out.append("* §7.4, Eq. 7.10 (the filtered mean light direction re-applies normal detail; "
                       "Fig. 8.7: it fluctuates from frame to frame): with the term "
                       f"{scores(direction)}: {flip_and_flicker(direction, both)} than without")
        for c in cells:
            if c.technique == TECHNIQUE and stage_label(c).startswith("both, n_tile"):
                r = estimate_ratio(c, both, "auto")
                out.append(f"* §8.6.4 (a larger n_tile blurs and costs more: 0.5 -> 3.0 took the estimate "
                           f"0.9 -> 10.6 ms): n_tile {setting(c, 'n_tile'):g} against "
                           f"{DEFAULTS['n_tile']:g}: {scores(c)}; indirect FLIP "
                           f"{versus(c, both, 'flip')}, estimate time x{fmt(r, 2)}")
        sampler = find(cells, "both, sampler tracer")
        if sampler is not None:
            out.append("* §5.3 (photons from Hammersley points warped through the map's Haar pyramid): "
                       f"the tracer's own sampling of the same maps {scores(sampler)}: indirect FLIP "
                       f"{versus(sampler, both, 'flip')} than the warped points")
    for c in cells:
        if c.technique != TECHNIQUE or setting(c, "estimate") != "gather":
            continue
        splat = find(cells, stage_label(c).replace(", estimate gather", ""))
        if splat is None:
            continue
        r = estimate_ratio(c, splat, "auto")
        rp = estimate_ratio(c, splat, "process")
        thesis = ", ".join(f"{n} {g / s:.1f}x" for n, (s, g) in THESIS_TABLE_61.items())
        verdict = ("slower, as the thesis found" if r > 1 else "not slower, unlike the thesis") \
            if not math.isnan(r) else "not measured"
        out.append(f"* §6.4, Table 6.1 (gathering is \"significantly worse\" than splatting: {thesis}; Fig. "
                   f"6.2c shows their difference by eye): {stage_label(c)} against {stage_label(splat)}: "
                   f"estimate time x{fmt(r, 2)}" + (f" (process CPU x{fmt(rp, 2)})" if not math.isnan(rp) else "")
                   + f", {verdict}; indirect FLIP {fmt(c.metric_mean('flip', 'indirect'))} against "
                   f"{fmt(splat.metric_mean('flip', 'indirect'))} (floor "
                   f"{fmt(c.metric_mean('flip_floor', 'indirect'))}): {versus(c, splat, 'flip')}")
    direct = [c for c in cells if c.technique == NO_GI]
    if direct:
        d = direct[0].metric_mean("flip", "combined")
        gi = [c for c in cells if c.technique == TECHNIQUE]
        beaten = [c for c in gi if c.metric_mean("flip", "combined") < d]
        out.append(f"* against no indirect light (`{NO_GI}`, combined FLIP {fmt(d)}): {len(beaten)} of "
                   f"{len(gi)} cells lower")
    return out


def claims(run: Run) -> str:
    cells = [c for c in run.cells if c.ok and c.technique in (TECHNIQUE, NO_GI)]
    if not any(c.technique == TECHNIQUE for c in cells):
        raise MissingCells(f"no completed {TECHNIQUE} cells (run configs/rsm-photons.yaml)")
    out = [f"# Claims: {TITLE}", "", f"Run {run.name}; device {run.device}; commit {run.commit}.", "",
           "The thesis scored nothing: its quality was judged by eye against a path tracer it says not to "
           "treat as ground truth. Here each figure is the mean over the scored frames, its noise floor in "
           f"brackets (a FLIP under {RESOLVED:g}x its floor is unresolved); flicker compares consecutive "
           "frames' change with the reference's own.", ""]
    by_scene: Dict[str, List[Cell]] = OrderedDict()
    for c in cells:
        by_scene.setdefault(c.scene, []).append(c)
    for group in by_scene.values():
        group.sort(key=stage_order)
    has_process = any(not math.isnan(group_means(c, "process")[WHOLE_FRAME]) for c in cells)
    for scene, group in by_scene.items():
        gi = [c for c in group if c.technique == TECHNIQUE]
        if not gi:
            continue
        out += [f"## {scene}", "", "### Stage ablation", ""] + ablation_table(group) + [""]
        out += ["### Per-stage time (Fig. 1.2's groups)", "",
                "Mean ms per frame on the harness's clock; in brackets each group's share of the four "
                "groups' sum (the thesis's Total); the last column, that sum over the whole frame (the "
                "G-buffer, direct light and shading are outside the thesis's timings).", ""]
        out += times_table(gi, "auto") + [""]
        if has_process:
            out += ["The same on the process's CPU time (lavapipe's threads included), which waiting for "
                    "a core does not inflate:", ""] + times_table(gi, "process") + [""]
        out += ["### The thesis's statements, measured", ""] + statements(group) + [""]
    return "\n".join(out) + "\n"
