"""photonbench compare BASE_RUN NEW_RUN: did the change make any pass slower, or any image worse?

Timing, per cell and per pass (frames.csv, every measured frame is one sample):
  * change      = median(new) / median(base) - 1
  * test        = two-sided Mann-Whitney U on the two sets of per-frame samples: rank-based, so it needs
                  no normality and one slow frame (a spike from another process) moves it little;
  * noise       = each run's own robust per-frame noise, 1.4826 * MAD of successive differences / sqrt(2),
                  relative to its median. Successive differences remove the animation's slow change
                  of cost along the camera path, which is signal, not noise; MAD ignores spikes.
  * verdict     = slower when p < alpha AND change > max(threshold, k * noise) AND the absolute change
                  exceeds --min-ms; faster symmetrically. The p-value alone is not enough: two runs on a
                  noisy machine differ systematically by a few percent (clock, load), and with dozens of
                  frames a U test detects that; the threshold is the smallest change worth a red CI.
Metrics, per cell and path class (means over the metric frames of metrics.csv): error quantities are
compared relatively: FLIP and relMSE directly, SSIM through 1-SSIM, PSNR through the MSE it stands for
(a drop of d dB is an MSE ratio of 10^(d/10)); worse beyond --metric-tol percent is a regression.
A cell that was ok and now fails is a regression. Exit 1 on any regression, else 0 (2: bad input).
"""

from __future__ import annotations

import argparse
import json
import math
import re
import sys
from dataclasses import asdict, dataclass
from typing import Dict, List, Optional, Tuple

import numpy as np

from .rundata import Cell, Run, RunError, format_param

DEFAULTS = {"threshold": 10.0, "alpha": 0.01, "noise_k": 2.0, "metric_tol": 2.0, "min_ms": 0.02}
COMPARED_METRICS = ("flip", "ssim", "psnr", "relmse")
MIN_SAMPLES = 5  # with fewer frames per side a two-sided U test cannot reach p < 0.01


@dataclass
class PassRow:
    cell: str
    label: str
    pass_name: str
    n_base: int
    n_new: int
    base_ms: float
    new_ms: float
    change_pct: float
    p: float
    noise_pct: float
    limit_pct: float
    verdict: str  # "slower", "faster", "same", "n/a"


@dataclass
class MetricRow:
    cell: str
    label: str
    path_class: str
    metric: str
    base: float
    new: float
    error_change_pct: float  # change of the error quantity behind the metric (positive = worse)
    verdict: str  # "worse", "better", "same", "n/a"


@dataclass
class StatusRow:
    cell: str
    label: str
    base: str
    new: str
    verdict: str  # "regression", "fixed", "still failing", "new", "missing", "same"


@dataclass
class Comparison:
    base: Run
    new: Run
    passes: List[PassRow]
    metrics: List[MetricRow]
    statuses: List[StatusRow]
    settings: dict

    @property
    def regressions(self) -> int:
        return (sum(r.verdict == "slower" for r in self.passes) + sum(r.verdict == "worse" for r in self.metrics)
                + sum(r.verdict == "regression" for r in self.statuses))

    @property
    def improvements(self) -> int:
        return (sum(r.verdict == "faster" for r in self.passes) + sum(r.verdict == "better" for r in self.metrics)
                + sum(r.verdict == "fixed" for r in self.statuses))


def robust_noise(samples: np.ndarray) -> float:
    """Robust per-sample standard deviation from successive differences: for independent noise of
    s.d. sigma, x[i]-x[i-1] has s.d. sigma*sqrt(2); 1.4826*MAD estimates a normal s.d. robustly."""
    if len(samples) < 3:
        return math.nan
    d = np.diff(samples)
    mad = float(np.median(np.abs(d - np.median(d))))
    return 1.4826 * mad / math.sqrt(2.0)


def mann_whitney_p(a: np.ndarray, b: np.ndarray) -> float:
    from scipy.stats import mannwhitneyu
    if len(a) < MIN_SAMPLES or len(b) < MIN_SAMPLES:
        return math.nan
    if np.all(a == a[0]) and np.all(b == a[0]):
        return 1.0  # identical constant samples: scipy's normal approximation would divide by zero
    return float(mannwhitneyu(b, a, alternative="two-sided").pvalue)


def compare_samples(base: np.ndarray, new: np.ndarray, threshold: float, alpha: float, noise_k: float,
                    min_ms: float) -> Tuple[float, float, float, float, float, float, str]:
    """(base median, new median, change %, p, noise %, limit %, verdict) for one pass."""
    if len(base) == 0 or len(new) == 0:
        return (math.nan,) * 6 + ("n/a",)
    mb, mn = float(np.median(base)), float(np.median(new))
    change = (mn / mb - 1.0) * 100.0 if mb > 0 else math.nan
    p = mann_whitney_p(base, new)
    rel = [robust_noise(s) / m for s, m in ((base, mb), (new, mn)) if m > 0]
    rel = [r for r in rel if math.isfinite(r)]
    noise = noise_k * max(rel) * 100.0 if rel else 0.0
    limit = max(threshold, noise)
    if not math.isfinite(p) or not math.isfinite(change):
        verdict = "n/a"
    elif p < alpha and abs(mn - mb) > min_ms and change > limit:
        verdict = "slower"
    elif p < alpha and abs(mn - mb) > min_ms and change < -limit:
        verdict = "faster"
    else:
        verdict = "same"
    return mb, mn, change, p, noise, limit, verdict


def error_change(metric: str, base: float, new: float) -> float:
    """Relative change (%) of the error quantity behind a metric; positive means worse."""
    if not (math.isfinite(base) and math.isfinite(new)):
        return math.nan
    if metric == "psnr":  # PSNR = 10 log10(peak^2 / MSE): MSE_new / MSE_base = 10^((base - new) / 10)
        return (10.0 ** ((base - new) / 10.0) - 1.0) * 100.0
    if metric == "ssim":
        eb, en = 1.0 - base, 1.0 - new
    else:
        eb, en = base, new
    if eb <= 0:
        return 0.0 if en <= 0 else math.inf
    return (en / eb - 1.0) * 100.0


def _key(run: Run, c: Cell) -> tuple:
    return (c.scene, c.technique, tuple(sorted((k, format_param(v)) for k, v in c.params.items())))


def match_cells(base: Run, new: Run) -> List[Tuple[Optional[Cell], Optional[Cell]]]:
    """Pairs cells by id, then by (scene, technique, params) for ids that changed."""
    pairs, used = [], set()
    new_by_key = {_key(new, c): c for c in new.cells}
    for b in base.cells:
        n = new.cell(b.id)
        if n is None:
            n = new_by_key.get(_key(base, b))
        if n is not None and n.id in used:
            n = None
        if n is not None:
            used.add(n.id)
        pairs.append((b, n))
    pairs += [(None, n) for n in new.cells if n.id not in used]
    return pairs


def compare(base: Run, new: Run, threshold: float = DEFAULTS["threshold"], alpha: float = DEFAULTS["alpha"],
            noise_k: float = DEFAULTS["noise_k"], metric_tol: float = DEFAULTS["metric_tol"],
            min_ms: float = DEFAULTS["min_ms"], clock: str = "auto") -> Comparison:
    passes, metrics, statuses = [], [], []
    for b, n in match_cells(base, new):
        c = b or n
        label = f"{c.scene} / {(base if b else new).label(c)}"
        if b is None or n is None:
            statuses.append(StatusRow(c.id, label, b.status if b else "-", n.status if n else "-",
                                      "new" if b is None else "missing"))
            continue
        if b.ok and not n.ok:
            verdict = "regression"
        elif not b.ok and n.ok:
            verdict = "fixed"
        elif not n.ok:
            verdict = "still failing"  # not a new regression, but never silently passed over
        else:
            verdict = "same"
        statuses.append(StatusRow(n.id, label, b.status, n.status, verdict))
        # Passes: frame first, then in the new run's order.
        names = list(dict.fromkeys(["frame"] + b.pass_names() + n.pass_names()))
        for name in names:
            _, sb = b.pass_samples(name, clock)
            _, sn = n.pass_samples(name, clock)
            if len(sb) == 0 and len(sn) == 0:
                continue
            mb, mn, ch, p, noise, limit, v = compare_samples(sb, sn, threshold, alpha, noise_k, min_ms)
            passes.append(PassRow(n.id, label, name, len(sb), len(sn), mb, mn, ch, p, noise, limit, v))
        # Metrics per path class; a failed new cell's metrics are covered by its status.
        for cls in dict.fromkeys(b.metric_classes() + n.metric_classes()):
            for m in COMPARED_METRICS:
                vb, vn = b.metric_mean(m, cls), n.metric_mean(m, cls)
                if not (math.isfinite(vb) or math.isfinite(vn)):
                    continue
                ec = error_change(m, vb, vn)
                if not math.isfinite(ec) and ec != math.inf:
                    mv = "n/a"
                elif ec > metric_tol:
                    mv = "worse"
                elif ec < -metric_tol:
                    mv = "better"
                else:
                    mv = "same"
                metrics.append(MetricRow(n.id, label, cls, m, vb, vn, ec, mv))
    settings = {"threshold_pct": threshold, "alpha": alpha, "noise_k": noise_k, "metric_tol_pct": metric_tol,
                "min_ms": min_ms, "clock": clock}
    return Comparison(base, new, passes, metrics, statuses, settings)


# ---- output ----------------------------------------------------------------------------------------
def _ms(v: float) -> str:
    return "" if not math.isfinite(v) else (f"{v:.3f}" if v < 10 else f"{v:.2f}")


def _pct(v: float) -> str:
    return "" if not math.isfinite(v) else f"{v:+.1f}%"


def _p(v: float) -> str:
    return "" if not math.isfinite(v) else (f"{v:.1e}" if v < 0.001 else f"{v:.3f}")


def _metric(m: str, v: float) -> str:
    return "" if not math.isfinite(v) else (f"{v:.2f}" if m == "psnr" else f"{v:.4f}")


VERDICT_TEXT = {"slower": "**SLOWER**", "faster": "faster", "same": "", "n/a": "n/a",
                "worse": "**WORSE**", "better": "better", "regression": "**NOW FAILS**", "fixed": "now ok",
                "still failing": "failed in both runs",
                "new": "new cell", "missing": "missing"}


def _md_escape(text: str) -> str:
    return str(text).replace("|", "\\|")


def _pass_table(rows: List[PassRow]) -> List[str]:
    out = ["| cell | pass | frames | base ms | new ms | change | p | limit | |",
           "|---|---|--:|--:|--:|--:|--:|--:|---|"]
    for r in rows:
        out.append(f"| {_md_escape(r.label)} | `{_md_escape(r.pass_name)}` | {r.n_base}/{r.n_new} | "
                   f"{_ms(r.base_ms)} | {_ms(r.new_ms)} | {_pct(r.change_pct)} | {_p(r.p)} | "
                   f"±{r.limit_pct:.1f}% | {VERDICT_TEXT[r.verdict]} |")
    return out


def _metric_table(rows: List[MetricRow]) -> List[str]:
    out = ["| cell | class | metric | base | new | error change | |", "|---|---|---|--:|--:|--:|---|"]
    for r in rows:
        out.append(f"| {_md_escape(r.label)} | {_md_escape(r.path_class)} | {r.metric} | "
                   f"{_metric(r.metric, r.base)} | {_metric(r.metric, r.new)} | {_pct(r.error_change_pct)} | "
                   f"{VERDICT_TEXT[r.verdict]} |")
    return out


def testing_hooks(run: Run) -> List[str]:
    """The test-only `testing.*` overrides a run was made with (run.json "overrides"), e.g. the delay
    injection testing.slow_pass: such a run is a check of this tool, never a benchmark to trust."""
    hooks = [str(o) for o in run.info.get("overrides") or [] if str(o).startswith("testing.")]
    config = run.info.get("config")
    if not hooks and isinstance(config, str) and re.search(r"^testing\s*:", config, re.MULTILINE):
        hooks.append("testing: (set in the config file)")
    return hooks


def markdown(c: Comparison) -> str:
    s = c.settings
    slower = [r for r in c.passes if r.verdict == "slower"]
    faster = [r for r in c.passes if r.verdict == "faster"]
    worse = [r for r in c.metrics if r.verdict == "worse"]
    better = [r for r in c.metrics if r.verdict == "better"]
    broken = [r for r in c.statuses if r.verdict == "regression"]
    other_status = [r for r in c.statuses if r.verdict in ("fixed", "still failing", "new", "missing")]
    na = [r for r in c.passes if r.verdict == "n/a"]
    out = ["## photonbench compare", "",
           f"base `{c.base.name}` (commit {c.base.commit[:12]}, {c.base.device}) → "
           f"new `{c.new.name}` (commit {c.new.commit[:12]}, {c.new.device})", ""]
    if c.base.device != c.new.device:
        out += ["> **Different devices**: absolute times are not comparable across machines.", ""]
    for side, run in (("base", c.base), ("new", c.new)):
        hooks = testing_hooks(run)
        if hooks:
            out += [f"> **Testing hooks** in the {side} run (not a real benchmark): "
                    + ", ".join(f"`{h}`" for h in hooks), ""]
    verdict = "REGRESSION" if c.regressions else "no significant regression"
    out.append(f"**{verdict}**: {len(slower)} slower pass(es), {len(worse)} worse metric(s), "
               f"{len(broken)} newly failing cell(s); {len(faster)} faster, {len(better)} better; "
               f"{sum(r.verdict == 'same' for r in c.passes)} passes unchanged.")
    out += ["", f"Slower/faster: Mann–Whitney U p < {s['alpha']:g} on per-frame samples and |median change| "
                f"> limit = max({s['threshold_pct']:g}%, {s['noise_k']:g} × the runs' own per-frame noise) "
                f"and > {s['min_ms']:g} ms. Metrics: error (FLIP, 1−SSIM, MSE via PSNR, relMSE) changed by "
                f"more than {s['metric_tol_pct']:g}%.", ""]
    if broken:
        out += ["### Cells that now fail", "", "| cell | base | new |", "|---|---|---|"]
        out += [f"| {_md_escape(r.label)} | {r.base} | {r.new} |" for r in broken] + [""]
    if slower:
        out += ["### Slower", ""] + _pass_table(slower) + [""]
    if worse:
        out += ["### Worse images", ""] + _metric_table(worse) + [""]
    if faster or better:
        out += ["### Improvements", ""]
        if faster:
            out += _pass_table(faster) + [""]
        if better:
            out += _metric_table(better) + [""]
    if other_status:
        out += ["### Cells", "", "| cell | base | new | |", "|---|---|---|---|"]
        out += [f"| {_md_escape(r.label)} | {r.base} | {r.new} | {VERDICT_TEXT[r.verdict]} |"
                for r in other_status] + [""]
    if na:
        out += [f"_{len(na)} pass(es) not tested: fewer than {MIN_SAMPLES} frames on a side._", ""]
    out += ["<details><summary>All passes</summary>", ""] + _pass_table(c.passes) + ["", "</details>", ""]
    if c.metrics:
        out += ["<details><summary>All metrics</summary>", ""] + _metric_table(c.metrics) + ["", "</details>", ""]
    return "\n".join(out)


def to_json(c: Comparison) -> dict:
    def clean(d):
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}
    return {"base": c.base.path, "new": c.new.path, "settings": c.settings,
            "testing_hooks": {"base": testing_hooks(c.base), "new": testing_hooks(c.new)},
            "regressions": c.regressions,
            "improvements": c.improvements, "passes": [clean(asdict(r)) for r in c.passes],
            "metrics": [clean(asdict(r)) for r in c.metrics], "statuses": [asdict(r) for r in c.statuses]}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(
        prog="photonbench compare",
        description="Compare two runs cell by cell and pass by pass; print a markdown table; exit 1 on a "
                    "significant regression (slower pass, worse metric, or a cell that now fails).",
        epilog="A pass is slower when the Mann-Whitney U test on its per-frame times gives p < ALPHA and its "
               "median grew by more than max(THRESHOLD, NOISE_K x the runs' own relative per-frame noise).")
    ap.add_argument("base", metavar="BASE_RUN")
    ap.add_argument("new", metavar="NEW_RUN")
    ap.add_argument("--threshold", type=float, default=DEFAULTS["threshold"], metavar="PCT",
                    help="smallest median change that counts, in percent (default %(default)s)")
    ap.add_argument("--alpha", type=float, default=DEFAULTS["alpha"],
                    help="significance level of the U test (default %(default)s)")
    ap.add_argument("--noise-k", type=float, default=DEFAULTS["noise_k"],
                    help="multiple of the per-frame noise a change must exceed (default %(default)s)")
    ap.add_argument("--metric-tol", type=float, default=DEFAULTS["metric_tol"], metavar="PCT",
                    help="relative change of an error metric that counts, in percent (default %(default)s)")
    ap.add_argument("--min-ms", type=float, default=DEFAULTS["min_ms"],
                    help="smallest absolute median change that counts, ms (default %(default)s)")
    ap.add_argument("--clock", choices=["auto", "gpu", "cpu"], default="auto",
                    help="gpu_ms, cpu_ms, or gpu where present else cpu (default)")
    ap.add_argument("--out", metavar="FILE", help="also write the markdown to FILE")
    ap.add_argument("--json", metavar="FILE", help="write every row as JSON to FILE")
    a = ap.parse_args(argv)
    try:
        result = compare(Run(a.base), Run(a.new), a.threshold, a.alpha, a.noise_k, a.metric_tol, a.min_ms,
                         a.clock)
    except RunError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    text = markdown(result)
    print(text)
    if a.out:
        with open(a.out, "w", encoding="utf-8") as f:
            f.write(text + "\n")
    if a.json:
        with open(a.json, "w", encoding="utf-8") as f:
            json.dump(to_json(result), f, indent=2)
    return 1 if result.regressions else 0
