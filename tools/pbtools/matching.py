"""A match run's tables and figure (`match:` in a config; harness/src/run/match.h): read from
RUN_DIR/match.csv (one row per scene and technique: the knob value found, its probes, the achieved time
from the re-measurement rounds with p5/p95, each metric with its floor, the spread over seeds) and
RUN_DIR/match_probes.csv (every cell the matches ran).

Equal time (at: time): the techniques of a scene at one frame time, ordered by error. Two neighbours'
order is resolved when floors.comparison_resolved says so for their scores and, with seeds, when their
difference is also more than twice the combined seed spread (sqrt(sd_a^2 + sd_b^2)); otherwise it may be
the reference's noise or the photons' luck.

Equal quality (at: quality): the techniques at one error, ordered by achieved time. Two neighbours'
order is resolved when their p5-p95 frame-time ranges do not overlap.

A technique that did not match (unreachable, not converged, below the floor, failed) keeps its row,
with its status and reason, and takes no place in the order; a baseline (`match: false`) is listed at
its config values.
"""

from __future__ import annotations

import csv
import math
import os
from typing import Dict, List, Optional

from . import floors, measures, style
from .figures import Figure, pareto_front, slug
from .rundata import current_name


def _float(text: str) -> float:
    try:
        return float(text)
    except (TypeError, ValueError):
        return math.nan


def _rows(path: str) -> List[Dict[str, str]]:
    if not os.path.exists(path):
        return []
    with open(path, newline="", encoding="utf-8") as f:
        # An older run's columns under their current names (its frame_ms_median is wall_ms_median).
        return [{current_name(k): v for k, v in row.items()} for row in csv.DictReader(f)]


def read_matches(run_dir: str) -> List[Dict[str, str]]:
    return _rows(os.path.join(run_dir, "match.csv"))


def read_probes(run_dir: str) -> List[Dict[str, str]]:
    return _rows(os.path.join(run_dir, "match_probes.csv"))


def _mode(rows: List[Dict[str, str]]) -> Optional[str]:
    modes = {r["at"] for r in rows if r["at"] in ("time", "quality")}
    return modes.pop() if len(modes) == 1 else None


def _lower(metric: str) -> bool:
    """mae (not in measures.METRICS) is an error like rmse: lower is better."""
    return metric not in measures.METRICS or measures.lower_is_better(metric)


def _floor_resolved(metric: str, a: Dict[str, str], b: Dict[str, str]) -> Optional[bool]:
    """floors.comparison_resolved on the two scores; for mae (a mean of absolute differences, which
    obeys the triangle inequality) its worst-case rule alone."""
    va, fa = _float(a.get(metric, "")), _float(a.get(f"{metric}_floor", ""))
    vb, fb = _float(b.get(metric, "")), _float(b.get(f"{metric}_floor", ""))
    if any(math.isnan(v) for v in (va, fa, vb, fb)):
        return None
    if metric in measures.METRICS:
        return floors.comparison_resolved(metric, va, fa, vb, fb)
    return abs(va - vb) > fa + fb


def _seed_resolved(a: Dict[str, str], b: Dict[str, str], metric: str) -> Optional[bool]:
    sa, sb = _float(a.get(f"{metric}_seed_sd", "")), _float(b.get(f"{metric}_seed_sd", ""))
    if math.isnan(sa) or math.isnan(sb):
        return None
    return abs(_float(a[metric]) - _float(b[metric])) > 2 * math.sqrt(sa * sa + sb * sb)


def _verdict(parts: List[Optional[bool]]) -> str:
    known = [p for p in parts if p is not None]
    if not known:
        return "unknown (no floors)"
    return "resolved" if all(known) else "unresolved"


def order_verdict(a: Dict[str, str], b: Dict[str, str], metric: str, mode: str) -> str:
    """Whether match.csv row `a` placed before row `b` holds: "resolved", "unresolved" or "unknown (no
    floors)". At equal time (mode "time") `a` has the better `metric` and the difference must beat the
    floors and, with seeds, twice the combined seed spread; at equal quality `a` is the faster and its
    p95 frame time must lie below `b`'s p5. The tables here and the claims (tools/pbtools/claims) share
    it."""
    if mode == "time":
        parts = [_floor_resolved(metric, a, b), _seed_resolved(a, b, metric)]
    else:
        parts = [_float(a["wall_ms_p95"]) < _float(b["wall_ms_p5"])]
    return _verdict(parts)


def time_text(r: Dict[str, str]) -> str:
    m, lo, hi = (_float(r[k]) for k in ("wall_ms_median", "wall_ms_p5", "wall_ms_p95"))
    if math.isnan(m):
        return ""
    return f"{m:.4g} [{lo:.4g}, {hi:.4g}]"


def score_text(r: Dict[str, str], metric: str) -> str:
    v, f = _float(r.get(metric, "")), _float(r.get(f"{metric}_floor", ""))
    if math.isnan(v):
        return ""
    text = f"{v:.4g}" + ("" if math.isnan(f) else f" (floor {f:.3g})")
    sd = _float(r.get(f"{metric}_seed_sd", ""))
    return text + ("" if math.isnan(sd) else f" ±{sd:.2g} over seeds")


def scene_table(rows: List[Dict[str, str]], metric: str) -> dict:
    """One scene's equal-time or equal-quality table: the matched rows in order (by `metric` at equal
    time, by achieved time at equal quality), each with whether its order against the next holds,
    then the rows that did not match and the baselines."""
    mode = _mode(rows) or "time"
    matched = [r for r in rows if r["status"] == "matched"]
    key = (lambda r: _float(r[metric])) if mode == "time" else (lambda r: _float(r["wall_ms_median"]))
    if mode == "time" and metric and not _lower(metric):
        matched.sort(key=lambda r: -key(r))
    else:
        matched.sort(key=key)
    out = []
    for i, r in enumerate(matched):
        order = ""
        if i + 1 < len(matched):
            n = matched[i + 1]
            order = f"{order_verdict(r, n, metric, mode)} against {n['technique']}"
        out.append(_view(r, metric, order))
    others = [r for r in rows if r["status"] != "matched"]
    return {"mode": mode, "metric": metric, "rows": out + [_view(r, metric, "") for r in others]}


def _view(r: Dict[str, str], metric: str, order: str) -> dict:
    knob = f"{r['knob']} = {r['knob_value']}" if r["knob"] and r["knob_value"] else ""
    return {"technique": r["technique"], "status": r["status"], "knob": knob, "probes": r["probes"],
            "time": time_text(r), "rounds": r["rounds"], "score": score_text(r, metric),
            "order": order, "reason": r["reason"], "cell": r["cell"]}


def probes_figure(run_dir: str, scene: str, metric: str, styles: style.TechniqueStyle,
                  target: Optional[float], mode: str) -> Optional[Figure]:
    """Every probe of the scene's matches on the error-against-time plane, each technique's probes
    joined in knob order, the kept one ringed, the target drawn, and the Pareto front through all."""
    probes = [p for p in read_probes(run_dir) if p["scene"] == scene and p["role"] in ("probe", "baseline")
              and p["status"] == "ok" and not math.isnan(_float(p.get(metric, "")))
              and not math.isnan(_float(p["wall_ms_median"]))]
    if not probes:
        return None
    found = {r["cell"] for r in read_matches(run_dir) if r["scene"] == scene}
    fig, axes = style.new_figure(3.4, 2.4)
    ax = axes[0][0]
    xs = [_float(p["wall_ms_median"]) for p in probes]
    ys = [_float(p[metric]) for p in probes]
    front = pareto_front(xs, ys, _lower(metric))
    if front:
        ax.plot([xs[i] for i in front], [ys[i] for i in front], drawstyle="steps-post",
                color=style.PARETO_COLOR, lw=0.8, ls="--", zorder=1, label="Pareto front of the probes")
    techniques = sorted({p["technique"] for p in probes})
    for tech in techniques:
        tp = [p for p in probes if p["technique"] == tech]
        tp.sort(key=lambda p: _float(p["knob_value"]) if p["knob_value"] else 0.0)
        color, marker = styles.color(tech), styles.marker(tech)
        tx = [_float(p["wall_ms_median"]) for p in tp]
        ty = [_float(p[metric]) for p in tp]
        ax.plot(tx, ty, color=color, lw=0.6, alpha=0.6, zorder=2)
        ax.plot(tx, ty, ls="none", marker=marker, color=color, markeredgecolor="white",
                markeredgewidth=0.4, zorder=3, label=tech, gid=f"probes:{tech}")
        kept = [(x, y) for p, x, y in zip(tp, tx, ty) if p["cell"] in found]
        if kept:
            ax.plot([k[0] for k in kept], [k[1] for k in kept], ls="none", marker="o", ms=8,
                    markerfacecolor="none", markeredgecolor=color, markeredgewidth=0.9, zorder=4,
                    gid=f"found:{tech}")
    if target is not None:
        (ax.axvline if mode == "time" else ax.axhline)(target, color="0.4", lw=0.6, ls=":", zorder=0,
                                                       label="target")
    ax.set_xscale("log")
    ax.set_xlabel("median frame time [ms]")
    ax.set_ylabel(measures.metric(metric).label if metric in measures.METRICS else metric)
    ax.legend(fontsize=5, loc="best")
    fig.tight_layout()
    header = ["technique", "role", "knob", "knob_value", "cell", "wall_ms_median", metric, "kept",
              "pareto"]
    rows = [[p["technique"], p["role"], p["knob"], p["knob_value"], p["cell"], xs[i], ys[i],
             int(p["cell"] in found), int(i in front)] for i, p in enumerate(probes)]
    caption = ("Each probe of the search (a cell of the run) at its median frame time and mean error; a "
               "technique's probes are joined in knob order, the one kept is ringed, the dotted line is "
               "the target, and the dashed staircase the Pareto front through every probe.")
    return Figure(f"match_probes_{slug(scene)}", f"{scene}: the match's probes", caption, fig, header,
                  rows)


def view(run_dir: str, styles: style.TechniqueStyle) -> Optional[dict]:
    """The report's matching section (None for a run without match.csv): per scene, its table and the
    probes' figure (unsaved)."""
    rows = read_matches(run_dir)
    if not rows:
        return None
    mode, metric = mode_and_metric(run_dir, rows)
    target = next((_float(r["target"]) for r in rows if r["target"]), None)
    scenes = []
    for scene in dict.fromkeys(r["scene"] for r in rows):
        sr = [r for r in rows if r["scene"] == scene]
        scenes.append({"name": scene, "table": scene_table(sr, metric),
                       "figure": probes_figure(run_dir, scene, metric, styles, target, mode)})
    return {"mode": mode, "target": target, "metric": metric, "scenes": scenes}


def mode_and_metric(run_dir: str, rows: List[Dict[str, str]]) -> (str, str):
    """The run's match mode ("time" or "quality") and the metric its tables order by: the matched
    metric at equal quality, the first error metric with a column at equal time."""
    mode = _mode(rows) or "time"
    return mode, _config_metric(run_dir) if mode == "quality" else _first_metric(rows)


def measured_cells(run_dir: str, row: Dict[str, str]) -> List[str]:
    """The cells whose frames give a match.csv row its achieved time (run/match.cpp, achieved_time):
    the found cell's ok re-measurement rounds ("<found id>__round<r>", match_probes.csv's role
    "round"), or the found cell itself when it has none."""
    if not row.get("cell"):
        return []
    prefix = row["cell"] + "__round"
    rounds = [p["cell"] for p in read_probes(run_dir)
              if p["role"] == "round" and p["cell"].startswith(prefix) and p["status"] == "ok"]
    return rounds or [row["cell"]]


def _first_metric(rows: List[Dict[str, str]]) -> str:
    """The first error metric with a column: flip before the others."""
    for m in ("flip", "rmse", "relmse", "mae", "ssim", "psnr"):
        if rows and m in rows[0]:
            return m
    return ""


def _config_metric(run_dir: str) -> str:
    """match.metric of the run's config (run.json's YAML text)."""
    import json

    import yaml

    try:
        with open(os.path.join(run_dir, "run.json"), encoding="utf-8") as f:
            info = json.load(f)
        config = info.get("config")
        config = yaml.safe_load(config) if isinstance(config, str) else config
        return str(config["match"]["metric"])
    except (OSError, KeyError, TypeError, ValueError, yaml.YAMLError):
        return _first_metric(read_matches(run_dir))
