"""Seed 003 (Fabianowski and Dingliana, "Interactive Global Photon Mapping", EGSR 2009) claims, measured
on a run of configs/paper003.yaml (digest shared/research/seed001-003.md, part A).

The paper's statements, each set beside what the run measured:
  * Table 1: the automatic leaf threshold T_auto reaches "an average of 98.80% of the best manually tuned
    speed" (98.79% for the linear build, the one built here): FPS_auto / FPS_max per scene, FPS from frame-
    time medians, FPS_max the fastest of the swept T (T_auto's own cell included, as the paper's 100%
    entries imply);
  * Table 2: photon differentials against k-nearest-neighbour photon mapping at matched k (k_PM set to
    the k_PD the photon-differentials cells measure, `hits_per_query`): 6.6x to 20.6x faster, with the
    kNN photon map built once for a static light (the paper's own timing); the rebuilt-every-frame kNN
    beside it, which does the same work per frame as photon differentials (trace, build, render), and the
    density estimation alone (knn's `gather` against photon differentials' `query`);
  * Table 3: the footprint-radius histogram (semi-axes after compression and smoothing, before the
    clamp) beside the paper's column for the scene the run's scene stands in for;
  * Fig. 5: per-stage times, photon tracing, BVH construction and rendering: "the rendering phase clearly
    dominates";
  * what the paper judged by eye: FLIP and SSIM of each technique against the path-traced references,
    each beside its noise floor (floors.py), the indirect class and the composed image.
Time ratios come from alternating rounds: the config runs every cell `seeds: K` times with `seed_order:
rounds` (round i runs seed index i of every cell, forward in even rounds and backward in odd ones), and
a ratio is the median over the rounds of the per-round ratio of frame-time medians, with its range. A
run whose seeds ran grouped, or without seeds, is reported with a warning: its ratios are one pass.
A cell's frame time is frames.csv's `frame` row, the wall time of the timed region (every pass the
technique runs in the frame, CPU and GPU, plus the harness's pass bookkeeping): the paper's FPS. Beside
each time ratio the same ratio of the frame's process CPU time (`process_cpu_ms`, all threads, lavapipe's
workers included): the work done, which other jobs on a shared machine do not inflate (compare.py's clock
on fenced runs); on a GPU the two differ by what runs in parallel.
"""

import math
import re
from collections import defaultdict
from typing import Callable, Dict, List, Optional, Sequence, Tuple

import numpy as np

from .. import floors, seeds, stats
from ..rundata import FULL_REFERENCE, WHOLE_FRAME_PASS, Cell, Run, format_param

TITLE = "Interactive Global Photon Mapping (Fabianowski and Dingliana, EGSR 2009; seed 003)"

PD, KNN, DIRECT = "photon-differentials", "knn", "direct"
THRESHOLD = "leaf_threshold"  # 0: T_auto
KNN_MODES = ("static", "every_frame")

# The paper's scene each of the run's scenes stands in for (configs/paper003.yaml says why).
STANDS_FOR = {"ring": "Ring", "wall": "Wall", "cornell-box": "Scene 6"}

# Table 1, linear BVH: column -> (T_auto, best T, FPS_auto / FPS_max in %); the mean of the seven
# fractions is the paper's 98.79%.
PAPER_TABLE1 = {"Sponza 292k": (5, 8, 100.0), "Scene 6 161k": (19, 8, 98.4), "Scene 6 321k": (56, 128, 99.1),
                "Conf. 98k": (7, 8, 100.0), "Conf. 391k": (22, 16, 99.4), "Sibenik 414k": (5, 8, 97.6),
                "Wall 70k": (42, 16, 97.0)}
PAPER_TABLE1_MEAN = 98.79
# Table 2: scene -> (emits, hits, s, k_PD, FPS_PD, k_PM, FPS_PM).
PAPER_TABLE2 = {"Sponza": (256e3, 299e3, 40, 175, 3.98, 155, 0.60),
                "Scene 6": (128e3, 164e3, 17.5, 344, 3.50, 319, 0.17),
                "Conf.": (128e3, 83e3, 22.5, 234, 4.50, 241, 0.55),
                "Sibenik": (512e3, 418e3, 60, 224, 3.43, 197, 0.46),
                "Wall": (128e3, 69e3, 15, 480, 4.22, 511, 0.25),
                "Ring": (128e3, 76e3, 10, 182, 6.22, 151, 0.52)}
PAPER_SPEEDUP_RANGE = (6.6, 20.6)
# Table 3 columns of the stand-ins: semi-axes per 0.05 m bin up to 1.00, then "> 1.00".
PAPER_TABLE3 = {
    "Scene 6": [0, 67, 1312, 4924, 22669, 141992, 115835, 29015, 11434, 4171, 1767, 1147, 838, 669, 558,
                464, 399, 348, 304, 266, 2406],
    "Wall": [0, 0, 5239, 113176, 42587, 4338, 800, 206, 70, 21, 12, 6, 2, 1, 1, 0, 0, 0, 0, 0, 0],
    "Ring": [2263, 2599, 77738, 91040, 6818, 820, 176, 45, 14, 7, 1, 1, 1, 0, 0, 0, 0, 0, 0, 0, 0],
}
BIN_WIDTH = 0.05
PD_BINS = [f"radius_{i * BIN_WIDTH:.2f}_{(i + 1) * BIN_WIDTH:.2f}".replace(".", "p") for i in range(20)] + \
    ["radius_above_1p00"]
KNN_BINS = [f"radius_bin_{i:02d}" for i in range(21)]
BIN_LABELS = [f"{i * BIN_WIDTH:.2f}–{(i + 1) * BIN_WIDTH:.2f}" for i in range(20)] + ["> 1.00"]

# Fig. 5's three stages: the top-level passes of each technique that belong to them. Anything else in
# the frame (the harness's scene-update and its bookkeeping) is "other".
STAGES = {
    PD: (("photon tracing", ("photon-trace", "photon-upload")),
         ("BVH build", ("postprocess", "build")),
         ("rendering", ("gbuffer", "direct-light", "query", "shade"))),
    KNN: (("photon tracing", ("photon-trace", "photon-upload")),
          ("grid build", ("build",)),
          ("rendering", ("gbuffer", "direct-light", "gather", "shade"))),
}
DENSITY_PASS = {PD: "query", KNN: "gather"}
BYTES_PER_QUERY = "bytes_read_per_query"  # both techniques' counter
K_MATCH_TOLERANCE = 0.15  # k_PM within 15% of k_PD counts as matched (the paper's: 0.86-1.06)
NOT_PASSES = (WHOLE_FRAME_PASS, "harness-overhead")
UNRESOLVED_MARK = "†"
WALL, CPU = "auto", "process"  # Cell.pass_times clocks: the pass's time as the harness takes it; CPU time


class MissingCells(Exception):
    pass


# -- reading ------------------------------------------------------------------------------------------

def frame_times(cell: Cell, clock: str = WALL) -> np.ndarray:
    return np.asarray(cell.pass_samples(WHOLE_FRAME_PASS, clock)[1], float)


def frame_median(cell: Cell, clock: str = WALL) -> float:
    t = frame_times(cell, clock)
    if len(t):
        return float(np.median(t))
    return cell.value("wall_ms_median") if clock == WALL else math.nan


def frame_cpu_median(cell: Cell) -> float:
    return frame_median(cell, CPU)


def pass_median(cell: Cell, names: Sequence[str], clock: str = WALL) -> float:
    """Median over the frames of the per-frame sum of the named top-level passes."""
    sums = cell.pass_sums(names, clock)
    return float(sums.median()) if len(sums) else math.nan


def top_level_passes(cell: Cell) -> List[str]:
    return [p for p in cell.pass_names() if "/" not in str(p) and p not in NOT_PASSES]


def counter_mean(cells: Sequence[Cell], name: str) -> float:
    """The counter's mean per frame over every frame of the cells."""
    values = [v for c in cells for v in c.counters.loc[c.counters["name"] == name, "value"].dropna()]
    return float(np.mean(values)) if values else math.nan


def seed_order(run: Run) -> str:
    text = str(run.info.get("config", ""))
    m = re.search(r"^seed_order:\s*([A-Za-z_]+)", text, re.M)
    order = m.group(1) if m else "grouped"
    for o in run.info.get("overrides") or []:
        if str(o).startswith("seed_order="):
            order = str(o).split("=", 1)[1].strip()
    return order


class Setting:
    """One setting of a technique on a scene: its cells, one per round (seed), in seed order."""

    def __init__(self, cells: List[Cell]):
        self.cells = cells
        self.first = cells[0]
        self.by_seed = {seeds.seed_of(c) if seeds.seed_of(c) is not None else i: c
                        for i, c in enumerate(cells) if c.ok}

    @property
    def ok(self) -> bool:
        return bool(self.by_seed)

    @property
    def ok_cells(self) -> List[Cell]:
        return list(self.by_seed.values())

    def param(self, name: str, default=None):
        return self.first.params.get(name, default)

    def frame_median(self, clock: str = WALL) -> float:
        """The median of every round's frames pooled."""
        t = np.concatenate([frame_times(c, clock) for c in self.ok_cells]) if self.ok else np.zeros(0)
        return float(np.median(t)) if len(t) else math.nan

    def fps(self, clock: str = WALL) -> float:
        ms = self.frame_median(clock)
        return 1000.0 / ms if ms > 0 else math.nan

    def stage_medians(self, stages: Sequence[Sequence[str]]) -> List[float]:
        """Per stage (a list of pass names), the median over every round's frames of the stage's
        per-frame time; then the median of each frame's rest (the frame less its stages)."""
        per_stage: List[List[float]] = [[] for _ in stages]
        rest: List[float] = []
        for c in self.ok_cells:
            frames = c.pass_samples(WHOLE_FRAME_PASS)
            series = [c.pass_sums(names, WALL) for names in stages]
            for f, total in zip(*frames):
                values = [float(x.get(f, 0.0)) for x in series]
                for i, v in enumerate(values):
                    per_stage[i].append(v)
                rest.append(total - sum(values))
        return [float(np.median(v)) if v else math.nan for v in per_stage + [rest]]

    def counter(self, name: str) -> float:
        return counter_mean(self.ok_cells, name)

    @property
    def caustics(self) -> bool:
        """The map holds pure caustic photons too: its image is more than the `indirect` class."""
        return str(self.param("caustics", "false")).lower() == "true"

    def own_class(self) -> str:
        """The class its fair score is of: combined when the map holds caustics, else indirect."""
        return "combined" if self.caustics else "indirect"

    def metric(self, metric: str, cls: str) -> Tuple[float, float]:
        """(mean over the rounds of each round's mean score, the same of its floor)."""
        v = [c.metric_mean(metric, cls, FULL_REFERENCE) for c in self.ok_cells]
        f = [c.metric_mean(metric + floors.FLOOR_SUFFIX, cls, FULL_REFERENCE) for c in self.ok_cells]
        v, f = [x for x in v if math.isfinite(x)], [x for x in f if math.isfinite(x)]
        return (float(np.mean(v)) if v else math.nan, float(np.mean(f)) if f else math.nan)


def round_ratios(num: Setting, den: Setting,
                 measure: Callable[[Cell], float] = frame_median) -> np.ndarray:
    """measure(num) / measure(den) in every round (seed) both completed."""
    out = []
    for s in sorted(set(num.by_seed) & set(den.by_seed)):
        a, b = measure(num.by_seed[s]), measure(den.by_seed[s])
        if math.isfinite(a) and math.isfinite(b) and b > 0:
            out.append(a / b)
    return np.asarray(out, float)


def ratio_text(r: np.ndarray, unit: str = "×", scale: float = 1.0, digits: int = 2) -> str:
    """"median [min–max]" over the rounds ("" range with one round)."""
    if not len(r):
        return "–"
    r = r * scale
    med = f"{np.median(r):.{digits}f}{unit}"
    return med if len(r) == 1 else f"{med} [{r.min():.{digits}f}–{r.max():.{digits}f}]"


def _f(v: Optional[float], digits: int = 2) -> str:
    return "–" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.{digits}f}"


def _n(v: float) -> str:
    return "–" if not math.isfinite(v) else f"{v:,.0f}"


def settings_of(run: Run) -> Dict[str, List[Setting]]:
    """scene -> its settings (every seed group of ok or failed cells), in the run's order."""
    out: Dict[str, List[Setting]] = defaultdict(list)
    for cells in seeds.groups(run).values():
        out[cells[0].scene].append(Setting(cells))
    return out


def is_technique(s: Setting, technique: str) -> bool:
    return s.first.technique == technique


def without(params: dict, name: str) -> Tuple:
    return tuple(sorted((k, format_param(v)) for k, v in params.items() if k != name))


def threshold_sweep(settings: List[Setting]) -> Dict[int, Setting]:
    """The photon-differentials settings that differ only in leaf_threshold, T -> setting (0: T_auto):
    the largest such family holding T_auto."""
    families: Dict[Tuple, Dict[int, Setting]] = defaultdict(dict)
    for s in settings:
        if is_technique(s, PD) and s.param(THRESHOLD) is not None:
            families[without(s.first.params, THRESHOLD)][int(s.param(THRESHOLD))] = s
    with_auto = [f for f in families.values() if 0 in f]
    return max(with_auto, key=len) if with_auto else {}


GRID_BASELINE = ("grid", "private")  # knn's defaults: the stronger baseline
PAPER_BASELINE = ("kdtree", "global")  # seed 003 §7's: a kd-tree searched from r_max, its heap in a buffer
BASELINE_NAMES = {GRID_BASELINE: "grid, private heap (knn's default)",
                  PAPER_BASELINE: "kd-tree, global heap (the paper's §7)"}


def baseline_of(s: Setting) -> Tuple[str, str]:
    """(search, heap) of a knn cell; cells written before those parameters existed are the grid's."""
    return (str(s.param("search", "grid") or "grid"), str(s.param("heap", "private") or "private"))


def baseline_name(baseline: Tuple[str, str]) -> str:
    return BASELINE_NAMES.get(baseline, f"{baseline[0]}, {baseline[1]} heap")


def knn_baselines(settings: List[Setting]) -> List[Tuple[str, str]]:
    """The (search, heap) pairs of the scene's knn cells: the grid's first, the paper's next, then others."""
    found = {baseline_of(s) for s in settings if is_technique(s, KNN)}
    rank = {GRID_BASELINE: 0, PAPER_BASELINE: 1}
    return sorted(found, key=lambda b: (rank.get(b, 2), b))


def knn_settings(settings: List[Setting], baseline: Tuple[str, str] = GRID_BASELINE) -> Dict[str, Setting]:
    """knn's cells of one baseline by `rebuild`; by default the uniform grid with a private heap (knn's
    defaults, the stronger baseline), which Table 3, Fig. 5 and the quality table use."""
    return {str(s.param("rebuild", "every_frame")): s for s in settings
            if is_technique(s, KNN) and baseline_of(s) == baseline}


def label(s: Setting) -> str:
    t = s.first.technique
    if t == PD:
        extra = ", caustics" if s.caustics else ""
        threshold = int(s.param(THRESHOLD, 0) or 0)
        return f"{PD} (T {'auto' if threshold == 0 else threshold}{extra})"
    if t == KNN:
        search, heap = baseline_of(s)
        extra = "" if (search, heap) == GRID_BASELINE else f", {search}, {heap} heap"
        return f"knn {s.param('rebuild', 'every_frame')} (k {format_param(s.param('k'))}{extra})"
    return t


# -- the claims ----------------------------------------------------------------------------------------

def claims(run: Run) -> str:
    by_scene = settings_of(run)
    sweeps = {scene: threshold_sweep(ss) for scene, ss in by_scene.items()}
    sweeps = {scene: sw for scene, sw in sweeps.items() if sw and sw[0].ok}
    if not sweeps:
        raise MissingCells(f"no completed {PD} cell with {THRESHOLD}: 0 (T_auto); run configs/paper003.yaml")
    scenes = [s for s in by_scene if s in sweeps]
    rounds = max(len(s.cells) for ss in by_scene.values() for s in ss)
    order = seed_order(run)
    out: List[str] = [f"# Seed 003 claims, measured: {run.name}", "",
                      f"{TITLE}. Device: {run.device}; commit {run.commit}.", ""]
    if rounds > 1 and order == "rounds":
        out += [f"Times: {rounds} alternating rounds (`seeds: {rounds}`, `seed_order: rounds`: forward, "
                "backward, ...). A ratio is the median over the rounds of the per-round ratio of frame-time "
                "medians, [min–max] over the rounds; an FPS is 1000 / the median of every round's frames.", ""]
    else:
        why = "the seeds ran grouped (`seed_order` is not `rounds`)" if rounds > 1 else "one round (no seeds)"
        out += [f"**Warning: not alternating rounds** ({why}): every ratio below compares cells measured at "
                "different times, so a change of the machine's load between them is in the ratio. Run the "
                "config as written (`seeds: K`, `seed_order: rounds`).", ""]
    out += frame_composition(by_scene)
    out += table1(scenes, sweeps)
    out += table2(scenes, sweeps, by_scene)
    out += table3(scenes, by_scene, sweeps)
    out += figure5(scenes, sweeps, by_scene)
    out += quality(scenes, by_scene, sweeps)
    return "\n".join(out) + "\n"


def frame_composition(by_scene: Dict[str, List[Setting]]) -> List[str]:
    out = ["## What each frame time holds", "",
           "The top-level passes of each technique's timed frame (frames.csv), besides the harness's "
           "scene-update; `knn static` traced and built its photon map once, in setup, outside every frame "
           "(its one-time cost is in the counters setup_trace_ms and setup_build_ms), as the paper's "
           "baseline did.", "", "| technique | passes in the frame | setup (once): trace / build ms |",
           "|---|---|---|"]
    rows: Dict[str, Tuple[List[str], List[str]]] = {}  # technique -> (passes, setup per scene)
    for scene, ss in by_scene.items():
        for s in ss:
            if not s.ok or s.first.technique == DIRECT:
                continue
            key = label(s).split(" (")[0] if s.first.technique == PD else f"knn {s.param('rebuild')}"
            passes, setups = rows.setdefault(
                key, ([p for p in top_level_passes(s.ok_cells[0]) if p != "scene-update"], []))
            if s.first.technique == KNN and s.param("rebuild") == "static":
                setups.append(f"{scene}: {_f(s.counter('setup_trace_ms'), 0)} / "
                              f"{_f(s.counter('setup_build_ms'), 0)}")
    for key, (passes, setups) in rows.items():
        out.append(f"| {key} | {', '.join(passes)} | {'; '.join(setups) or '–'} |")
    return out + [""]


def table1(scenes: List[str], sweeps: Dict[str, Dict[int, Setting]]) -> List[str]:
    thresholds = sorted({t for sw in sweeps.values() for t in sw if t > 0})
    out = ["## Table 1: leaf threshold T against T_auto (linear BVH)", "",
           "FPS = 1000 / the frame-time median (every round's frames). FPS_auto / FPS_max: per round, T_auto's "
           "FPS over the fastest cell of the sweep that round (T_auto's included), then the median over the "
           f"rounds [range]. Paper: {PAPER_TABLE1_MEAN}% on average over its seven columns (98.80% with the "
           "voxel volume heuristic, which is not built here).", "",
           "| T | " + " | ".join(scenes) + " |", "|---|" + "---|" * len(scenes)]
    for t in thresholds:
        out.append(f"| {t} | " + " | ".join(_f(sweeps[sc][t].fps()) if t in sweeps[sc] and sweeps[sc][t].ok
                                             else "–" for sc in scenes) + " |")
    out.append("| T_auto | " + " | ".join(_f(sweeps[sc][0].fps()) for sc in scenes) + " |")
    out.append("| T_auto's T (mean) | " + " | ".join(_f(sweeps[sc][0].counter("t_auto"), 1) for sc in scenes) + " |")
    best, fractions, medians, cpu_best, cpu_fractions, cpu_medians = [], [], [], [], [], []
    for sc in scenes:
        for clock, best_list, texts, meds in ((WALL, best, fractions, medians),
                                              (CPU, cpu_best, cpu_fractions, cpu_medians)):
            fixed = {t: s.fps(clock) for t, s in sweeps[sc].items() if t > 0 and s.ok}
            fixed = {t: v for t, v in fixed.items() if math.isfinite(v)}
            best_list.append(str(max(fixed, key=fixed.get)) if fixed else "–")
            r = auto_fractions(sweeps[sc], clock)
            texts.append(ratio_text(r, "%", 100.0, 1))
            if len(r):
                meds.append(float(np.median(r)) * 100.0)
    out.append("| fastest fixed T | " + " | ".join(best) + " |")
    out.append("| **FPS_auto / FPS_max** | " + " | ".join(fractions) + " |")
    out.append("| fastest fixed T, CPU time | " + " | ".join(cpu_best) + " |")
    out.append("| FPS_auto / FPS_max, CPU time | " + " | ".join(cpu_fractions) + " |")
    paper = []
    for sc in scenes:
        name = STANDS_FOR.get(sc)
        cols = [f"{k}: T_auto {v[0]}, best {v[1]}, {v[2]}%" for k, v in PAPER_TABLE1.items()
                if name and k.startswith(name)]
        paper.append("; ".join(cols) if cols else "not in Table 1")
    out.append("| paper (stand-in's column) | " + " | ".join(paper) + " |")
    out.append("")
    mean = f"{np.mean(medians):.1f}%" if medians else "–"
    cpu_mean = f"{np.mean(cpu_medians):.1f}%" if cpu_medians else "–"
    out += [f"Mean of the per-scene medians: **{mean}** (paper: {PAPER_TABLE1_MEAN}%); by the frame's process "
            f"CPU time: {cpu_mean}.", ""]
    return out


def auto_fractions(sweep: Dict[int, Setting], clock: str = WALL) -> np.ndarray:
    """Per round in which every cell of the sweep completed: T_auto's FPS over the best FPS of the
    sweep's cells that round (a round missing a cell would compare T_auto with fewer T)."""
    out = []
    for seed in sorted(sweep[0].by_seed):
        if any(seed not in s.by_seed for s in sweep.values()):
            continue
        fps = [1000.0 / frame_median(s.by_seed[seed], clock) for s in sweep.values()]
        if len(fps) > 1 and all(math.isfinite(v) for v in fps):
            out.append(1000.0 / frame_median(sweep[0].by_seed[seed], clock) / max(fps))
    return np.asarray(out, float)


def table2(scenes: List[str], sweeps: Dict[str, Dict[int, Setting]],
           by_scene: Dict[str, List[Setting]]) -> List[str]:
    out = ["## Table 2: photon differentials (T_auto) against kNN photon mapping at matched k", "",
           "k_PD: photon differentials' hits per query (`hits_per_query`, footprints containing the shading "
           "point); k_PM: knn's k as configured (mean found in brackets: `mean_k`, fewer where r_max holds "
           f"fewer). Matched: k_PM within {K_MATCH_TOLERANCE:.0%} of k_PD. Hits: photon differentials' `hits` "
           "and knn's `photons_stored`.", "",
           "| scene (paper's) | emits | hits PD / knn | s | r_max | k_PD | k_PM (found) | k_PM / k_PD | paper: "
           "emits, hits, s, k_PD, k_PM |", "|---|---|---|---|---|---|---|---|---|"]
    speed = ["| scene | knn baseline | FPS_PD | FPS_PM static | **speed-up over static** | CPU time | "
             "FPS_PM every_frame | speed-up over every_frame | CPU time | density estimate: knn gather / PD "
             "query | bytes read per query: knn / PD | paper: FPS_PD, FPS_PM, speed-up |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for sc in scenes:
        pd = sweeps[sc][0]
        baselines = knn_baselines(by_scene[sc])
        paper_name = STANDS_FOR.get(sc, "")
        p = PAPER_TABLE2.get(paper_name)
        k_pd = pd.counter("hits_per_query")
        any_knn = next((s for b in baselines for s in knn_settings(by_scene[sc], b).values() if s.ok), None)
        if any_knn is not None:
            k_pm = float(any_knn.param("k", math.nan))
            k_found = any_knn.counter("mean_k")
            k_ratio = k_pm / k_pd if k_pd > 0 else math.nan
            matched = abs(k_ratio - 1) <= K_MATCH_TOLERANCE if math.isfinite(k_ratio) else False
            k_text = f"{_f(k_ratio)}" + ("" if matched else " (**not matched**: set knn's k to k_PD)")
            hits_knn = _n(any_knn.counter("photons_stored"))
            k_pm_text = f"{k_pm:.0f} ({_f(k_found, 1)})"
        else:
            k_text, hits_knn, k_pm_text = "–", "–", "–"
        paper = (f"{p[0] / 1e3:.0f}k, {p[1] / 1e3:.0f}k, {p[2]}, {p[3]}, {p[5]}" if p else "–")
        out.append(f"| {sc} ({paper_name or '–'}) | {format_param(pd.param('photons', '–'))} | "
                   f"{_n(pd.counter('hits'))} / {hits_knn} | {format_param(pd.param('smoothing', '–'))} | "
                   f"{format_param(pd.param('r_max', '–'))} | {_f(k_pd, 1)} | {k_pm_text} | {k_text} | {paper} |")
        paper_speed = (f"{p[4]}, {p[6]}, {p[4] / p[6]:.1f}×" if p else "–")
        for baseline in baselines or [GRID_BASELINE]:
            knn = knn_settings(by_scene[sc], baseline)
            cols = [_f(pd.fps())]
            for mode in KNN_MODES:
                s = knn.get(mode)
                if s is None or not s.ok:
                    cols += ["–", "–", "–"]
                    continue
                cols += [_f(s.fps()), ratio_text(round_ratios(s, pd)),
                         ratio_text(round_ratios(s, pd, frame_cpu_median))]
            knn_any = knn.get("static") if knn.get("static") is not None and knn["static"].ok else \
                next((s for s in knn.values() if s.ok), None)
            density, traffic = "–", "–"
            if knn_any is not None:
                density = ratio_text(round_ratios(knn_any, pd,
                                                  lambda c: pass_median(c, (DENSITY_PASS[c.technique],))))
                traffic = f"{_n(knn_any.counter(BYTES_PER_QUERY))} / {_n(pd.counter(BYTES_PER_QUERY))}"
            speed.append(f"| {sc} | {baseline_name(baseline)} | " + " | ".join(cols) +
                         f" | {density} | {traffic} | {paper_speed} |")
    lo, hi = PAPER_SPEEDUP_RANGE
    out += ["", "Speed (FPS from frame-time medians; a speed-up is knn's frame time over photon differentials' in "
            "each round, median [range]; \"CPU time\" the same of the frame's process CPU time), one row per knn "
            "baseline the run holds: knn's default, a uniform grid searched near to far with a private heap, is "
            "a stronger baseline than the paper's kd-tree searched from r_max with its heap in global memory "
            "(§7), which knn offers as `search: kdtree, heap: global`; only the paper's row tests the paper's "
            "claim, and on this device only as far as a heap in a buffer is slow here. The static "
            "speed-up is the paper's comparison (its kNN map built once, light static); every_frame counts the "
            "same work on both sides (trace, build and render every frame); the density estimate is the one "
            "pass where the two differ in kind (wall time). Bytes read per query (`bytes_read_per_query`: "
            "nodes, records and heap traffic): the work that does not depend on the device. "
            f"Paper: {lo}× to {hi}×.", ""] + speed + [""]
    return out


def table3(scenes: List[str], by_scene: Dict[str, List[Setting]],
           sweeps: Dict[str, Dict[int, Setting]]) -> List[str]:
    out = ["## Table 3: footprint radii", "",
           "Semi-axis lengths of photon differentials' footprints after compression and smoothing, before the "
           "r_max clamp (two per hit), per frame (the mean over the frames of every round), with the share of "
           "the scene's total in brackets, beside the paper's column for the scene it stands in for. knn: its "
           "query radii r(x) (one per query) at the same bins, for the bandwidth kNN chose at the same k.", ""]
    for sc in scenes:
        columns: List[Tuple[str, List[float]]] = []
        for s in by_scene[sc]:
            if s.ok and is_technique(s, PD) and (s is sweeps[sc][0] or s not in sweeps[sc].values()):
                columns.append((label(s), [s.counter(b) for b in PD_BINS]))
        knn = knn_settings(by_scene[sc])
        k = knn.get("static") if knn.get("static") is not None and knn["static"].ok else knn.get("every_frame")
        if k is not None and k.ok and abs(float(k.param("radius_bin_width", BIN_WIDTH)) - BIN_WIDTH) < 1e-9:
            columns.append((f"{label(k)}: query radii", [k.counter(b) for b in KNN_BINS]))
        paper_name = STANDS_FOR.get(sc)
        paper = PAPER_TABLE3.get(paper_name)
        head = [c for c, _ in columns] + ([f"paper: {paper_name}"] if paper else [])
        out += [f"**{sc}**", "", "| radius (m) | " + " | ".join(head) + " |", "|---|" + "---|" * len(head)]
        data = [v for _, v in columns] + ([[float(x) for x in paper]] if paper else [])
        totals = [np.nansum(v) for v in data]
        for i, b in enumerate(BIN_LABELS):
            row = []
            for v, tot in zip(data, totals):
                x = v[i]
                row.append("–" if not math.isfinite(x) else f"{x:,.0f} ({x / tot * 100:.1f}%)" if tot > 0 else
                           f"{x:,.0f}")
            out.append(f"| {b} | " + " | ".join(row) + " |")
        r_max = float(sweeps[sc][0].param("r_max", 0.7))
        above = int(round(r_max / BIN_WIDTH))
        clamped = [np.nansum(v[above:]) / tot * 100 if tot > 0 else math.nan for v, tot in zip(data, totals)]
        out.append(f"| ≥ r_max {format_param(r_max)} (clamped) | " + " | ".join(f"{_f(x, 1)}%" for x in clamped) + " |")
        out.append("")
    return out


def figure5(scenes: List[str], sweeps: Dict[str, Dict[int, Setting]],
            by_scene: Dict[str, List[Setting]]) -> List[str]:
    out = ["## Fig. 5: time per stage", "",
           "Median ms over every round's frames of each stage's passes, and its share of the frame-time median "
           "(\"other\": the median of each frame's rest, the harness's scene-update and pass bookkeeping). Photon differentials: photon tracing = "
           "photon-trace + photon-upload, BVH build = postprocess (footprints, their boxes, T_auto) + build "
           "(Morton codes, sort, leaves, hierarchy), rendering = gbuffer + direct-light + query + shade. knn "
           "every_frame, for comparison: its grid build in place of the BVH, gather in place of the query. "
           "Paper: \"The rendering phase clearly dominates\".", "",
           "| scene | technique | frame | photon tracing | build | rendering | other | rendering dominates |",
           "|---|---|---|---|---|---|---|---|"]
    for sc in scenes:
        rows = [sweeps[sc][0]]
        ef = knn_settings(by_scene[sc]).get("every_frame")
        if ef is not None and ef.ok:
            rows.append(ef)
        for s in rows:
            frame = s.frame_median()
            *stages, other = s.stage_medians([passes for _, passes in STAGES[s.first.technique]])
            cols = [f"{_f(v, 1)} ms ({v / frame * 100:.0f}%)" for v in stages + [other]]
            dominates = stages[2] > 0.5 * frame
            out.append(f"| {sc} | {label(s)} | {_f(frame, 1)} ms | " + " | ".join(cols) +
                       f" | {'yes' if dominates else 'no'} ({stages[2] / frame * 100:.0f}% of the frame) |")
    return out + [""]


QUALITY = (("flip", "indirect"), ("ssim", "indirect"), ("flip", "combined"), ("ssim", "combined"))


def quality(scenes: List[str], by_scene: Dict[str, List[Setting]],
            sweeps: Dict[str, Dict[int, Setting]]) -> List[str]:
    k = floors.RESOLVE_FACTOR
    out = ["## Quality against the references (the paper compared by eye)", "",
           "Means over every round's metric frames, floor in brackets (what the true image scores against the "
           f"same reference). {UNRESOLVED_MARK}: within {k:g}× its floor (unresolved: it may be the reference's "
           "noise). Indirect: the technique's own class against the `indirect` reference; combined: the composed "
           "frame. A map holding caustics (`caustics: true`) is more than the indirect class, so its indirect "
           "score is not shown (n/a) and combined is its fair score. The threshold sweep's cells render the "
           "same image, so only T_auto's is listed.", "",
           "| scene | technique | FLIP indirect | SSIM indirect | FLIP combined | SSIM combined |",
           "|---|---|---|---|---|---|"]
    orders = []
    for sc in scenes:
        listed = [s for s in by_scene[sc] if s.ok and
                  (not is_technique(s, PD) or s is sweeps[sc][0] or s not in sweeps[sc].values())]
        for s in listed:
            cols = []
            for metric, cls in QUALITY:
                v, f = s.metric(metric, cls)
                mark = UNRESOLVED_MARK if floors.resolved(metric, v, f) is False else ""
                if cls == "indirect" and s.caustics and math.isfinite(v):
                    cols.append("n/a")
                else:
                    cols.append("–" if not math.isfinite(v) else f"{v:.3f}{mark} ({_f(f, 3)})")
            out.append(f"| {sc} | {label(s)} | " + " | ".join(cols) + " |")
        pd = sweeps[sc][0]
        for mode, s in knn_settings(by_scene[sc]).items():
            if s.ok:
                orders.append(flip_order_row(sc, pd, s))
    out.append("")
    orders = [o for o in orders if o]
    if orders:
        out += ["At matched k, FLIP of each technique's fair class (indirect, or combined where the maps hold "
                "caustics), lower first: `<` the order holds against the true image (floors.py: a difference "
                "beyond both floors, or both resolved), `≈` it may be the reference's noise. p: Welch's t-test "
                "(two-sided) on the per-round mean FLIP (each round's photons are its own seed): a p-value above "
                f"{stats.ALPHA:g} says the rounds' own noise could give the difference.", "",
                "| scene | class | order | test | rounds | p |", "|---|---|---|---|---|---|"] + orders + [""]
    return out


def flip_order_row(scene: str, a: Setting, b: Setting) -> str:
    cls = "combined" if a.caustics or b.caustics else "indirect"
    (va, fa), (vb, fb) = a.metric("flip", cls), b.metric("flip", cls)
    if not (math.isfinite(va) and math.isfinite(vb)):
        return ""
    holds = floors.comparison_resolved("flip", va, fa, vb, fb)
    sep = "<" if holds else "≈" if holds is False else ","
    first, second = ((label(a), va), (label(b), vb)) if va <= vb else ((label(b), vb), (label(a), va))
    w = stats.welch(seeds.per_seed_means(a.ok_cells, "flip", cls), seeds.per_seed_means(b.ok_cells, "flip", cls))
    p = f"{w.p:.3g}" if w.possible else "–"
    return (f"| {scene} | {cls} | {first[0]} {first[1]:.3f} {sep} {second[0]} {second[1]:.3f} | {w.test} | "
            f"{w.n_a} / {w.n_b} | {p} |")
