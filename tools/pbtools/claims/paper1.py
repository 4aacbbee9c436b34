"""Paper I (Moreau et al., HPG 2016) claims, measured on a run of configs/paper1.yaml.

The comparisons, with the paper's statements (digest seed002-papers-I-II.md §6.4-6.6):
  * speed: "the cluster-trivial method is on average about two times faster than the tiled method, and up
    to three at some peaks" (splat + radiance estimate; Fig. 6 also counts the hierarchy build);
  * efficiency: "less than 3% of the photons read from the lists are rejected" (cluster);
  * directional: "another 2-3x speedup", "little variance in execution times" (Fig. 6 near-flat);
  * memory per structure (Table 1) and quality per technique and setting (Table 2: SSIM %, PSNR dB),
    each score marked † when it lies within 4x its noise floor (floors.py), the techniques ordered by
    FLIP with "<" where the difference exceeds both floors and "≈" where it does not; against the full
    reference, and again against the bounce-matched one when the run scored it
    (reference: {bounce_matched: true}), so truncation and the estimator's own error separate.
Paper I makes no equal-time or equal-cost comparison (its ratios are at equal photon count and radius); the
claims say so, and from a matched run (match.csv) list its techniques' rows as what it did not measure: at
equal time the FLIP order, at equal quality the splat + estimate + build ratios of the pairs it compares.
Every "A beats B" and "A equals B" statement (the FLIP order: `<`, `≈`, `=`) carries the statistical
test behind it and its p-value (stats.py): Welch's t-test across seeds on the per-seed mean FLIP, one-
sided for "beats", two-sided for "equals" (a p-value below 0.05 rejects the equality). A run without a
seed axis (`run --seeds K`) has one sample per cell, and the row says the test was not possible. With
seeds, the tables show each cell's first seed and the tests use all of them.
A technique's "kind" is its name plus its `variant` when it has one (cluster-plain, cluster-trivial...);
a "setting" is its (photons, radius) pair. Ratios are per frame (same frame index, same scene and
setting), then averaged: the paper's Fig. 6 compares curves over the same fly-through.
"""

import math
import re
from collections import defaultdict
from typing import Dict, List, Optional, Tuple

import numpy as np
import pandas as pd

from .. import floors, matching, measures, seeds, stats
from ..rundata import BOUNCE_MATCHED_REFERENCE, FULL_REFERENCE, Cell, Run, format_param

TITLE = "Photon Splatting Using a View-Sample Cluster Hierarchy (Moreau et al., HPG 2016)"

# Passes of "splat + estimate" (the issue's and Fig. 6's splatting time) and the structure build that
# Fig. 6/9 add to it. Photon tracing, the G-buffer, direct light and the final shade are excluded, as the
# paper excludes them ("the time is similar for all methods").
SPLAT_ESTIMATE = ("splat", "radiance-estimate", "blur")
BUILD = ("tile-bounds", "cluster-build")

# Paper I Table 1 (MiB, 1920x1080, Sponza, 10k photons of radius 4): row -> (counter, cluster, directional,
# tiled). "-" where the technique has no such structure.
TABLE1 = [
    ("Tiles z-Bounds", "bytes_tile_bounds", None, None, 0.016),
    ("Cluster Hierarchy", "bytes_cluster_hierarchy", 97, 97, None),
    ("Final Bounds", "bytes_final_bounds", 256, 256, None),
    ("Normal Cone", "bytes_normal_cone", 24, None, None),
    ("Accum. Flux", "bytes_accum_flux", 73, 582, None),
    ("Jobs", "bytes_jobs", 2.4, 2.4, None),
    ("Photons Array", "bytes_photon_lists", 60, None, 28),
    ("Photon Map", "bytes_photons", 0.16, 0.16, 0.16),
]


class MissingCells(Exception):
    pass


def kind(cell: Cell) -> str:
    variant = cell.params.get("variant")
    return f"{cell.technique}-{variant}" if variant is not None else cell.technique


def setting(cell: Cell) -> Tuple[float, float]:
    return (float(cell.params.get("photons", math.nan)), float(cell.params.get("radius", math.nan)))


def setting_label(s: Tuple[float, float]) -> str:
    if math.isnan(s[0]):  # a technique without a photons parameter
        return "default"
    return f"{format_param(int(s[0]) if s[0] == int(s[0]) else s[0])} paths, r {format_param(s[1])}"


def frame_ratios(slow: pd.Series, fast: pd.Series) -> np.ndarray:
    """slow / fast on the frames both have (frame order), where fast took any time."""
    slow, fast = slow.align(fast, join="inner")
    keep = fast > 0
    return (slow[keep] / fast[keep]).to_numpy(float)


def counter_values(cell: Cell, name: str) -> pd.Series:
    c = cell.counters
    return c.loc[c["name"] == name, "value"].dropna()


def counter_sum(cell: Cell, name: str) -> float:
    return float(counter_values(cell, name).sum())


def counter_max(cell: Cell, name: str) -> Optional[float]:
    values = counter_values(cell, name)
    return float(values.max()) if len(values) else None


def resolution(run: Run) -> str:
    """The run's resolution as configured (run.json keeps the config text and the --set overrides)."""
    text = "?"
    m = re.search(r"^resolution:\s*(\[[^\]]*\])", str(run.info.get("config", "")), re.M)
    if m:
        text = m.group(1)
    for o in run.info.get("overrides") or []:
        if str(o).startswith("resolution="):
            text = str(o).split("=", 1)[1]
    return text


def _f(v: float, digits: int = 2) -> str:
    return "–" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.{digits}f}"


# -- a matched run (`match:`; match.csv, read by tools/pbtools/matching.py) -----------------------------
# Shared by the claims modules: each states its paper's equal-time (or equal-cost) comparison from the
# rows of match.csv, in the paper's own quantity, each score beside its floor and each order marked
# resolved or not by matching.order_verdict (the report's rule).

def matched_rows(run: Run, techniques) -> Tuple[str, str, List[Tuple[Dict[str, str], Optional[Cell]]]]:
    """(mode, metric, [(match.csv row, its found cell)]) for the rows of `techniques`: mode "time" or
    "quality", metric the one the report's tables order by; no rows for a run without match.csv."""
    rows = [r for r in matching.read_matches(run.path) if r["technique"] in techniques]
    if not rows:
        return "", "", []
    mode, metric = matching.mode_and_metric(run.path, rows)
    return mode, metric, [(r, run.cell(r["cell"]) if r["cell"] else None) for r in rows]


def class_row(run: Run, row: Dict[str, str], metric: str, path_class: str) -> Dict[str, str]:
    """A match.csv row whose `metric`, floor and seed spread are one path class's (match.csv holds the
    combined image's): the found cell's means over its metric frames, and the sample standard
    deviation over it and its seed cells (match_probes.csv's role "seed" of its seed group), so that
    matching.order_verdict and score_text judge that class by the report's rule."""
    out = dict(row, **{metric: "", f"{metric}_floor": "", f"{metric}_seed_sd": ""})
    found = run.cell(row["cell"]) if row.get("cell") else None
    if found is None or not found.ok:
        return out
    group = seeds.seed_group(found)
    others = [run.cell(p["cell"]) for p in matching.read_probes(run.path) if p["role"] == "seed"]
    others = [c for c in others if c is not None and seeds.seed_group(c) == group]
    values = [c.metric_mean(metric, path_class) for c in [found] + others if c.ok]
    values = [v for v in values if not math.isnan(v)]
    out[metric] = "" if math.isnan(found.metric_mean(metric, path_class)) else repr(
        found.metric_mean(metric, path_class))
    floor = found.metric_mean(metric + floors.FLOOR_SUFFIX, path_class)
    out[f"{metric}_floor"] = "" if math.isnan(floor) else repr(floor)
    if len(values) > 1:
        out[f"{metric}_seed_sd"] = repr(float(np.std(values, ddof=1)))
    return out


def missing_match(techniques, config: str) -> List[str]:
    """What the claims say of a comparison the run did not measure."""
    return [f"Not measured: this run has no match.csv with {' or '.join(techniques)} rows. The comparison "
            f"needs a matched run: `photonbench run {config}`.", ""]


def matched_pairs(by_scene: Dict[str, Dict[str, Dict[str, str]]], base: str, others):
    """(scene, other, its row, base's row, why they are not compared: "" when both matched, else each
    unmatched side's status and reason) for every scene whose rows (variant -> match.csv row) hold
    `base` and one of `others`."""
    for scene, variants in by_scene.items():
        for other in others:
            a, b = variants.get(other), variants.get(base)
            if a is None or b is None:
                continue
            why = "; ".join(f"{name} {r['status']} ({r['reason']})" for name, r in ((other, a), (base, b))
                            if r["status"] != "matched")
            yield scene, other, a, b, why


def matched_pass_ms(run: Run, row: Dict[str, str], passes) -> float:
    """The median, over the frames that give a match.csv row its achieved time (its rounds:
    matching.measured_cells), of each frame's summed time of `passes`; NaN when none ran."""
    cells = [run.cell(i) for i in matching.measured_cells(run.path, row)]
    series = [c.pass_sums(passes) for c in cells if c is not None and c.ok]
    series = [s for s in series if len(s)]
    return float(pd.concat(series).median()) if series else math.nan


def knob_value(row: Dict[str, str]) -> str:
    """The knob value a match found, as written by the run ("" when it found none)."""
    v = row.get("knob_value", "")
    try:
        return format_param(int(float(v))) if float(v) == int(float(v)) else format_param(float(v))
    except (TypeError, ValueError, OverflowError):
        return v


def equal_time_held(a: Dict[str, str], b: Dict[str, str]) -> str:
    """Whether two rows' achieved times are one time as far as their spread tells: their p5-p95 ranges
    overlap (matching.order_verdict at equal quality leaves the faster's lead unresolved)."""
    fast, slow = sorted((a, b), key=lambda r: float(r["wall_ms_median"] or "nan"))
    if matching.order_verdict(fast, slow, "", "quality") == "resolved":
        return (f"not held: the re-measured times are apart ({matching.time_text(fast)} against "
                f"{matching.time_text(slow)} ms, p5-p95 not overlapping)")
    return "held (the p5-p95 ranges of the re-measured times overlap)"


def score_order(a: Dict[str, str], b: Dict[str, str], metric: str, name_a: str, name_b: str) -> str:
    """"A's FLIP x (floor f) is lower than B's y (floor g), resolved" (or unresolved: matching's rule)."""
    va, vb = float(a.get(metric) or "nan"), float(b.get(metric) or "nan")
    if math.isnan(va) or math.isnan(vb):
        return f"{metric} not scored"
    lower = not (metric in measures.METRICS and not measures.lower_is_better(metric))
    better, worse, nb, nw = (a, b, name_a, name_b) if (va < vb) == lower else (b, a, name_b, name_a)
    verdict = matching.order_verdict(better, worse, metric, "time")
    return (f"{nb} {matching.score_text(better, metric)} is better than {nw} "
            f"{matching.score_text(worse, metric)}: {verdict}")


def claims(run: Run) -> str:
    cells = [c for c in run.cells if c.ok]
    if not cells:
        raise MissingCells("no completed cells")
    # (scene, setting) -> kind -> cell (the first seed's), and every seed's cells
    grid: Dict[Tuple[str, Tuple[float, float]], Dict[str, Cell]] = defaultdict(dict)
    replicas: Dict[Tuple[str, Tuple[float, float]], Dict[str, List[Cell]]] = defaultdict(
        lambda: defaultdict(list))
    for group in seeds.groups(run).values():
        for c in group:
            if c.ok and c.technique in ("tiled", "cluster", "directional"):
                grid[(c.scene, setting(c))].setdefault(kind(c), c)
                replicas[(c.scene, setting(c))][kind(c)].append(c)
    if not grid:
        raise MissingCells("no tiled, cluster or directional cells")

    out: List[str] = [f"# Paper I claims, measured: {run.name}", "",
                      f"{TITLE}. Device: {run.device}; commit {run.commit}.",
                      "Times per frame are pass medians' building blocks: the per-frame sum of the passes "
                      f"{', '.join(SPLAT_ESTIMATE)} (\"splat + estimate\"), and with {' / '.join(BUILD)} "
                      "added (\"+ build\", as Paper I Fig. 6/9). Ratios are taken frame by frame, then "
                      "averaged; \"peak\" is the largest per-frame ratio.", ""]

    # -- 1. cluster vs tiled -------------------------------------------------------------------------
    out += ["## Cluster vs tiled (paper: cluster-trivial ≈2× faster on average, up to 3× at peaks)", "",
            "| scene | setting | cluster variant | tiled / cluster, splat + estimate: mean (peak) | "
            "+ build: mean (peak) |", "|---|---|---|---|---|"]
    for (scene, s), kinds in sorted(grid.items()):
        tiled = kinds.get("tiled")
        if not tiled:
            continue
        t_se, t_b = tiled.pass_sums(SPLAT_ESTIMATE), tiled.pass_sums(SPLAT_ESTIMATE + BUILD)
        for k in sorted(k for k in kinds if k.startswith("cluster")):
            r1 = frame_ratios(t_se, kinds[k].pass_sums(SPLAT_ESTIMATE))
            r2 = frame_ratios(t_b, kinds[k].pass_sums(SPLAT_ESTIMATE + BUILD))
            if len(r1):
                out.append(f"| {scene} | {setting_label(s)} | {k} | {_f(r1.mean())}× ({_f(r1.max())}×) | "
                           f"{_f(r2.mean())}× ({_f(r2.max())}×) |")
    out.append("")

    # -- 2. rejection ----------------------------------------------------------------------------------
    out += ["## Photons read from lists but rejected in the estimate (paper: < 3% for cluster)", "",
            "| scene | setting | technique | photons read / frame | rejected | trivial accepts / frame |",
            "|---|---|---|---|---|---|"]
    for (scene, s), kinds in sorted(grid.items()):
        for k, c in sorted(kinds.items()):
            read = counter_sum(c, "photons_read")
            if read <= 0:
                continue
            frames = max(1, c.counters["frame"].nunique())
            rej = counter_sum(c, "photons_rejected") / read * 100.0
            trivial = counter_sum(c, "trivial_accepts") / frames
            out.append(f"| {scene} | {setting_label(s)} | {k} | {read / frames:,.0f} | {rej:.2f}% | "
                       f"{trivial:,.0f} |")
    out.append("")

    # -- 3. directional -------------------------------------------------------------------------------
    out += ["## Directional (paper: a further 2–3× over cluster-trivial, near-constant frame time)", "",
            "| scene | setting | cluster-trivial / directional, splat + estimate: mean (peak) | + build | "
            "frame-to-frame CV of splat + estimate + build: tiled / cluster-trivial / directional |",
            "|---|---|---|---|---|"]

    def cv(c: Optional[Cell]) -> str:
        if c is None:
            return "–"
        v = measures.coefficient_of_variation(c.pass_sums(SPLAT_ESTIMATE + BUILD))
        return f"{v * 100:.1f}%" if math.isfinite(v) else "–"

    for (scene, s), kinds in sorted(grid.items()):
        d, ct = kinds.get("directional"), kinds.get("cluster-trivial")
        if not d:
            continue
        if ct:
            r1 = frame_ratios(ct.pass_sums(SPLAT_ESTIMATE), d.pass_sums(SPLAT_ESTIMATE))
            r2 = frame_ratios(ct.pass_sums(SPLAT_ESTIMATE + BUILD), d.pass_sums(SPLAT_ESTIMATE + BUILD))
            speed, build = f"{_f(r1.mean())}× ({_f(r1.max())}×)", f"{_f(r2.mean())}×"
        else:
            speed = build = "–"
        out.append(f"| {scene} | {setting_label(s)} | {speed} | {build} | "
                   f"{cv(kinds.get('tiled'))} / {cv(ct)} / {cv(d)} |")
    out.append("")

    # Sensitivity to the photon count at a fixed radius (the thesis: directional "less sensitive to the
    # amount of photons processed").
    by_radius: Dict[Tuple[str, str, float], List[Tuple[float, float]]] = defaultdict(list)
    for (scene, s), kinds in grid.items():
        for k, c in kinds.items():
            m = c.pass_medians()
            t = sum(m.get(p, 0.0) for p in SPLAT_ESTIMATE + BUILD)
            by_radius[(scene, k, s[1])].append((s[0], t))
    rows = []
    for (scene, k, r), pts in sorted(by_radius.items()):
        if len(pts) < 2:
            continue
        pts.sort()
        (n0, t0), (n1, t1) = pts[0], pts[-1]
        if t0 > 0:
            rows.append(f"| {scene} | {k} | {format_param(r)} | {int(n0):,} → {int(n1):,} | "
                        f"{t0:.1f} → {t1:.1f} ms | {t1 / t0:.2f}× |")
    if rows:
        out += ["### Time against photon count (median splat + estimate + build)", "",
                "| scene | technique | radius | paths | time | growth |", "|---|---|---|---|---|---|"] + rows + [""]

    # -- 4. memory -------------------------------------------------------------------------------------
    out += ["## Memory per structure, MiB (Paper I Table 1: 1920×1080, Sponza, 10k photons, r 4)", "",
            f"Measured at this run's resolution ({resolution(run)}) and, "
            "per technique, its largest photon setting in the run (largest memory).", ""]
    largest: Dict[Tuple[str, str], Cell] = {}
    for (scene, s), kinds in grid.items():
        for k, c in kinds.items():
            if k in ("tiled", "cluster-trivial", "directional"):
                prev = largest.get((scene, k))
                if prev is None or setting(c) > setting(prev):
                    largest[(scene, k)] = c
    for scene in sorted({sc for sc, _ in largest}):
        out += [f"**{scene}**", "", "| structure | cluster-trivial (paper) | directional (paper) | tiled (paper) |",
                "|---|---|---|---|"]
        totals = [0.0, 0.0, 0.0]
        counted = [False, False, False]  # a technique that did not run has no total, not 0.000
        for row, counter, p_cluster, p_dir, p_tiled in TABLE1:
            cols = []
            for i, (k, paper) in enumerate((("cluster-trivial", p_cluster), ("directional", p_dir),
                                            ("tiled", p_tiled))):
                c = largest.get((scene, k))
                v = counter_max(c, counter) if c else None
                mib = v / 2**20 if v is not None else None
                if mib is not None:
                    totals[i] += mib
                    counted[i] = True
                paper_text = "–" if paper is None else f"{paper:g}"
                cols.append(f"{_f(mib, 3)} ({paper_text})")
            out.append(f"| {row} | " + " | ".join(cols) + " |")
        total = [f"{t:.3f}" if n else "– (not run)" for t, n in zip(totals, counted)]
        out.append(f"| **Total** | {total[0]} (513) | {total[1]} (942) | {total[2]} (28) |")
        out.append("")

    # -- 5. quality -------------------------------------------------------------------------------------
    references = [r for r in (FULL_REFERENCE, BOUNCE_MATCHED_REFERENCE)
                  if any(r in c.metric_references() for ks in grid.values() for c in ks.values())]
    for reference in references:
        out += quality_table(grid, reference)
        out += order_tests(grid, replicas, reference)
    out += equal_time(run)
    return "\n".join(out)


def equal_time(run: Run) -> List[str]:
    """Paper I makes no equal-time or equal-cost comparison; a matched run's rows of its techniques are
    listed as what the paper did not measure: at equal time the FLIP order, at equal quality its own
    quantity (splat + estimate time) between the pairs it compares."""
    out = ["## At equal time or equal quality",
           "Paper I makes no equal-time or equal-cost comparison. Its speed ratios (cluster-trivial about "
           "2× tiled, directional a further 2-3×) and Table 2's quality are at equal photon count and "
           "radius: for tiled and the cluster variants that is also equal quality (they splat the same "
           "photons with the same estimator), for directional it is not (its node-level flux is an "
           "approximation; \"the difference in image quality is minimal\").", ""]
    mode, metric, rows = matched_rows(run, ("tiled", "cluster", "directional"))
    if not rows:
        return out + ["This run has no match.csv with tiled, cluster or directional rows (a matched run, "
                      "`photonbench run configs/equal-time.yaml`, adds what the paper did not measure).", ""]
    kinds = {id(r): kind(c) if c is not None else r["technique"] for r, c in rows}
    at = "equal time" if mode == "time" else f"equal {metric}"
    out += [f"Beyond the paper, this matched run at {at} (target {rows[0][0]['target']}): each technique's "
            "photons found by the match; the achieved frame time over the re-measurement rounds, median "
            "[p5, p95]; splat + estimate + build (the paper's time) as the median of those frames' sums; "
            f"{metric} of the combined image with the reference's floor; each order against the next row "
            "resolved or not (the report's rule: at equal time by the floors and seeds, at equal quality "
            "by the time spread).", "",
            f"| scene | technique | status | photons | frame ms | splat + estimate + build ms | {metric} | "
            "order |", "|---|---|---|---|---|---|---|---|"]
    ratios: List[str] = []
    for scene in dict.fromkeys(r["scene"] for r, _ in rows):
        scene_rows = [r for r, _ in rows if r["scene"] == scene]
        for i, r in enumerate(ordered := table_order(scene_rows, metric)):
            nxt = ordered[i + 1] if i + 1 < len(ordered) else None
            order = ""
            if r["status"] == "matched" and nxt is not None and nxt["status"] == "matched":
                order = f"{matching.order_verdict(r, nxt, metric, mode)} against {kinds[id(nxt)]}"
            out.append(f"| {scene} | {kinds[id(r)]} | {r['status']} | {knob_value(r)} | "
                       f"{matching.time_text(r) or '–'} | "
                       f"{_f(matched_pass_ms(run, r, SPLAT_ESTIMATE + BUILD), 1)} | "
                       f"{matching.score_text(r, metric) or '–'} | {order} |")
        if mode == "quality":
            by_kind = {kinds[id(r)]: r for r in scene_rows if r["status"] == "matched"}
            for slow, fast, paper in (("tiled", "cluster-trivial", "about 2× (up to 3×)"),
                                      ("cluster-trivial", "directional", "a further 2-3×")):
                if slow in by_kind and fast in by_kind:
                    ratio = (matched_pass_ms(run, by_kind[slow], SPLAT_ESTIMATE + BUILD) /
                             matched_pass_ms(run, by_kind[fast], SPLAT_ESTIMATE + BUILD))
                    ratios.append(f"* {scene}: {slow} / {fast}, splat + estimate + build at equal {metric}: "
                                  f"{_f(ratio)}× (paper, at equal settings: {paper})")
    return out + [""] + ratios + ([""] if ratios else [])


def table_order(rows: List[Dict[str, str]], metric: str) -> List[Dict[str, str]]:
    """One scene's match.csv rows in the order of the report's table (matching.scene_table: the matched
    ones by error at equal time or by time at equal quality, then the others)."""
    left = list(rows)
    ordered = []
    for v in matching.scene_table(rows, metric)["rows"]:
        r = next(r for r in left if (r["cell"], r["technique"], r["status"]) ==
                 (v["cell"], v["technique"], v["status"]))
        left.remove(r)
        ordered.append(r)
    return ordered


# Table 2's cells: (metric, path class, shown as, digits). SSIM is shown in percent, as the paper does.
QUALITY = [("ssim", "combined", 100.0, 1), ("psnr", "combined", 1.0, 1), ("flip", "combined", 1.0, 3),
           ("flip", "indirect", 1.0, 3), ("relmse", "indirect", 1.0, 3)]
UNRESOLVED_MARK = "†"


def _score(c: Cell, metric: str, cls: str, reference: str) -> Tuple[float, float]:
    return (c.metric_mean(metric, cls, reference),
            c.metric_mean(metric + floors.FLOOR_SUFFIX, cls, reference))


def _quality_text(values: List[Tuple[float, float, bool]]) -> str:
    """"SSIM / PSNR / FLIP; ind. FLIP / relMSE", each value marked when unresolved."""
    parts = [_f(v * scale, digits) + (UNRESOLVED_MARK if loose else "")
             for (v, loose), (_, _, scale, digits) in zip(values, QUALITY)]
    return " / ".join(parts[:3]) + "; ind. " + " / ".join(parts[3:])


def flip_order(kinds: Dict[str, Cell], cls: str, reference: str) -> List[Tuple[str, float, str]]:
    """The kinds ordered by FLIP (best first) as (kind, FLIP, separator before it): "=" between
    neighbours equal to the digits shown, "<" where their order holds against the true image
    whatever the reference's noise (the report's verdict rule, verdict.py: the gap beats both
    floors together), "≈" where it may not, "," where a floor is missing; the first kind's
    separator is "". The seed test of each pair is order_tests'."""
    scored = []
    for k, c in kinds.items():
        v, f = _score(c, "flip", cls, reference)
        if math.isfinite(v):
            scored.append((v, f, k))
    scored.sort(reverse=not measures.lower_is_better("flip"))
    if not scored:
        return []
    order = [(scored[0][2], scored[0][0], "")]
    for (va, fa, _), (vb, fb, kb) in zip(scored, scored[1:]):
        if f"{va:.3f}" == f"{vb:.3f}":
            sep = "="
        else:
            holds = (floors.order_holds_in_worst_case("flip", va, fa, vb, fb)
                     if math.isfinite(fa) and math.isfinite(fb) else None)
            sep = {True: "<", False: "≈", None: ","}[holds]
        order.append((kb, vb, sep))
    return order


def flip_ranking(kinds: Dict[str, Cell], cls: str, reference: str) -> str:
    """flip_order as text: "a 0.100 < b 0.200 ≈ c 0.210"."""
    order = flip_order(kinds, cls, reference)
    if not order:
        return "–"
    return "".join((f"{sep} " if sep == "," else f" {sep} " if sep else "") + f"{k} {v:.3f}"
                   for k, v, sep in order)


def order_tests(grid: Dict[Tuple[str, Tuple[float, float]], Dict[str, Cell]],
                replicas: Dict[Tuple[str, Tuple[float, float]], Dict[str, List[Cell]]],
                reference: str) -> List[str]:
    """Every neighbouring pair of the FLIP order as a claim, "A beats B" (`<`) or "A equals B" (`≈`,
    `=`), with Welch's t-test across seeds on the per-seed mean FLIP and its p-value."""
    which = "the full" if reference == FULL_REFERENCE else "the bounce-matched"
    out = [f"### Tests behind the FLIP order, against {which} reference", "",
           "Each neighbouring pair of the order above. \"A beats B\": Welch's t-test, one-sided (H0: A's "
           "mean FLIP is not lower); \"A equals B\": two-sided (H0: equal means; a p-value below "
           f"{stats.ALPHA:g} rejects the equality). Samples: each seed's mean FLIP over the metric frames. "
           "The test is on the techniques' own Monte Carlo noise against one reference; the reference's "
           "noise, which shifts every seed's score alike, is what the floors and `≈` above account for: "
           "an order needs both to hold against the true image.",
           "", "| scene | setting | class | claim | test | seeds | p |", "|---|---|---|---|---|---|---|"]
    for (scene, s), kinds in sorted(grid.items()):
        ks = {kind: c for kind, c in kinds.items() if reference in c.metric_references()}
        for cls in ("combined", "indirect"):
            order = flip_order(ks, cls, reference)
            for (ka, _, _), (kb, _, sep) in zip(order, order[1:]):
                if sep == ",":
                    continue
                beats = sep == "<"
                a = seeds.per_seed_means(replicas[(scene, s)][ka], "flip", cls, reference)
                b = seeds.per_seed_means(replicas[(scene, s)][kb], "flip", cls, reference)
                w = stats.welch(a, b, "less" if beats else "two-sided")
                claim = f"{ka} beats {kb}" if beats else f"{ka} equals {kb}"
                p = f"{w.p:.3g}" if w.possible else "–"
                out.append(f"| {scene} | {setting_label(s)} | {cls} | {claim} | {w.test} | "
                           f"{w.n_a} / {w.n_b} | {p} |")
    out.append("")
    return out


def quality_table(grid: Dict[Tuple[str, Tuple[float, float]], Dict[str, Cell]], reference: str) -> List[str]:
    kinds_present = sorted({k for ks in grid.values() for k, c in ks.items()
                            if reference in c.metric_references()})
    against = ("the full reference" if reference == FULL_REFERENCE else
               "the bounce-matched reference (truncated at each technique's max_bounces, so truncation is "
               "not counted as error: what is left is the estimator's)")
    k = floors.RESOLVE_FACTOR
    out = [f"## Quality (the analogue of Paper I Table 2), against {against}", "",
           "Combined image (direct + the technique's indirect) against the path-traced `combined` reference: "
           "SSIM %, PSNR dB, FLIP; then the technique's indirect estimate alone against the `indirect` "
           f"reference: FLIP and relMSE. {UNRESOLVED_MARK}: within {k:g}× the reference's noise floor "
           "(unresolved: the score may be the reference's noise). The floor column: what the true image "
           "itself scores against the same reference (the row's cells share it).", "",
           "| scene | setting | " + " | ".join(kinds_present) + " | floor |",
           "|---|---|" + "---|" * (len(kinds_present) + 1)]
    counted = loose_flip = 0
    for (scene, s), kinds in sorted(grid.items()):
        cols, floor_values = [], None
        for kind in kinds_present:
            c = kinds.get(kind)
            if c is None or reference not in c.metric_references():
                cols.append("")
                continue
            scores = [_score(c, m, cls, reference) for m, cls, _, _ in QUALITY]
            marks = [floors.resolved(m, v, f) is False for (m, _, _, _), (v, f) in zip(QUALITY, scores)]
            cols.append(_quality_text([(v, loose) for (v, _), loose in zip(scores, marks)]))
            if floors.resolved("flip", *scores[2]) is not None:
                counted += 1
                loose_flip += marks[2]
            if floor_values is None:
                floor_values = [(f, False) for _, f in scores]
        floor_text = _quality_text(floor_values) if floor_values else ""
        out.append(f"| {scene} | {setting_label(s)} | " + " | ".join(cols) + f" | {floor_text} |")
    out.append("")
    if counted:
        out += [f"Combined FLIP within {k:g}× its floor: {loose_flip} of {counted} cells.", ""]
    which = "the full" if reference == FULL_REFERENCE else "the bounce-matched"
    out += [f"### FLIP order per setting, against {which} reference", "",
            "Best first; `=`: equal to the digits shown; `<`: the order holds against the true image (both "
            f"scores at least {k:g}× their floors, or a difference beyond both floors together); `≈`: it may "
            "be the reference's noise (unresolved).", "",
            "| scene | setting | combined | indirect |", "|---|---|---|---|"]
    for (scene, s), kinds in sorted(grid.items()):
        ks = {kind: c for kind, c in kinds.items() if reference in c.metric_references()}
        if ks:
            out.append(f"| {scene} | {setting_label(s)} | {flip_ranking(ks, 'combined', reference)} | "
                       f"{flip_ranking(ks, 'indirect', reference)} |")
    out.append("")
    return out
