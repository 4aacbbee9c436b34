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
                  its per-frame noise (1.4826 x MAD of successive differences / sqrt(2), relative to
                  the median) stands in for it, and the single-run rule below applies.
  * verdict     = slower when p < alpha AND change > limit = max(threshold, noise_k x the larger noise of
                  the two sides) AND the levels differ by more than --min-ms; faster symmetrically.
  * one run on a side (`run` twice, then `compare`): the U test on frames is no evidence about runs (on
    single-run A/A pairs here it gave p < 0.01 for about half of all passes), and whole runs drift: a
    run made under load (load average 16 on 2 cores) had even its fastest frames up to 93% slower in a
    1.3 ms pass and 65-80% slower in 15-30 ms ones. So a timing verdict needs the change to exceed a
    factor of 2 (--single-run-limit 100%: slower beyond x2, faster below x0.5) AND 1 ms
    (--single-run-min-ms); a significant change beyond the threshold but within that limit is
    "inconclusive": listed, said so, exit 0. Measured with tools/aa_single.py (20 single runs of a
    2-technique 320x180 config, 20 frames, one build, on this shared 2-core machine, three batches):
    no false alarm in 29 disjoint A/A pairs nor in 1102 ordered A/A pairs; the first two batches
    chose the limit (a 60% limit flagged 15 of 342 ordered pairs of the second, all against the loaded
    run), the third (load average 15) was held out: 0 of 10 and 0 of 380, while a pass made x2.5
    slower by the testing.slow_pass hook was flagged in 10 of 10 single-run pairs.
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
from dataclasses import asdict, dataclass, field
from typing import Dict, List, Optional, Tuple

import numpy as np

from . import environment, measures
from .rundata import CLOCK_COLUMNS, Cell, Run, RunError, format_param

# single_run_limit, single_run_min_ms: with one run on a side, the smallest level change (relative and
# absolute) that is flagged. Measured on single-run A/A pairs of this machine by tools/aa_single.py
# (the module docstring gives the figures).
DEFAULTS = {"threshold": 15.0, "alpha": 0.01, "noise_k": 1.0, "metric_tol": 2.0, "min_ms": 0.02,
            "single_run_limit": 100.0, "single_run_min_ms": 1.0}
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
    verdict: str  # "slower", "faster", "same", "n/a", "inconclusive" (one run a side: see the docstring)
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
    environment_changes: List[str] = field(default_factory=list)  # environment_warnings

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


def compare_samples(base, new, threshold: float, alpha: float, noise_k: float, min_ms: float,
                    single_run_limit: float = DEFAULTS["single_run_limit"],
                    single_run_min_ms: float = DEFAULTS["single_run_min_ms"]
                    ) -> Tuple[float, float, float, float, float, float, str]:
    """(base level, new level, change %, p, noise %, limit %, verdict) for one pass. `base` and `new` are
    each one array of per-frame samples (one run) or a list of them (replicate runs). The limit is the
    one that flags: with one run on a side, at least single_run_limit (and single_run_min_ms)."""
    return compare_detail(base, new, threshold, alpha, noise_k, min_ms, single_run_limit,
                          single_run_min_ms)[:7]


def compare_detail(base, new, threshold, alpha, noise_k, min_ms,
                   single_run_limit=DEFAULTS["single_run_limit"],
                   single_run_min_ms=DEFAULTS["single_run_min_ms"]):
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
    # One run on a side: nothing measures the run-to-run drift, which on a shared machine is larger than
    # any per-frame noise; only a change beyond the single-run limit (whose A/A false-alarm rate was
    # measured) is flagged, a significant one between the two limits is inconclusive.
    one_run = "frames" in sources
    flag_limit = max(limit, single_run_limit) if one_run else limit
    significant = math.isfinite(p) and p < alpha and abs(ln - lb) > min_ms
    if not math.isfinite(p) or not math.isfinite(change):
        verdict = "n/a"
    elif one_run and significant and abs(ln - lb) > single_run_min_ms and lb > 0 and ln > 0 and \
            abs(math.log(ln / lb)) > math.log1p(flag_limit / 100.0):
        # A factor both ways: 100% slower and "100% faster" (half the time) are the same distance.
        verdict = "slower" if change > 0 else "faster"
    elif not one_run and significant and abs(change) > flag_limit:
        verdict = "slower" if change > 0 else "faster"
    elif significant and abs(change) > limit:
        verdict = "inconclusive"
    else:
        verdict = "same"
    limit = flag_limit
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
            min_ms: float = DEFAULTS["min_ms"], clock: str = "auto",
            single_run_limit: float = DEFAULTS["single_run_limit"],
            single_run_min_ms: float = DEFAULTS["single_run_min_ms"]) -> Comparison:
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
                                                                            noise_k, min_ms, single_run_limit,
                                                                            single_run_min_ms)
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
                "single_run_limit_pct": single_run_limit, "single_run_min_ms": single_run_min_ms,
                "runs_base": len(base.runs), "runs_new": len(new.runs)}
    comparison = Comparison(base, new, passes, metrics, statuses, settings)
    comparison.environment_changes = environment_warnings(base, new)
    return comparison


def environment_warnings(base: RunSet, new: RunSet) -> List[str]:
    """Sentences naming what differs in the machine, driver or build type (pbtools/environment.py)
    between the two sides, or between the replicates of one side: times across them are not a
    comparison of the code alone."""
    out = []
    diffs = environment.differences(environment.of(base.info), environment.of(new.info))
    if diffs:
        out.append("base and new ran in different environments: " + environment.describe(diffs))
    for side, rs in (("base", base), ("new", new)):
        first = environment.of(rs.runs[0].info)
        for r in rs.runs[1:]:
            d = environment.differences(first, environment.of(r.info))
            if d:
                out.append(f"the {side} side's replicate {r.name} ran in another environment than its first: "
                           + environment.describe(d))
                break
    return out


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
                "inconclusive": "inconclusive (one run a side)",
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
    unsure = [r for r in c.passes if r.verdict == "inconclusive"]
    out = ["## photonbench compare", "",
           f"base `{c.base.name}` (commit {c.base.commit[:12]}, {c.base.device}) → "
           f"new `{c.new.name}` (commit {c.new.commit[:12]}, {c.new.device})", ""]
    if c.base.device != c.new.device:
        out += ["> **Different devices**: absolute times are not comparable across machines.", ""]
    for warning in c.environment_changes:
        out += [f"> **Warning**: {warning}; a time change may come from that, not from the code.", ""]
    for side, run in (("base", c.base), ("new", c.new)):
        hooks = testing_hooks(run)
        if hooks:
            out += [f"> **Testing hooks** in the {side} run (not a real benchmark): "
                    + ", ".join(f"`{h}`" for h in hooks), ""]
    verdict = "REGRESSION" if c.regressions else "no significant regression"
    out.append(f"**{verdict}**: {len(slower)} slower pass(es), {len(worse)} worse metric(s), "
               f"{len(broken)} newly failing cell(s); {len(faster)} faster, {len(better)} better; "
               f"{len(unsure)} inconclusive; {sum(r.verdict == 'same' for r in c.passes)} passes unchanged.")
    out += ["", test_statement(c), ""]
    if single_run(c):
        out += [f"> **One run on a side**: nothing measures the run-to-run drift, so a timing change is "
                f"flagged only beyond the single-run limit ({s['single_run_limit_pct']:g}% and "
                f"{s['single_run_min_ms']:g} ms); "
                f"{len(unsure)} significant change(s) between {s['threshold_pct']:g}% and that limit are "
                "**inconclusive** (exit 0). Give each side several runs (a folder of runs) for a verdict "
                "on smaller changes.", ""]
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
    if unsure:
        out += ["### Inconclusive (one run a side)", ""] + _pass_table(unsure, s["floor_samples"]) + [""]
    if na:
        out += [f"_{len(na)} pass(es) not tested: fewer than {MIN_SAMPLES} frames on a side._", ""]
    out += (["<details><summary>All passes</summary>", ""] + _pass_table(c.passes, s["floor_samples"])
            + ["", "</details>", ""])
    if c.metrics:
        out += ["<details><summary>All metrics</summary>", ""] + _metric_table(c.metrics) + ["", "</details>", ""]
    return "\n".join(out)


def single_run(c: Comparison) -> bool:
    """Whether a side has one run only (its timing verdicts use the single-run limit)."""
    return any(r.noise_source == "frames" for r in c.passes)


def test_statement(c: Comparison) -> str:
    """The test compare used, in one paragraph (markdown and the plain-text list both print it)."""
    s = c.settings
    clocks = sorted({r.clock for r in c.passes})
    clock_text = ", ".join(CLOCK_TEXT.get(k, k) for k in clocks) or "-"
    if single_run(c):
        factor = 1.0 + s["single_run_limit_pct"] / 100.0
        limit = (f"a factor {factor:g} (the single-run limit {s['single_run_limit_pct']:g}%) and "
                 f"{s['single_run_min_ms']:g} ms (one run on a side; a significant change above "
                 f"{s['threshold_pct']:g}% but within that limit is inconclusive)")
    else:
        limit = f"max({s['threshold_pct']:g}%, {s['noise_k']:g} x the sides' run-to-run noise)"
    return (f"Test: per pass, a two-sided Mann-Whitney U rank test on the per-frame samples "
            f"({clock_text}; {s['runs_base']} base / {s['runs_new']} new run(s)) must give p < {s['alpha']:g}, "
            f"AND the level (mean of the {s['floor_samples']} fastest frames) must change by more than "
            f"{limit} and by more than {s['min_ms']:g} ms. Metrics: an error (FLIP, 1-SSIM, MSE via PSNR, "
            f"relMSE) worse by more than {s['metric_tol_pct']:g}%. A cell that now fails is a regression.")


def text_list(c: Comparison) -> str:
    """A plain-text list for a CI log: one line per regression (then improvements and inconclusive
    changes), the test used, and the environment warnings."""
    s = c.settings
    out = [f"photonbench compare: {'REGRESSION' if c.regressions else 'no regression'} "
           f"({c.regressions} regression(s), {c.improvements} improvement(s)); base {c.base.path} -> new {c.new.path}"]
    out += [f"WARNING: {w}" for w in c.environment_changes]
    out.append(test_statement(c))

    def pass_line(tag, r):
        return (f"{tag} {r.label} pass {r.pass_name}: {_ms(r.base_ms)} -> {_ms(r.new_ms)} ms "
                f"({_pct(r.change_pct)}, limit {r.limit_pct:.1f}%, p {_p(r.p)}, "
                f"{CLOCK_SHORT.get(r.clock, r.clock)} mean of {s['floor_samples']} fastest)")
    for r in c.statuses:
        if r.verdict == "regression":
            out.append(f"REGRESSION failing {r.label}: {r.base} -> {r.new}")
    out += [pass_line("REGRESSION slower", r) for r in c.passes if r.verdict == "slower"]
    for r in c.metrics:
        if r.verdict == "worse":
            out.append(f"REGRESSION worse {r.label} {r.path_class} {r.metric}: {_metric(r.metric, r.base)} -> "
                       f"{_metric(r.metric, r.new)} (error {_pct(r.error_change_pct)}, tolerance "
                       f"{s['metric_tol_pct']:g}%)")
    out += [pass_line("improved faster", r) for r in c.passes if r.verdict == "faster"]
    out += [pass_line("inconclusive", r) for r in c.passes if r.verdict == "inconclusive"]
    if not c.regressions:
        out.append("no regressions")
    return "\n".join(out)


def to_json(c: Comparison) -> dict:
    def clean(d):
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in d.items()}
    return {"base": c.base.path, "new": c.new.path, "settings": c.settings,
            "testing_hooks": {"base": testing_hooks(c.base), "new": testing_hooks(c.new)},
            "test": test_statement(c), "environment_changes": c.environment_changes,
            "regressions": c.regressions,
            "improvements": c.improvements, "passes": [clean(asdict(r)) for r in c.passes],
            "metrics": [clean(asdict(r)) for r in c.metrics], "statuses": [asdict(r) for r in c.statuses]}


def parse_args(argv=None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(
        prog="photonbench compare",
        description="Compare two runs (or two folders of replicate runs) cell by cell and pass by pass; "
                    "print a markdown table and a plain-text list of regressions; exit 1 on a significant "
                    "regression (slower pass, worse metric, or a cell that now fails).",
        epilog="A pass is slower when the two-sided Mann-Whitney U test on its per-frame times gives "
               "p < ALPHA and its level (mean of the 3 fastest frames of a side's runs) grew by more than "
               "max(THRESHOLD, NOISE_K x the sides' run-to-run noise); with one run on a side, by more than "
               "SINGLE_RUN_LIMIT (smaller significant changes are inconclusive, exit 0). "
               "Rationale: tools/pbtools/compare.py's docstring.")
    ap.add_argument("base", metavar="BASE_RUN", help="a run directory, or a folder of replicate runs")
    ap.add_argument("new", metavar="NEW_RUN", help="a run directory, or a folder of replicate runs")
    ap.add_argument("--threshold", type=float, default=DEFAULTS["threshold"], metavar="PCT",
                    help="smallest level change that counts, in percent (default %(default)s)")
    ap.add_argument("--single-run-limit", type=float, default=DEFAULTS["single_run_limit"], metavar="PCT",
                    help="with one run on a side, the smallest level change flagged, in percent; its A/A "
                         "false-alarm rate is measured by tools/aa_single.py (default %(default)s)")
    ap.add_argument("--single-run-min-ms", type=float, default=DEFAULTS["single_run_min_ms"], metavar="MS",
                    help="with one run on a side, the smallest absolute level change flagged (default "
                         "%(default)s)")
    ap.add_argument("--alpha", type=float, default=DEFAULTS["alpha"],
                    help="significance level of the U test (default %(default)s)")
    ap.add_argument("--noise-k", type=float, default=DEFAULTS["noise_k"],
                    help="multiple of the run-to-run noise a change must exceed (default %(default)s)")
    ap.add_argument("--metric-tol", type=float, default=DEFAULTS["metric_tol"], metavar="PCT",
                    help="relative change of an error metric that counts, in percent (default %(default)s)")
    ap.add_argument("--min-ms", type=float, default=DEFAULTS["min_ms"],
                    help="smallest absolute level change that counts, ms (default %(default)s)")
    ap.add_argument("--clock", choices=CLOCKS, default="auto",
                    help="gpu_ms, cpu_ms, process_cpu_ms, or auto (default): process CPU time where every "
                         "run of a cell was fenced (lavapipe) and recorded it, else the larger of gpu_ms "
                         "and cpu_ms")
    ap.add_argument("--format", choices=("both", "markdown", "text"), default="both",
                    help="stdout: the markdown tables, the plain-text list of regressions for a CI log, or "
                         "both, markdown first (default %(default)s)")
    ap.add_argument("--out", metavar="FILE", help="also write the markdown to FILE")
    ap.add_argument("--json", metavar="FILE", help="write every row as JSON to FILE")
    return ap.parse_args(argv)


def settings_of(a: argparse.Namespace) -> dict:
    """compare()'s keyword arguments from parsed options."""
    return {"threshold": a.threshold, "alpha": a.alpha, "noise_k": a.noise_k, "metric_tol": a.metric_tol,
            "min_ms": a.min_ms, "clock": a.clock, "single_run_limit": a.single_run_limit,
            "single_run_min_ms": a.single_run_min_ms}


def main(argv=None) -> int:
    a = parse_args(argv)
    try:
        result = compare(RunSet(a.base), RunSet(a.new), **settings_of(a))
    except RunError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    text = markdown(result)
    if a.format in ("both", "markdown"):
        print(text)
    if a.format in ("both", "text"):
        if a.format == "both":
            print("\n---- plain text (for a CI log) ----")
        print(text_list(result))
    if a.out:
        with open(a.out, "w", encoding="utf-8") as f:
            f.write(text + "\n")
    if a.json:
        with open(a.json, "w", encoding="utf-8") as f:
            json.dump(to_json(result), f, indent=2)
    return 1 if result.regressions else 0
