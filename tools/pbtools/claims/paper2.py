"""Paper II (Moreau, Sintorn et al., "Path Verification for Dynamic Indirect Illumination") claims,
measured on a run of configs/paper2.yaml.

The comparisons, with the paper's statements (digest seed002-papers-I-II.md §7.5):
  * rays traced per frame against the baseline (reuse: none): "reduce the number of rays traced by up to
    5x"; armadillo 5x (naive); merry-go-round "almost half as many rays as the baseline"; and the rays of
    every variant frame by frame (Fig. 7 analogue);
  * error-based against naive in the paper's quantity, rays reused (segments of this frame's paths that
    were not traced again: full_retrace_rays - segments_retraced): "reuses close to 1.5x as many rays"
    on the merry-go-round; near frame 250 of armadillo it "retraces only half the number of rays"
    (rays_traced, visibility rays included); villa (a moving light only): "no differences";
  * time: all the light-transport work of a frame (every reuse step and the re-trace: update-origins with
    compute-dm, dynamic-occlusion, prune, fill, photon-trace; the baseline has only photon-trace), the
    headline, and photon-trace alone beside it: "a 3x decrease" for 5x fewer rays, "an average 4x
    increase in performance" with the reuse overhead included;
  * the reuse steps' overhead (update-origins, compute-dm, dynamic-occlusion, prune, fill): "about 2.5 ms,
    compared to the average baseline time of 60 ms"; per-step time (Fig. 8 analogue);
  * memory per structure (Table 1 analogue, MiB);
  * at equal frame time (Fig. 1, villa), from a matched run (match.csv; configs/paper2-equal-time.yaml):
    the paths each variant affords (the paper's quantity: error-based 5M against the baseline's 3M at
    333 and 341 ms), its light-transport and splat time there (80 against 178 ms, 236 against 148),
    whether the two times are one time as far as their spread tells, and the error with its floor, the
    order resolved or not (tools/pbtools/matching.py's rule); a run without match.csv says so;
  * what the paper never measured: the estimate's error against the reference over the animation
    (relMSE and FLIP of the indirect class, the variant's mean against the baseline's, with the
    reference's noise floor beside them) and flicker between consecutive frames (the frame pairs of
    frames.metrics_window), with its floor.
A "variant" is a cell's `reuse` (none, naive, error_based); cells are grouped by scene and the other
parameters (splatter, photons, ...). A ratio is a ratio of means over the frames after the first (the sum
of one series over the sum of the other, frame by frame on the frames both have), which a frame where a
variant traced nothing does not drop or blow up; "peak" is the largest per-frame ratio. The shipped stand-ins: walker for the armadillo, merry-go-round and villa by name.
"""

import math
from collections import defaultdict
from typing import Dict, List, Optional, Tuple

import numpy as np
import pandas as pd

from .. import matching
from ..rundata import FULL_REFERENCE, Cell, Run, format_param
from .paper1 import (BUILD, SPLAT_ESTIMATE, equal_time_held, frame_ratios, knob_value, matched_pairs,
                     matched_pass_ms, matched_rows, missing_match, score_order)

TITLE = "Path Verification for Dynamic Indirect Illumination (Moreau, Sintorn et al.)"

VARIANTS = ("none", "naive", "error_based")
REUSE_STEPS = ("update-origins", "dynamic-occlusion", "prune", "fill")  # compute-dm is nested
# A frame's light-transport work (Paper II Fig. 8's categories: the reuse steps, generate and trace rays);
# the splatter and the photon upload are left out, as the paper leaves its splatting out.
LIGHT_TRANSPORT = REUSE_STEPS + ("photon-trace",)
FIG8_STEPS = ("update-origins", "update-origins/compute-dm", "dynamic-occlusion", "prune", "fill",
              "photon-trace", "photon-upload")

# Paper II Table 1 (MiB; 5M paths of at most 7 photons, one disc light, a 32^4 map): row -> (counter,
# no reuse, reuse lights, reuse objects).
TABLE1 = [
    ("Path information", "bytes_path_information", None, 19.07, 19.07),
    ("Path origin pos.", "bytes_path_origins", None, 57.22, 57.22),
    ("Distribution maps", "bytes_distribution_maps", None, 8.000, None),
    ("Pruned paths array", "bytes_pruned_paths", None, 19.07, None),
    ("Photon map (ours: compacted 96-byte records)", "bytes_photon_map", 1068, 1068, 1068),
    ("Photon map (the paper's layout: paths x 7 x 32 B)", "bytes_photon_map_paper", 1068, 1068, 1068),
]


# What the paper states per scene: baseline / variant rays, and naive / error-based rays.
PAPER_RAYS = {"merry-go-round": "about 2×", "walker": "up to 5× (armadillo)", "villa": "–"}
PAPER_REUSED = {"merry-go-round": "close to 1.5×", "walker": "slightly more (armadillo)",
                "villa": "1× (no difference)"}
PAPER_NEAR_250 = "2× (armadillo: half the rays)"
FIG7_EVERY = 30  # frames between the rows of the per-frame rays table
WALKER_PEAK = (240, 260)  # the frames around 250 where the paper's armadillo passes its light


# Fig. 1 (villa, at roughly equal frame time): variant -> (frame ms, paths, light transport ms, splat ms).
PAPER_FIG1 = {"none": (341, 3_000_000, 178, 148), "error_based": (333, 5_000_000, 80, 236)}
SPLATTER_PASSES = SPLAT_ESTIMATE + BUILD  # the splatter's passes, Paper I's; Fig. 1's "splatting"


class MissingCells(Exception):
    pass


def paths_resolution(ratio: float, a: Dict[str, str], b: Dict[str, str]) -> str:
    """Whether a ratio of the paths two matches found tells them apart: each found value's time is within
    its match's tolerance t of the target, so with time proportional to paths a ratio within
    (1 + t_a) / (1 - t_b) of 1 (or its inverse) may be the tolerance alone."""
    ta, tb = float(a["tolerance"] or "nan"), float(b["tolerance"] or "nan")
    band = max((1 + ta) / (1 - tb), (1 + tb) / (1 - ta))
    if math.isnan(band):
        return "no tolerance to judge the ratio by"
    told = ratio > band or ratio < 1 / band
    return (f"{'resolved' if told else 'unresolved'}: the tolerances alone allow {1 / band:.2f}-{band:.2f}×"
            " with time proportional to paths")


def equal_time(run: Run) -> List[str]:
    """Fig. 1 from a matched run (configs/paper2-equal-time.yaml): each reuse variant's paths at one
    frame time, its light-transport and splat time there, and its error with the floor; the paper's
    quantity is the paths, 5M against the baseline's 3M at 333 and 341 ms."""
    out = ["## At equal frame time (Fig. 1)",
           "(paper, villa, at roughly equal frame time: the baseline 341 ms, 3 million paths traced in "
           "about 178 ms and splatted in 148 ms; error-based 333 ms, 5 million paths traced and reused in "
           "about 80 ms and splatted in 236 ms: 5/3 = 1.67× the paths. Its only equal-time comparison; it "
           "makes none at equal quality, and shows the two images without an error measure)", ""]
    mode, metric, rows = matched_rows(run, ("path-verification",))
    if not rows:
        return out + missing_match(("path-verification",), "configs/paper2-equal-time.yaml")
    if mode != "time":
        out += [f"This run matched at equal quality ({metric}), not at equal time: Fig. 1's comparison "
                "is not in it. Its rows:", ""]
    out += ["Each variant's `photons` (light paths) found by the match for one frame time (its knob); the "
            "achieved frame time over the re-measurement rounds, median [p5, p95]; light transport "
            "(" + ", ".join(LIGHT_TRANSPORT) + ") and splatting (" + ", ".join(SPLATTER_PASSES) + ") as "
            f"the medians of those frames' sums; {metric} of the combined image with the reference's "
            "floor.", "",
            f"| scene | reuse | status | paths | probes | frame ms | light transport ms | splat ms | {metric} |",
            "|---|---|---|---|---|---|---|---|---|"]
    by_scene: Dict[str, Dict[str, Dict[str, str]]] = defaultdict(dict)
    for row, cell in rows:
        reuse = str(cell.params.get("reuse", "error_based")) if cell is not None else "?"
        out.append(f"| {row['scene']} | {reuse} | {row['status']} | {knob_value(row)} | {row['probes']} | "
                   f"{matching.time_text(row) or '–'} | "
                   f"{_f(matched_pass_ms(run, row, LIGHT_TRANSPORT), 1)} | "
                   f"{_f(matched_pass_ms(run, row, SPLATTER_PASSES), 1)} | "
                   f"{matching.score_text(row, metric) or '–'} |")
        by_scene[row["scene"]][reuse] = row
    out.append("")
    if mode != "time":
        return out
    p_base, p_err = PAPER_FIG1["none"], PAPER_FIG1["error_based"]
    for scene, v, r, base, why in matched_pairs(by_scene, "none", ("error_based", "naive")):
        if why:
            out.append(f"* {scene}, {v} against the baseline: no comparison, {why}")
            continue
        paths = float(r["knob_value"]) / float(base["knob_value"])
        paper = (f"paper {p_err[1] / p_base[1]:.2f}× (5M / 3M, villa)" if v == "error_based"
                 else "the paper's Fig. 1 has no naive")
        out.append(f"* {scene}, {v} against the baseline at {float(r['target']):g} ms a frame: "
                   f"{paths:.2f}× the paths ({knob_value(r)} / {knob_value(base)}; {paper}; "
                   f"{paths_resolution(paths, r, base)}); equal time "
                   f"{equal_time_held(r, base)}; light transport "
                   f"{_f(matched_pass_ms(run, r, LIGHT_TRANSPORT), 1)} / "
                   f"{_f(matched_pass_ms(run, base, LIGHT_TRANSPORT), 1)} ms, splatting "
                   f"{_f(matched_pass_ms(run, r, SPLATTER_PASSES), 1)} / "
                   f"{_f(matched_pass_ms(run, base, SPLATTER_PASSES), 1)} ms (paper "
                   f"{p_err[2]} / {p_base[2]} and {p_err[3]} / {p_base[3]} ms); "
                   f"{score_order(r, base, metric, v, 'none')}.")
    return out + [""]


def group_key(cell: Cell, swept: List[str]) -> Tuple[str, str]:
    """(scene, the swept parameters other than reuse: "splatter=tiled, photons=20000")."""
    return cell.scene, ", ".join(f"{p}={format_param(cell.params[p])}" for p in swept
                                 if p != "reuse" and p in cell.params) or "default"


def counter_series(cell: Cell, name: str) -> pd.Series:
    c = cell.counters
    rows = c[c["name"] == name].dropna(subset=["value"])
    return rows.groupby("frame")["value"].sum()


def ratio_of_means(num: pd.Series, den: pd.Series) -> float:
    """mean(num) / mean(den) over the frames both series have; NaN when den sums to nothing."""
    num, den = num.align(den, join="inner")
    return float(num.sum() / den.sum()) if len(den) and den.sum() > 0 else math.nan


def ratio_peak(num: pd.Series, den: pd.Series) -> str:
    """The ratio of means, and in brackets the largest per-frame ratio."""
    r = ratio_of_means(num, den)
    per_frame = frame_ratios(num, den)
    if math.isnan(r):
        return "–"
    return f"{r:.2f}× ({np.max(per_frame):.2f}×)" if len(per_frame) else f"{r:.2f}×"


def reused_rays(cell: Cell) -> pd.Series:
    """Segments of each frame's paths that were not traced again (the paper's rays reused)."""
    full, traced = counter_series(cell, "full_retrace_rays").align(
        counter_series(cell, "segments_retraced"), join="inner")
    return full - traced


def variant_pairs(grid: Dict[Tuple[str, str], Dict[str, Cell]], variants=("naive", "error_based")):
    """(scene, setting, baseline cell, variant name, variant cell) for every variant with a baseline."""
    for (scene, setting), kinds in sorted(grid.items()):
        base = kinds.get("none")
        for v in variants:
            if base is not None and kinds.get(v) is not None:
                yield scene, setting, base, v, kinds[v]


def _f(v: Optional[float], digits: int = 2) -> str:
    return "–" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.{digits}f}"


def claims(run: Run) -> str:
    cells = [c for c in run.cells if c.ok and c.technique == "path-verification"]
    if not cells:
        raise MissingCells("no completed path-verification cells")
    swept = run.swept_params(cells)
    grid: Dict[Tuple[str, str], Dict[str, Cell]] = defaultdict(dict)
    for c in cells:
        grid[group_key(c, swept)][str(c.params.get("reuse", "error_based"))] = c
    out: List[str] = [f"# Paper II claims, measured: {run.name}", "",
                      f"{TITLE}. Device: {run.device}; commit {run.commit}.",
                      "A ratio is the ratio of the means over the frames after the first (which traces "
                      "everything in every variant); \"peak\" is the largest per-frame ratio. Rays are "
                      "counter rays_traced (re-traced segments plus visibility rays); rays reused are the "
                      "segments of a frame's paths not traced again (full_retrace_rays - segments_retraced). "
                      "Light-transport time: " + ", ".join(LIGHT_TRANSPORT) + " (compute-dm is inside "
                      "update-origins).", ""]

    def later(s: pd.Series) -> pd.Series:
        return s[s.index > s.index.min()] if len(s) else s

    # -- 1. rays and trace time against the baseline -------------------------------------------------
    out += ["## Rays traced and light-transport time against the baseline",
            "(paper: up to 5× fewer rays; armadillo 5× fewer rays for 3× less trace time, and an average 4× "
            "with the reuse overhead; merry-go-round about 2× fewer rays)", "",
            "| scene | setting | variant | baseline / variant rays (peak) | paper | light-transport time, "
            "baseline / variant (peak) | trace time (photon-trace) alone (peak) | paths kept per frame | "
            "rays a full re-trace would trace / rays traced |",
            "|---|---|---|---|---|---|---|---|---|"]
    for scene, setting, base, v, c in variant_pairs(grid):
        b_rays = later(counter_series(base, "rays_traced"))
        rays = later(counter_series(c, "rays_traced"))
        kept = later(counter_series(c, "paths_kept"))
        full = later(counter_series(c, "full_retrace_rays"))
        work = ratio_peak(later(base.pass_sums(LIGHT_TRANSPORT)), later(c.pass_sums(LIGHT_TRANSPORT)))
        trace = ratio_peak(later(base.pass_sums(("photon-trace",))),
                           later(c.pass_sums(("photon-trace",))))
        out.append(f"| {scene} | {setting} | {v} | {ratio_peak(b_rays, rays)} | "
                   f"{PAPER_RAYS.get(scene, '–')} | {work} | {trace} | "
                   f"{_f(kept.mean() if len(kept) else None, 0)} | {ratio_peak(full, rays)} |")
    out.append("")

    # -- 1b. rays frame by frame (Fig. 7) ------------------------------------------------------------
    out += ["## Rays traced per frame (Fig. 7 analogue)",
            f"(every {FIG7_EVERY}th frame and the last; rays_traced of each variant)", "",
            "| scene | setting | frame | none | naive | error_based | naive / error_based |",
            "|---|---|---|---|---|---|---|"]
    for (scene, setting), kinds in sorted(grid.items()):
        series = {v: counter_series(kinds[v], "rays_traced") for v in VARIANTS if v in kinds}
        frames = sorted(set().union(*(s.index for s in series.values()))) if series else []
        shown = [f for f in frames if f % FIG7_EVERY == 0 or f == frames[-1]]
        for f in shown:
            vals = {v: series[v].get(f) for v in series}
            n, e = vals.get("naive"), vals.get("error_based")
            ratio = f"{n / e:.2f}×" if n is not None and e else "–"
            out.append(f"| {scene} | {setting} | {f} | " +
                       " | ".join(_f(vals.get(v), 0) if vals.get(v) is not None else "–"
                                  for v in VARIANTS) + f" | {ratio} |")
    out.append("")

    # -- 2. error-based against naive ----------------------------------------------------------------
    out += ["## Error-based against naive",
            "(paper: error_based reuses close to 1.5× as many rays as naive on the merry-go-round, slightly "
            "more on armadillo except near frame 250, where it traces half the rays; villa: no difference)", "",
            "| scene | setting | rays reused, error_based / naive (peak) | paper | rays traced, naive / "
            "error_based (peak) | frame of the peak | walker, frames "
            f"{WALKER_PEAK[0]}-{WALKER_PEAK[1]}: rays traced, naive / error_based | paper | paths kept: "
            "error_based / naive |",
            "|---|---|---|---|---|---|---|---|---|"]
    for (scene, setting), kinds in sorted(grid.items()):
        n, e = kinds.get("naive"), kinds.get("error_based")
        if n is None or e is None:
            continue
        nr, er = later(counter_series(n, "rays_traced")), later(counter_series(e, "rays_traced"))
        r = (nr / er.where(er > 0)).dropna()
        peak = int(r.idxmax()) if len(r) else None
        in_window = lambda s: s[(s.index >= WALKER_PEAK[0]) & (s.index <= WALKER_PEAK[1])]  # noqa: E731
        near_250 = ratio_peak(in_window(nr), in_window(er)) if scene == "walker" else "–"
        out.append(f"| {scene} | {setting} | {ratio_peak(later(reused_rays(e)), later(reused_rays(n)))} | "
                   f"{PAPER_REUSED.get(scene, '–')} | {ratio_peak(nr, er)} | "
                   f"{peak if peak is not None else '–'} | {near_250} | "
                   f"{PAPER_NEAR_250 if scene == 'walker' else '–'} | "
                   f"{ratio_peak(later(counter_series(e, 'paths_kept')), later(counter_series(n, 'paths_kept')))} |")
    out.append("")

    # -- 3. overhead and per-step time (Fig. 8) ------------------------------------------------------
    out += ["## Reuse overhead and per-step time (Fig. 8 analogue)",
            "(paper, armadillo: the reuse steps cost about 2.5 ms against a 60 ms baseline trace)", "",
            "| scene | setting | variant | " + " | ".join(FIG8_STEPS) + " | reuse steps / baseline photon-trace "
            "| baseline photon-trace / light-transport work |",
            "|---|---|---|" + "---|" * len(FIG8_STEPS) + "---|---|"]
    for (scene, setting), kinds in sorted(grid.items()):
        base = kinds.get("none")
        b_trace = later(base.pass_sums(("photon-trace",))).mean() if base is not None else math.nan
        for v in VARIANTS:
            c = kinds.get(v)
            if c is None:
                continue
            steps = [later(c.pass_sums((p,))) for p in FIG8_STEPS]
            means = [s.mean() if len(s) else math.nan for s in steps]
            overhead = later(c.pass_sums(REUSE_STEPS))
            ratio = overhead.mean() / b_trace if len(overhead) and b_trace > 0 else math.nan
            work = later(c.pass_sums(LIGHT_TRANSPORT)).mean()
            out.append(f"| {scene} | {setting} | {v} | " + " | ".join(f"{_f(m)} ms" for m in means) +
                       f" | {_f(ratio, 3)} | {_f(b_trace / work if work > 0 else math.nan, 2)}× |")
    out.append("")

    # -- 4. memory (Table 1) ------------------------------------------------------------------------
    out += ["## Memory per structure (Table 1 analogue, MiB; the paper's figures at 5M paths in brackets)", "",
            "| scene | setting | structure | none | naive | error_based |", "|---|---|---|---|---|---|"]
    for (scene, setting), kinds in sorted(grid.items()):
        for label, counter, p_none, p_lights, p_objects in TABLE1:
            vals = []
            for v in VARIANTS:
                c = kinds.get(v)
                s = counter_series(c, counter) if c is not None else pd.Series(dtype=float)
                vals.append(_f(s.max() / 2**20, 3) if len(s) else "–")
            paper = f" [paper: {p_none or '–'} / {p_lights or '–'} / {p_objects or '–'}]"
            out.append(f"| {scene} | {setting} | {label}{paper} | " + " | ".join(vals) + " |")
    out.append("")

    # -- 5. quality and flicker (beyond the paper) ---------------------------------------------------
    out += ["## Error against the reference (the paper measured none)",
            "(the issue's bar: within 10% of the baseline's relMSE at equal photon count. Floors: what the "
            "true image would score against these references, the means of metrics.csv's *_floor; a "
            "ratio of errors far above their floors compares the techniques, not the references' noise. "
            "Flicker: the technique's change from one frame to the next against the reference's own, over "
            "the consecutive frame pairs the config scores, with its floor)", "",
            "| scene | setting | variant | relMSE (indirect) | floor | / baseline | FLIP (indirect) | floor "
            "| / baseline | flicker (indirect) | floor | / baseline |",
            "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for (scene, setting), kinds in sorted(grid.items()):
        base = kinds.get("none")
        for v in VARIANTS:
            c = kinds.get(v)
            if c is None:
                continue
            row = f"| {scene} | {setting} | {v} |"
            for metric, digits in (("relmse", 4), ("flip", 4), ("flicker", 4)):
                value = c.metric_mean(metric, "indirect", FULL_REFERENCE)
                b = base.metric_mean(metric, "indirect", FULL_REFERENCE) if base is not None else math.nan
                floor = c.metric_mean(metric + "_floor", "indirect", FULL_REFERENCE)
                row += f" {_f(value, digits)} | {_f(floor, digits)} | {_f(value / b if b else math.nan, 3)} |"
            out.append(row)
    out.append("")
    out += equal_time(run)
    return "\n".join(out)
