"""Many-light sampling (seed 002 Papers III and IV: the light BVH's next-event estimation) claims,
measured on a run of configs/manylights.yaml.

The config runs the `direct` technique with `direct_light: nee` on lamp-hall (static, Paper III's
setting in miniature) and lamp-hall-moving (Paper IV's: orbiting, flashing lanterns). A cell's setting
is read from its parameters (nee_sampler, nee_importance, nee_levels, nee_update; a parameter the cell
does not set has the toolkit's default). Per setting:
  * MSE: each scored frame's mse_unbiased against the `direct` reference (the squared error less the
    reference's own noise: the papers' MSE against near-converged references; rmse^2 in a run without
    it), the mean over the frames and then over the rounds;
  * NEE time: the sum of the passes direct-light/nee/sample, nee/trace and nee/shade per frame (Paper
    IV times "only the ray-tracing pass"), its median over the measured frames; the update time: the
    light-bvh/build and light-bvh/refit passes per frame (the first build falls in the warm-up);
  * the efficiency 1/(t MSE) of Paper IV, t the NEE time plus the update time.
Ratios between two settings are per round (seed: `seeds: K`, `seed_order: rounds` runs round i of
every cell before round i + 1, alternately forward and backward), the median over the rounds with its
range: the time ratios compare cells measured side by side. Paper III's SAOH against SAH and its leaf
sizes are build options, not technique parameters: bench/bench_light_bvh measures them (the claims
name it). Each row carries the paper's figure beside ours.
"""

import math
from collections import OrderedDict
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np

from ..rundata import FULL_REFERENCE, Cell, Run
from .paper003 import Setting, ratio_text, round_ratios, seed_order, settings_of

TITLE = ("Importance Sampling of Many Lights on the GPU (Moreau and Clarberg, Ray Tracing Gems ch. 18) and "
         "Dynamic Many-Light Sampling for Real-Time Ray Tracing (Moreau, Pharr and Clarberg, HPG 2019): "
         "seed 002 Papers III and IV")
TECHNIQUE = "direct"
PATH_CLASS = "direct"  # what `direct` is scored on; the combined image where a run lacks it
# The toolkit's defaults (harness/include/photonbench/context.h, DirectLightSettings).
DEFAULTS = {"direct_light": "shadow_maps", "nee_sampler": "bvh", "nee_importance": "dfbo",
            "nee_levels": "one", "nee_update": "rebuild"}
NEE_PASSES = ("direct-light/nee/sample", "direct-light/nee/trace", "direct-light/nee/shade")
UPDATE_PASSES = ("direct-light/light-bvh/build", "direct-light/light-bvh/refit")
BENCH = "bench/bench_light_bvh"


class MissingCells(Exception):
    pass


def setting(cell: Cell, name: str) -> str:
    return str(cell.params.get(name, DEFAULTS[name])).strip().lower()


def label(s: Setting) -> str:
    """"uniform", "power", "bvh dfbo", "bvh d, two levels, refit", ..."""
    c = s.first
    if c.technique != TECHNIQUE or setting(c, "direct_light") != "nee":
        return f"`{c.technique}` {setting(c, 'direct_light')}"
    sampler = setting(c, "nee_sampler")
    if sampler != "bvh":
        return sampler
    parts = [f"bvh {setting(c, 'nee_importance')}"]
    if setting(c, "nee_levels") != "one":
        parts.append(f"{setting(c, 'nee_levels')} levels")
    if setting(c, "nee_update") != "rebuild":
        parts.append(setting(c, "nee_update"))
    return ", ".join(parts)


ORDER = {"nee_sampler": ("uniform", "power", "bvh"), "nee_importance": ("d", "df", "dfb", "dfbo"),
         "nee_levels": ("one", "two"), "nee_update": ("rebuild", "refit")}


def setting_order(s: Setting) -> Tuple[int, ...]:
    """The papers' order: uniform, power, the BVH by importance, then levels and update."""
    return tuple(ORDER[name].index(setting(s.first, name)) if setting(s.first, name) in ORDER[name]
                 else len(ORDER[name]) for name in ORDER)


def metric_class(cell: Cell) -> Optional[str]:
    classes = cell.metric_classes()
    return PATH_CLASS if PATH_CLASS in classes else cell.primary_class()


def mse_series(cell: Cell) -> Tuple[np.ndarray, np.ndarray]:
    """(frames, MSE) of the scored frames: mse_unbiased (the reference's own noise taken off, an
    estimate of the MSE against the true image, as the papers' 4,000-10,000 spp references nearly
    are) where the run has it, else rmse^2."""
    frames, unbiased = cell.metric_series("mse_unbiased", metric_class(cell), FULL_REFERENCE)
    if len(unbiased):
        return frames, np.asarray(unbiased, float)
    frames, rmse = cell.metric_series("rmse", metric_class(cell), FULL_REFERENCE)
    return frames, np.asarray(rmse, float) ** 2


def cell_mse(cell: Cell) -> float:
    values = mse_series(cell)[1]
    return float(np.mean(values)) if len(values) else math.nan


def per_frame_sum(cell: Cell, passes: Sequence[str]) -> np.ndarray:
    """The named passes' summed time in every measured frame (0 where a frame has none of them)."""
    frames = cell.pass_samples("frame")[0]
    sums = cell.pass_sums(passes)
    return np.asarray([float(sums.get(f, 0.0)) for f in frames], float)


def nee_ms(cell: Cell) -> float:
    t = per_frame_sum(cell, NEE_PASSES)
    return float(np.median(t)) if len(t) else math.nan


def update_ms(cell: Cell) -> float:
    t = per_frame_sum(cell, UPDATE_PASSES)
    return float(np.median(t)) if len(t) else math.nan


def efficiency(cell: Cell) -> float:
    t, mse = nee_ms(cell) + update_ms(cell), cell_mse(cell)
    return 1.0 / (t * mse) if t > 0 and mse > 0 else math.nan


def mean_over_rounds(s: Setting, measure) -> float:
    values = [measure(c) for c in s.ok_cells]
    values = [v for v in values if math.isfinite(v)]
    return float(np.mean(values)) if values else math.nan


def fmt(v: float, digits: int = 2) -> str:
    return "–" if v is None or not math.isfinite(v) else f"{v:,.{digits}f}"


def settings_table(settings: List[Setting]) -> List[str]:
    out = ["| setting | MSE | NEE ms | update ms | nodes / sample | occluded | bytes | efficiency vs uniform |",
           "|---|---|---|---|---|---|---|---|"]
    uniform = find(settings, "uniform")
    for s in settings:
        eff = ratio_text(round_ratios(s, uniform, efficiency)) if uniform is not None else "–"
        out.append(f"| {label(s)} | {fmt(mean_over_rounds(s, cell_mse))} | "
                   f"{fmt(mean_over_rounds(s, nee_ms))} | {fmt(mean_over_rounds(s, update_ms), 3)} | "
                   f"{fmt(s.counter('nee_nodes_per_sample'), 1)} | {fmt(s.counter('nee_occluded_share'), 3)} | "
                   f"{fmt(s.counter('light_bvh_bytes'), 0)} | {eff} |")
    return out


def find(settings: List[Setting], name: str) -> Optional[Setting]:
    for s in settings:
        if s.ok and label(s) == name:
            return s
    return None


def claim_row(claim: str, paper: str, settings: List[Setting], num: str, den: str, measure) -> str:
    """A table row: the claim, the paper's figure, ours as `num` / `den` of `measure` per round."""
    missing = [f"`{name}`" for name in (num, den) if find(settings, name) is None]
    if missing:
        return f"| {claim} | {paper} | not in this run ({' and '.join(missing)} missing) | {num} / {den} |"
    ratios = round_ratios(find(settings, num), find(settings, den), measure)
    digits = 4 if len(ratios) and abs(float(np.median(ratios))) < 0.1 else 2  # an update's 1/500
    return f"| {claim} | {paper} | {ratio_text(ratios, digits=digits)} | {num} / {den} |"


def paper_rows(settings: List[Setting]) -> List[str]:
    one, two, two_refit = "bvh dfbo", "bvh dfbo, two levels", "bvh dfbo, two levels, refit"
    rows = [
        ("III: the BVH with distance alone against uniform selection, MSE", "4x-6x lower",
         "uniform", "bvh d", cell_mse),
        ("III: the full importance (DFBO) against distance alone, MSE", "a further ~2x lower",
         "bvh d", one, cell_mse),
        ("III: BVH_DFBO's time against uniform's (NEE passes)", "2x-3x", one, "uniform", nee_ms),
        ("IV Table 1: two levels against one, MSE", "1.01x-1.02x (+1-2%)", two, one, cell_mse),
        ("IV Table 2: a two-level refit against a one-level rebuild, MSE", "1.05x-1.06x (within 6%)",
         two_refit, one, cell_mse),
        ("IV Table 2: a one-level refit against a rebuild, MSE", "1.16x-1.25x", "bvh dfbo, refit", one,
         cell_mse),
        ("IV Table 2: update time, two-level refit against one-level rebuild",
         "0.18-0.35 ms against 90-300 ms (1/860-1/500)", two_refit, one, update_ms),
        ("IV Table 2: efficiency 1/(t MSE) of the two-level refit against uniform",
         "5.2x (Bistro), 20.1x (Emerald Square)", two_refit, "uniform", efficiency),
        ("IV Table 2: efficiency of the one-level rebuild against uniform",
         "0.66x, 0.85x (its 90-300 ms rebuild)", one, "uniform", efficiency),
    ]
    out = ["| claim | the paper | ours (median [range] over the rounds) | ratio of |", "|---|---|---|---|"]
    out += [claim_row(claim, paper, settings, num, den, measure) for claim, paper, num, den, measure in rows]
    out.append(f"| III: SAOH against SAH (quality; build) | SAOH usually better; build ~3x SAH's | build "
               f"options, not technique parameters: `{BENCH}` | – |")
    out.append(f"| III: leaf sizes 1-10, time | within 5% | build options: `{BENCH}` | – |")
    out.append(f"| III: build time against light count | 2.3, 26, 280 ms at 1k, 21k, 53k-200k | "
               f"`{BENCH}`: slopes | – |")
    return out


def animation_table(settings: List[Setting]) -> List[str]:
    """Fig. 7: MSE per scored frame of every BVH setting (the mean over the rounds), on a scene whose
    lights move (some setting updates its tree within the measured frames)."""
    bvh = [s for s in settings if s.ok and label(s).startswith("bvh")]
    if not any(mean_over_rounds(s, update_ms) > 0 for s in bvh):
        return []
    frames = sorted({int(f) for s in bvh for c in s.ok_cells for f in mse_series(c)[0]})
    if len(frames) < 2:
        return []
    out = ["| frame | " + " | ".join(label(s) for s in bvh) + " |", "|---|" + "---|" * len(bvh)]
    for frame in frames:
        row = []
        for s in bvh:
            values = [v for c in s.ok_cells for f, v in zip(*mse_series(c)) if int(f) == frame]
            row.append(fmt(float(np.mean(values))) if values else "–")
        out.append(f"| {frame} | " + " | ".join(row) + " |")
    return out


def claims(run: Run) -> str:
    by_scene: Dict[str, List[Setting]] = OrderedDict()
    for scene, settings in settings_of(run).items():
        nee = [s for s in settings if s.first.technique == TECHNIQUE and setting(s.first, "direct_light") == "nee"]
        if any(s.ok for s in nee):
            by_scene[scene] = sorted(nee, key=setting_order)
    if not by_scene:
        raise MissingCells(f"no completed {TECHNIQUE} cell with direct_light: nee (run configs/manylights.yaml)")
    rounds = max(len(s.cells) for ss in by_scene.values() for s in ss)
    out = [f"# Claims: {TITLE}", "", f"Run {run.name}; device {run.device}; commit {run.commit}.", ""]
    if rounds > 1 and seed_order(run) == "rounds":
        out += [f"Times: {rounds} alternating rounds (`seeds: {rounds}`, `seed_order: rounds`). A ratio is the "
                "median over the rounds of the per-round ratio, [min–max] over the rounds.", ""]
    else:
        why = "the seeds ran grouped (`seed_order` is not `rounds`)" if rounds > 1 else "one round (no seeds)"
        out += [f"**Warning: not alternating rounds** ({why}): the time ratios below compare cells measured "
                "at different times. Run the config as written (`seeds: K`, `seed_order: rounds`).", ""]
    out += ["MSE: each scored frame's mse_unbiased (else rmse squared) against the `direct` reference, the "
            "mean over the frames and the rounds. NEE ms: direct-light/nee/sample + trace + shade per frame "
            "(median); update ms: "
            "light-bvh/build + refit per frame (median). The papers ran on an RTX 2080 Ti with DXR; here the "
            "walk and the rays run on this machine's CPU (harness/src/trace/README.md).", ""]
    for scene, settings in by_scene.items():
        out += [f"## {scene}", ""] + settings_table(settings) + [""]
        out += ["### The papers' figures beside ours", ""] + paper_rows(settings) + [""]
        animation = animation_table(settings)
        if animation:
            out += ["### MSE over the animation (Paper IV Fig. 7)", ""] + animation + [""]
    return "\n".join(out) + "\n"

