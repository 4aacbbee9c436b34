"""photonbench compare BASE NEW: did the change make any pass slower, or any image worse?

BASE and NEW are each a run directory, or a folder of run directories: replicate runs of one build and
config (e.g. results/new/1 ... results/new/8), interleaved in time with the other side's. Replicates
make the verdict trustworthy on a shared machine (see "noise" below); 8 a side are what was measured.

Timing, per cell and per pass (frames.csv; every measured frame of every replicate is one sample):
  * clock       = on fenced runs (lavapipe: cell.json "timing": "fenced") with a process_cpu_ms column,
                  the CPU time the cell's process spent in the pass (all threads, lavapipe's workers
                  included), else the harness's rule (the larger of gpu_ms and cpu_ms). On lavapipe the
                  "GPU" is the CPU: a pass's wall time there includes waiting for a core while other jobs
                  run, its CPU time is the work it did. --clock picks one for every cell.
  * level       = the mean of the FLOOR_SAMPLES (3) fastest frames of all the side's replicates. Other
                  processes only ever add time to a frame (preemption, cold caches after another job ran,
                  page faults), so the low end of the samples is the cost of the pass itself and the
                  median is a mix of that and the machine's load (Chen & Revels, "Robust benchmarking in
                  noisy environments", 2016, argue the same for the minimum). Three rather than one, so
                  one oddly fast frame does not decide. The medians are reported beside it.
  * change      = level(new) / level(base) - 1.
  * test        = two-sided Mann-Whitney U on the two sides' per-frame samples: a gate that the frames
                  differ at all (p < alpha). Frames of one run share its conditions, so p is overconfident
                  about runs; it never decides alone: the limit below carries the run-to-run noise.
  * noise       = with >= 2 replicates on a side, the run-to-run noise of its level: the median of its
                  runs' floors (each run's own 3 fastest frames) over its best run's, minus 1. Other
                  jobs' load comes in states lasting seconds, so whole runs are fast or slow and the
                  frames of one run cannot show it; the level is in effect the best run's, and how far
                  the typical run lies above it is the scale of the best run's luck, which grows with
                  the number of runs as the level falls. Measured on the runs being compared, so a
                  side measured while the machine was erratic gets a wider limit rather than a false
                  alarm. Rules tried on the same measured pairs (tools/aa_check.sh, threshold 15%,
                  noise_k 1; A/A clean, slowed flagged): with 8 runs a side (10 pairs) this one 10/10,
                  10/10, the standard error sqrt(2/k) x s.d. of log run floors 7/10, 10/10 (it shrinks
                  with k while the best run's luck grows); with 5 runs a side (40 pairs) 39/40, 36/40
                  against 37/40, 39/40. With one run on a side there is no run-to-run information:
                  its per-frame noise is used instead (1.4826 x MAD of successive differences /
                  sqrt(2), relative to the median; successive differences remove the animation's slow
                  change of cost) and the markdown says the verdict does not account for run-to-run
                  drift.
  * verdict     = slower when p < alpha AND change > limit = max(threshold, noise_k x the larger noise of
                  the two sides) AND the levels differ by more than --min-ms; faster symmetrically.
  * threshold   = 15% by default (noise_k 1): the smallest change worth a red CI on a shared 2-core
                  machine, where A/A level changes beyond 10% are common even with 5 runs a side (the
                  larger ones on sides whose runs disagreed); with 10%, one A/A pair in ten flagged.
  The false-alarm and detection rates of this rule on real runs of a loaded machine are measured by
  tools/aa_check.sh (A/A pairs and a pass slowed by the testing.slow_pass hook); see tools/README.md.
  Not a significance test at the run level: with k runs a side, a rank test over runs cannot reach
  p < 0.01 below k = 5 (and needs every run of one side above every run of the other); the rule's error
  rates are measured instead.
Metrics, per cell and path class (means over the metric frames of metrics.csv, first replicate): error
quantities are compared relatively: FLIP and relMSE directly, SSIM through 1-SSIM, PSNR through the MSE
it stands for (a drop of d dB is an MSE ratio of 10^(d/10)); worse beyond --metric-tol percent is a
regression. A cell that was ok and now fails (in any replicate) is a regression. Exit 1 on any
regression, else 0 (2: bad input).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import sys
from dataclasses import asdict, dataclass
from typing import Dict, List, Optional, Tuple

import numpy as np

from . import measures
from .rundata import CLOCK_COLUMNS, Cell, Run, RunError, format_param

DEFAULTS = {"threshold": 15.0, "alpha": 0.01, "noise_k": 1.0, "metric_tol": 2.0, "min_ms": 0.02}
COMPARED_METRICS = ("flip", "ssim", "psnr", "relmse")
MIN_SAMPLES = 5  # with fewer frames per side a two-sided U test cannot reach p < 0.01
FLOOR_SAMPLES = 3  # a side's level: the mean of its this many fastest frames
PROCESS_COLUMN = CLOCK_COLUMNS["process"]  # frames.csv: CPU time of the cell's process in the pass
CLOCKS = ("auto", "gpu", "cpu", "process")


@dataclass
class PassRow:
    cell: str
    label: str
    pass_name: str
    n_base: int  # frames, all replicates together
    n_new: int
    base_ms: float  # level: mean of the FLOOR_SAMPLES fastest frames
    new_ms: float
    change_pct: float
    p: float
    noise_pct: float  # noise_k x the larger noise of the two sides (the noise part of the limit)
    limit_pct: float
    verdict: str  # "slower", "faster", "same", "n/a"
    clock: str = ""  # "process", "gpu", "cpu" or "auto" (the harness's rule): what the samples are
    runs_base: int = 1
    runs_new: int = 1
    base_median_ms: float = math.nan
    new_median_ms: float = math.nan
    noise_source: str = ""  # "runs" (replicates' spread) or "frames" (one run on a side)


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


class RunSet:
    """One side of a comparison: a run directory, or a folder whose sub-folders are replicate runs of
    one build and config. Cells, labels, metrics and run.json facts come from the first replicate; pass
    samples from all of them."""

    def __init__(self, path: str):
        if os.path.isfile(os.path.join(path, "summary.csv")) or not os.path.isdir(path):
            self.runs = [Run(path)]  # Run reports a missing or malformed directory
        else:
            subs = sorted(d for d in os.listdir(path) if os.path.isfile(os.path.join(path, d, "summary.csv")))
            if not subs:
                raise RunError(f"{path}: neither a run directory (no summary.csv) nor a folder of runs")
            self.runs = [Run(os.path.join(path, d)) for d in subs]
        configs = {r.info.get("config_hash") for r in self.runs}
        if len(configs) > 1:
            raise RunError(f"{path}: its runs were made from different configs ({len(configs)} config "
                           f"hashes); replicates must share one")
        first = self.runs[0]
        self.path = os.path.abspath(path)
        self.info, self.cells = first.info, first.cells
        self.commit, self.device = first.commit, first.device
        commits = {r.commit for r in self.runs}
        self.mixed_commits = len(commits) > 1

    @property
    def name(self) -> str:
        base = os.path.basename(self.path.rstrip(os.sep))
        return base if len(self.runs) == 1 else f"{base} ({len(self.runs)} runs)"

    def cell(self, cell_id: str) -> Optional[Cell]:
        return self.runs[0].cell(cell_id)

    def label(self, cell: Cell) -> str:
        return self.runs[0].label(cell)

    def replicates(self, cell: Cell) -> List[Tuple[Cell, dict]]:
        """(the cell, its run's run.json) in every replicate that has it (matched by id), first
        replicate first; `cell` is the first replicate's."""
        out = [(cell, self.runs[0].info)]
        for r in self.runs[1:]:
            c = r.cell(cell.id)
            if c is not None:
                out.append((c, r.info))
        return out


@dataclass
class Comparison:
    base: RunSet
    new: RunSet
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
    """Robust per-sample standard deviation of one run's frames: 1.4826 x MAD of successive
    differences / sqrt 2 (measures.successive_difference_sigma), so the animation's slow change of
    cost is not noise."""
    return measures.successive_difference_sigma(samples)


def floor_level(samples: np.ndarray) -> float:
    """The mean of the FLOOR_SAMPLES smallest samples (all of them when there are fewer)."""
    if len(samples) == 0:
        return math.nan
    return float(np.mean(np.sort(samples)[:FLOOR_SAMPLES]))


def run_noise(runs: List[np.ndarray]) -> float:
    """Run-to-run noise of a side's level, relative: the median of its replicates' floors (each run's
    own FLOOR_SAMPLES fastest frames) over the best one's, minus 1. The level is in effect the best
    run's; interference comes in states lasting seconds, so whole runs are fast or slow, and the more
    runs a side has the luckier its best one gets. How far the typical run lies above the best one is
    the scale of that luck: small when most runs reach the level, large when one run caught a quiet
    window that the other side may have missed. NaN with fewer than two replicates."""
    floors = [f for f in (floor_level(r) for r in runs if len(r)) if f > 0]
    if len(floors) < 2:
        return math.nan
    return float(np.median(floors) / min(floors) - 1.0)


def mann_whitney_p(a: np.ndarray, b: np.ndarray) -> float:
    from scipy.stats import mannwhitneyu
    if len(a) < MIN_SAMPLES or len(b) < MIN_SAMPLES:
        return math.nan
    if np.all(a == a[0]) and np.all(b == a[0]):
        return 1.0  # identical constant samples: scipy's normal approximation would divide by zero
    return float(mannwhitneyu(b, a, alternative="two-sided").pvalue)


def _as_runs(x) -> List[np.ndarray]:
    """A side's samples as one array per replicate (a bare array is one run)."""
    if isinstance(x, np.ndarray):
        return [x]
    return [np.asarray(r, dtype=float) for r in x]


def compare_samples(base, new, threshold: float, alpha: float, noise_k: float,
                    min_ms: float) -> Tuple[float, float, float, float, float, float, str]:
    """(base level, new level, change %, p, noise %, limit %, verdict) for one pass. `base` and `new` are
    each one array of per-frame samples (one run) or a list of them (replicate runs)."""
    return compare_detail(base, new, threshold, alpha, noise_k, min_ms)[:7]


def compare_detail(base, new, threshold, alpha, noise_k, min_ms):
    """compare_samples plus (base median, new median, noise source)."""
    base_runs, new_runs = _as_runs(base), _as_runs(new)
    b, n = np.concatenate(base_runs), np.concatenate(new_runs)
    if len(b) == 0 or len(n) == 0:
        return (math.nan,) * 6 + ("n/a", math.nan, math.nan, "")
    lb, ln = floor_level(b), floor_level(n)
    change = (ln / lb - 1.0) * 100.0 if lb > 0 else math.nan
    p = mann_whitney_p(b, n)
    side_noise, sources = [], set()
    for runs, pooled in ((base_runs, b), (new_runs, n)):
        rn = run_noise(runs)
        if math.isfinite(rn):
            side_noise.append(rn)
            sources.add("runs")
        else:  # one run: only its per-frame noise is known (see the module docstring)
            med = float(np.median(pooled))
            fn = robust_noise(pooled) / med if med > 0 else math.nan
            if math.isfinite(fn):
                side_noise.append(fn)
                sources.add("frames")
    noise = noise_k * max(side_noise) * 100.0 if side_noise else 0.0
    limit = max(threshold, noise)
    if not math.isfinite(p) or not math.isfinite(change):
        verdict = "n/a"
    elif p < alpha and abs(ln - lb) > min_ms and change > limit:
        verdict = "slower"
    elif p < alpha and abs(ln - lb) > min_ms and change < -limit:
        verdict = "faster"
    else:
        verdict = "same"
    source = "frames" if "frames" in sources else ("runs" if sources else "")
    return lb, ln, change, p, noise, limit, verdict, float(np.median(b)), float(np.median(n)), source


def error_change(metric: str, base: float, new: float) -> float:
    """Relative change (%) of the error quantity behind a metric, positive worse (measures.py)."""
    return measures.error_change(metric, base, new)


def _key(c: Cell) -> tuple:
    return (c.scene, c.technique, tuple(sorted((k, format_param(v)) for k, v in c.params.items())))


def match_cells(base, new) -> List[Tuple[Optional[Cell], Optional[Cell]]]:
    """Pairs cells by id, then by (scene, technique, params) for ids that changed."""
    pairs, used = [], set()
    new_by_key = {_key(c): c for c in new.cells}
    for b in base.cells:
        n = new.cell(b.id)
        if n is None:
            n = new_by_key.get(_key(b))
        if n is not None and n.id in used:
            n = None
        if n is not None:
            used.add(n.id)
        pairs.append((b, n))
    pairs += [(None, n) for n in new.cells if n.id not in used]
    return pairs


def is_fenced(cell: Cell, run_info: dict) -> bool:
    """Whether the cell's passes were timed with fences (cell.json "timing", else run.json's)."""
    timing = cell.json.get("timing") or run_info.get("timing") or ""
    return str(timing).startswith("fenced")


def has_process_clock(cell: Cell) -> bool:
    return len(cell.frames) > 0 and PROCESS_COLUMN in cell.frames.columns


def resolve_clock(requested: str, cells: List[Tuple[Cell, dict]]) -> str:
    """The clock one cell pair is compared on. "auto": process CPU time when every replicate of both
    sides was fenced and recorded it, else the harness's own rule ("auto" in Cell.pass_samples)."""
    if requested != "auto":
        return requested
    if cells and all(is_fenced(c, info) and has_process_clock(c) for c, info in cells):
        return "process"
    return "auto"


def pass_samples(cell: Cell, name: str, clock: str) -> np.ndarray:
    """One pass's per-frame samples (ms, frame order) on a clock ("process": process_cpu_ms)."""
    return cell.pass_samples(name, clock)[1]


def compare(base, new, threshold: float = DEFAULTS["threshold"], alpha: float = DEFAULTS["alpha"],
            noise_k: float = DEFAULTS["noise_k"], metric_tol: float = DEFAULTS["metric_tol"],
            min_ms: float = DEFAULTS["min_ms"], clock: str = "auto") -> Comparison:
    """base and new: RunSet (or Run, wrapped as a one-run set)."""
    base = base if isinstance(base, RunSet) else _single(base)
    new = new if isinstance(new, RunSet) else _single(new)
    passes, metrics, statuses = [], [], []
    for b, n in match_cells(base, new):
        c = b or n
        label = f"{c.scene} / {(base if b else new).label(c)}"
        if b is None or n is None:
            statuses.append(StatusRow(c.id, label, b.status if b else "-", n.status if n else "-",
                                      "new" if b is None else "missing"))
            continue
        b_reps, n_reps = base.replicates(b), new.replicates(n)
        b_bad = [x for x, _ in b_reps if not x.ok]
        n_bad = [x for x, _ in n_reps if not x.ok]
        if not b_bad and n_bad:
            verdict = "regression"
        elif b_bad and not n_bad:
            verdict = "fixed"
        elif n_bad:
            verdict = "still failing"  # not a new regression, but never silently passed over
        else:
            verdict = "same"
        # A replicate that failed is shown by its status (the first failing one's).
        statuses.append(StatusRow(n.id, label, (b_bad or [b])[0].status, (n_bad or [n])[0].status, verdict))
        used_clock = resolve_clock(clock, b_reps + n_reps)
        # Passes: frame first, then in the new run's order.
        names = list(dict.fromkeys(["frame"] + b.pass_names() + n.pass_names()))
        for name in names:
            sb = [pass_samples(x, name, used_clock) for x, _ in b_reps]
            sn = [pass_samples(x, name, used_clock) for x, _ in n_reps]
            if sum(map(len, sb)) == 0 and sum(map(len, sn)) == 0:
                continue
            mb, mn, ch, p, noise, limit, v, medb, medn, src = compare_detail(sb, sn, threshold, alpha,
                                                                            noise_k, min_ms)
            passes.append(PassRow(n.id, label, name, sum(map(len, sb)), sum(map(len, sn)), mb, mn, ch, p,
                                  noise, limit, v, used_clock, len(sb), len(sn), medb, medn, src))
        # Metrics per path class (first replicates; rendering is deterministic); a failed new cell's
        # metrics are covered by its status.
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
                "min_ms": min_ms, "clock": clock, "floor_samples": FLOOR_SAMPLES,
                "runs_base": len(base.runs), "runs_new": len(new.runs)}
    return Comparison(base, new, passes, metrics, statuses, settings)


def _single(run: Run) -> RunSet:
    s = RunSet.__new__(RunSet)
    s.runs = [run]
    s.path, s.info, s.cells, s.commit, s.device = run.path, run.info, run.cells, run.commit, run.device
    s.mixed_commits = False
    return s


# ---- output ----------------------------------------------------------------------------------------
def _ms(v: float) -> str:
    return "" if not math.isfinite(v) else (f"{v:.3f}" if v < 10 else f"{v:.2f}")


def _pct(v: float) -> str:
    return "" if not math.isfinite(v) else f"{v:+.1f}%"


def _p(v: float) -> str:
    return "" if not math.isfinite(v) else (f"{v:.1e}" if v < 0.001 else f"{v:.3f}")


def _metric(m: str, v: float) -> str:
    return "" if not math.isfinite(v) else (f"{v:.2f}" if m == "psnr" else f"{v:.4f}")


CLOCK_TEXT = {"process": "process CPU time (fenced passes)", "gpu": "gpu_ms", "cpu": "cpu_ms",
              "auto": "the larger of gpu_ms and cpu_ms"}
VERDICT_TEXT = {"slower": "**SLOWER**", "faster": "faster", "same": "", "n/a": "n/a",
                "worse": "**WORSE**", "better": "better", "regression": "**NOW FAILS**", "fixed": "now ok",
                "still failing": "failed in both runs",
                "new": "new cell", "missing": "missing"}


def _md_escape(text: str) -> str:
    return str(text).replace("|", "\\|")


CLOCK_SHORT = {"process": "process CPU", "gpu": "GPU", "cpu": "CPU", "auto": "max(GPU, CPU)"}


def _pass_table(rows: List[PassRow], floor_samples: int) -> List[str]:
    """Each row's level on its clock: the mean of the FLOOR_SAMPLES fastest frames (a floor, not the
    wall-clock median of `run` and summary.csv)."""
    out = [f"| cell | pass | clock | frames | base ms (mean of {floor_samples} fastest) | "
           f"new ms (mean of {floor_samples} fastest) | change | p | limit | |",
           "|---|---|---|--:|--:|--:|--:|--:|--:|---|"]
    for r in rows:
        out.append(f"| {_md_escape(r.label)} | `{_md_escape(r.pass_name)}` | "
                   f"{CLOCK_SHORT.get(r.clock, r.clock)} | {r.n_base}/{r.n_new} | "
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


def testing_hooks(run) -> List[str]:
    """The test-only `testing.*` overrides a run (or any replicate of a RunSet) was made with (run.json
    "overrides"), e.g. the delay injection testing.slow_pass: such a run is a check of this tool, never
    a benchmark to trust."""
    hooks = []
    for r in getattr(run, "runs", [run]):
        own = [str(o) for o in r.info.get("overrides") or [] if str(o).startswith("testing.")]
        config = r.info.get("config")
        if not own and isinstance(config, str) and re.search(r"^testing\s*:", config, re.MULTILINE):
            own.append("testing: (set in the config file)")
        hooks += own
    return list(dict.fromkeys(hooks))


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
    clocks = sorted({r.clock for r in c.passes})
    clock_text = ", ".join(CLOCK_TEXT.get(k, k) for k in clocks) or "-"
    out += ["", f"Times: {clock_text}; each side's level is the mean of its {s['floor_samples']} fastest frames "
                f"over {s['runs_base']} base / {s['runs_new']} new run(s) (medians in the JSON). "
                f"Slower/faster: Mann–Whitney U p < {s['alpha']:g} on per-frame samples and |level change| "
                f"> limit = max({s['threshold_pct']:g}%, {s['noise_k']:g} × the sides' run-to-run noise) "
                f"and > {s['min_ms']:g} ms. Metrics: error (FLIP, 1−SSIM, MSE via PSNR, relMSE) changed by "
                f"more than {s['metric_tol_pct']:g}%.", ""]
    if any(r.noise_source == "frames" for r in c.passes):
        out += ["> **One run on a side**: its noise is only the per-frame noise within that run, which "
                "misses run-to-run drift; on a shared machine give each side several runs (a folder of "
                "runs) for a verdict to trust.", ""]
    for side, rs in (("base", c.base), ("new", c.new)):
        if rs.mixed_commits:
            out += [f"> The {side} runs recorded more than one commit (run.json git_commit): check that "
                    "they are replicates of one build.", ""]
    if broken:
        out += ["### Cells that now fail", "", "| cell | base | new |", "|---|---|---|"]
        out += [f"| {_md_escape(r.label)} | {r.base} | {r.new} |" for r in broken] + [""]
    if slower:
        out += ["### Slower", ""] + _pass_table(slower, s["floor_samples"]) + [""]
    if worse:
        out += ["### Worse images", ""] + _metric_table(worse) + [""]
    if faster or better:
        out += ["### Improvements", ""]
        if faster:
            out += _pass_table(faster, s["floor_samples"]) + [""]
        if better:
            out += _metric_table(better) + [""]
    if other_status:
        out += ["### Cells", "", "| cell | base | new | |", "|---|---|---|---|"]
        out += [f"| {_md_escape(r.label)} | {r.base} | {r.new} | {VERDICT_TEXT[r.verdict]} |"
                for r in other_status] + [""]
    if na:
        out += [f"_{len(na)} pass(es) not tested: fewer than {MIN_SAMPLES} frames on a side._", ""]
    out += (["<details><summary>All passes</summary>", ""] + _pass_table(c.passes, s["floor_samples"])
            + ["", "</details>", ""])
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
        description="Compare two runs (or two folders of replicate runs) cell by cell and pass by pass; "
                    "print a markdown table; exit 1 on a significant regression (slower pass, worse "
                    "metric, or a cell that now fails).",
        epilog="A pass is slower when the Mann-Whitney U test on its per-frame times gives p < ALPHA and its "
               "level (mean of the 3 fastest frames of a side's runs) grew by more than max(THRESHOLD, "
               "NOISE_K x the sides' run-to-run noise; with one run on a side, its per-frame noise). "
               "Rationale: tools/pbtools/compare.py's docstring.")
    ap.add_argument("base", metavar="BASE_RUN", help="a run directory, or a folder of replicate runs")
    ap.add_argument("new", metavar="NEW_RUN", help="a run directory, or a folder of replicate runs")
    ap.add_argument("--threshold", type=float, default=DEFAULTS["threshold"], metavar="PCT",
                    help="smallest median change that counts, in percent (default %(default)s)")
    ap.add_argument("--alpha", type=float, default=DEFAULTS["alpha"],
                    help="significance level of the U test (default %(default)s)")
    ap.add_argument("--noise-k", type=float, default=DEFAULTS["noise_k"],
                    help="multiple of the run-to-run noise a change must exceed (default %(default)s)")
    ap.add_argument("--metric-tol", type=float, default=DEFAULTS["metric_tol"], metavar="PCT",
                    help="relative change of an error metric that counts, in percent (default %(default)s)")
    ap.add_argument("--min-ms", type=float, default=DEFAULTS["min_ms"],
                    help="smallest absolute median change that counts, ms (default %(default)s)")
    ap.add_argument("--clock", choices=CLOCKS, default="auto",
                    help="gpu_ms, cpu_ms, process_cpu_ms, or auto (default): process CPU time where every "
                         "run of a cell was fenced (lavapipe) and recorded it, else the larger of gpu_ms "
                         "and cpu_ms")
    ap.add_argument("--out", metavar="FILE", help="also write the markdown to FILE")
    ap.add_argument("--json", metavar="FILE", help="write every row as JSON to FILE")
    a = ap.parse_args(argv)
    try:
        result = compare(RunSet(a.base), RunSet(a.new), a.threshold, a.alpha, a.noise_k, a.metric_tol, a.min_ms,
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
