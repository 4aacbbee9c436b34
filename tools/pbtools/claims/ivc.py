"""Indirectly visible caustics (seed 002's Paper V, Moreau et al.; seed 004 §5.2's splat BVH) claims,
measured on a run of configs/indirect-caustics.yaml.

  * Paper V's Table 1 without SVGF: per scene and scored frame (AC@150, AC@298, AL@150, ... as the
    paper names them: the caustic-box variant's letters and the frame) collection-points' MAE and FLIP
    of the indirect_caustics class, the mean over the run's seeds with their standard deviation and
    its share of the mean (the paper's spread over 10 seeds: at most 3.7%), FLIP beside its floor;
  * temporal against basic (§3.1): FLIP's change per scene and frame (the paper: -13.9% and -24.6%
    on AC);
  * aaps's splat_bvh against plain aaps (seed 004 §5.2): the mean frame time of AAPS's passes with
    the walk's passes added over AAPS's alone (the thesis: about 10x, 1.5 -> 15 ms), the BVH build's
    share of build and walk (the thesis: over two thirds), BVH nodes and bytes, and splat_bvh's
    indirect_caustics FLIP beside collection-points' (seed-matched means);
  * accumulation against rasterisation (Paper V §4: 8.5-9 ms to accumulate against 1-1.5 ms to
    rasterise the same photons): collection-points' accumulate pass per thousand stored photons
    beside AAPS's rasterize pass per thousand splats drawn, the photon counts differing between the
    two, so the per-photon time is the comparison; and each technique's GPU memory;
  * equal time (a run with a `match:` block, configs/indirect-caustics-equal-time.yaml): each
    technique's knob value found, its achieved frame time and its indirect_caustics FLIP beside the
    floor.
A cell's setting is read from its parameters, a parameter it does not set taking the technique's
default. Times are the harness's rule for a pass's time (the larger of its GPU and CPU times)."""

import math
from typing import Dict, List, Tuple

import numpy as np

from ..matching import measured_cells, read_matches
from ..rundata import Cell, Run

TITLE = ("Real-Time Rendering of Indirectly Visible Caustics (seed 002's Paper V) and AAPS's splat "
         "BVH (seed 004 §5.2)")
CP, AAPS = "collection-points", "aaps"
CLASS = "indirect_caustics"
PAPER_SPREAD = 0.037  # Table 1: the largest standard deviation over 10 seeds, as a share of the mean
PAPER_TEMPORAL = "AC: FLIP -13.9% and -24.6%"
THESIS_RATIO, THESIS_BUILD_SHARE = 10.0, 2.0 / 3.0
AAPS_PASSES = ("photon-trace", "rasterize", "apply", "task-update")
WALK_PASSES = ("camera-paths", "camera-path-upload", "splat-bvh", "indirect")


class MissingCells(Exception):
    pass


def setting(cell: Cell, name: str, default: str) -> str:
    v = cell.params.get(name)
    return default if v is None or (isinstance(v, float) and math.isnan(v)) or str(v) == "" \
        else str(v).strip().lower()


def variant(scene: str) -> str:
    """Paper V's name of a caustic-box variant (caustic-box-ac -> AC); other scenes keep theirs."""
    return scene.rsplit("-", 1)[1].upper() if scene.startswith("caustic-box-") else scene


def by_frame(cells: List[Cell], metric: str) -> Dict[int, List[float]]:
    """frame -> the metric of CLASS in each cell (one per seed) scored there."""
    out: Dict[int, List[float]] = {}
    for c in cells:
        frames, values = c.metric_series(metric, CLASS)
        for f, v in zip(frames, values):
            out.setdefault(int(f), []).append(float(v))
    return out


def spread(values: List[float]) -> Tuple[float, float]:
    mean = float(np.mean(values))
    sd = float(np.std(values, ddof=1)) if len(values) > 1 else math.nan
    return mean, sd


def fmt(v: float, digits: int = 3) -> str:
    return "-" if v is None or math.isnan(v) else f"{v:.{digits}f}"


def cp_cells(run: Run, scene: str, temporal: bool) -> List[Cell]:
    return [c for c in run.cells_of(scene) if c.ok and c.technique == CP
            and setting(c, "accumulator", "fixed64") == "fixed64"
            and setting(c, "emission", "aimed") == "aimed"
            and (setting(c, "temporal", "false") == "true") == temporal]


def table1(run: Run, scenes: List[str]) -> List[str]:
    lines = ["### Table 1 without SVGF: collection-points, `indirect_caustics`", "",
             "| row | temporal | seeds | MAE (sd) | FLIP (sd) | FLIP floor | spread (sd / mean FLIP) |",
             "|---|---|---|---|---|---|---|"]
    for scene in scenes:
        for temporal in (False, True):
            cells = cp_cells(run, scene, temporal)
            mae, flip = by_frame(cells, "mae"), by_frame(cells, "flip")
            floors = by_frame(cells, "flip_floor")
            for frame in sorted(flip):
                m_mae, sd_mae = spread(mae[frame]) if frame in mae else (math.nan, math.nan)
                m_flip, sd_flip = spread(flip[frame])
                share = sd_flip / m_flip if m_flip > 0 else math.nan
                floor = float(np.mean(floors.get(frame, [math.nan])))
                lines.append(f"| {variant(scene)}@{frame} | {'yes' if temporal else 'no'} | "
                             f"{len(flip[frame])} | {fmt(m_mae, 4)} ({fmt(sd_mae, 4)}) | "
                             f"{fmt(m_flip)} ({fmt(sd_flip)}) | {fmt(floor)} | "
                             f"{'-' if math.isnan(share) else f'{share * 100:.1f}%'} |")
    lines += ["", f"The paper's spread over 10 seeds: at most {PAPER_SPREAD * 100:.1f}% of the mean.", ""]
    return lines


def temporal_rows(run: Run, scenes: List[str]) -> List[str]:
    lines = ["### Temporal reuse against basic (§3.1)", "",
             f"The paper: {PAPER_TEMPORAL}.", "", "| row | basic FLIP | temporal FLIP | change |",
             "|---|---|---|---|"]
    for scene in scenes:
        basic = by_frame(cp_cells(run, scene, False), "flip")
        reuse = by_frame(cp_cells(run, scene, True), "flip")
        for frame in sorted(set(basic) & set(reuse)):
            b, t = float(np.mean(basic[frame])), float(np.mean(reuse[frame]))
            lines.append(f"| {variant(scene)}@{frame} | {fmt(b)} | {fmt(t)} | {(t - b) / b * 100:+.1f}% |")
    return lines + [""]


def mean_frame_ms(cells: List[Cell], passes) -> float:
    sums = [c.pass_sums(passes) for c in cells]
    sums = [s for s in sums if len(s)]
    return float(np.mean([s.mean() for s in sums])) if sums else math.nan


def counter_mean(cells: List[Cell], name: str) -> float:
    values = [c.counter_means().get(name, math.nan) for c in cells]
    return float(np.nanmean(values)) if values and not all(math.isnan(v) for v in values) else math.nan


def all_frames_mean(cells: List[Cell], metric: str) -> float:
    values = sum(by_frame(cells, metric).values(), [])
    return float(np.mean(values)) if values else math.nan


def splat_bvh_rows(run: Run, scenes: List[str]) -> List[str]:
    lines = ["### AAPS's splat BVH against plain AAPS (seed 004 §5.2)", "",
             f"The thesis: about {THESIS_RATIO:.0f}x (1.5 -> 15 ms), the build over "
             f"{THESIS_BUILD_SHARE * 100:.0f}% of the added time.", "",
             "| scene | aaps ms | splat_bvh ms | ratio | build share of build + walk | BVH nodes | "
             f"bytes added | `{CLASS}` FLIP splat_bvh | collection-points |",
             "|---|---|---|---|---|---|---|---|---|"]
    found = False
    for scene in scenes:
        cells = [c for c in run.cells_of(scene) if c.ok and c.technique == AAPS]
        plain = [c for c in cells if setting(c, "indirect", "none") == "none"]
        walked = [c for c in cells if setting(c, "indirect", "none") == "splat_bvh"]
        if not plain or not walked:
            continue
        found = True
        t_plain = mean_frame_ms(plain, AAPS_PASSES)
        t_walked = mean_frame_ms(walked, AAPS_PASSES + WALK_PASSES)
        build, walk = mean_frame_ms(walked, ("splat-bvh",)), mean_frame_ms(walked, ("indirect",))
        flip_walked = all_frames_mean(walked, "flip")
        flip_cp = all_frames_mean(cp_cells(run, scene, False), "flip")
        nodes, added = counter_mean(walked, "bvh_nodes"), counter_mean(walked, "bytes_indirect")
        lines.append(f"| {scene} | {fmt(t_plain, 1)} | {fmt(t_walked, 1)} | {t_walked / t_plain:.2f}x | "
                     f"{build / (build + walk) * 100:.0f}% | {fmt(nodes, 0)} | {fmt(added, 0)} | "
                     f"{fmt(flip_walked)} | {fmt(flip_cp)} |")
    if not found:
        lines.append("| (no scene has aaps cells with indirect: none and splat_bvh) | | | | | | | | |")
    return lines + [""]


def label(cell: Cell) -> str:
    if cell.technique == CP:
        notes = [n for n, on in (("temporal", setting(cell, "temporal", "false") == "true"),
                                 ("power emission", setting(cell, "emission", "aimed") == "power"),
                                 ("fixed4_28", setting(cell, "accumulator", "fixed64") == "fixed4_28"))
                 if on]
        return f"{CP} ({', '.join(notes)})" if notes else CP
    return f"{AAPS} ({setting(cell, 'indirect', 'none')})" if cell.technique == AAPS else cell.technique


def per_thousand(cells: List[Cell], pass_name: str, counter: str) -> float:
    """The pass's mean time (ms) per thousand of `counter`, over the cells' frames."""
    ms, count = mean_frame_ms(cells, (pass_name,)), counter_mean(cells, counter)
    return ms / count * 1000.0 if count > 0 else math.nan


def accumulation_rows(run: Run, scenes: List[str]) -> List[str]:
    lines = ["### Accumulation against rasterisation, and memory", "",
             "The paper: accumulating the photons into the CPs 8.5-9 ms against 1-1.5 ms to rasterise "
             "the same photons. The photon counts differ between the techniques, so each pass's time "
             "is given per thousand of its own items (lavapipe rasterises on the CPU: the work "
             "counts are the platform-independent part).", "",
             "| scene | setting | accumulate ms / 1k photons stored | rasterize ms / 1k splats drawn | "
             "photons stored / splats drawn | GPU bytes |", "|---|---|---|---|---|---|"]
    for scene in scenes:
        groups: Dict[str, List[Cell]] = {}
        for c in run.cells_of(scene):
            if c.ok and c.technique in (CP, AAPS) and c.match_round is None:
                groups.setdefault(label(c), []).append(c)
        for name, cells in groups.items():
            if cells[0].technique == CP:
                lines.append(f"| {scene} | {name} | "
                             f"{fmt(per_thousand(cells, 'accumulate', 'photons_stored'))} | - | "
                             f"{fmt(counter_mean(cells, 'photons_stored'), 0)} | "
                             f"{fmt(counter_mean(cells, 'bytes_total'), 0)} |")
            else:
                lines.append(f"| {scene} | {name} | - | "
                             f"{fmt(per_thousand(cells, 'rasterize', 'splats_drawn'))} | "
                             f"{fmt(counter_mean(cells, 'splats_drawn'), 0)} | "
                             f"{fmt(counter_mean(cells, 'bytes_indirect'), 0)} (splat_bvh's) |")
    return lines + [""]


def equal_time_rows(run: Run) -> List[str]:
    """The found cells of a match run at one frame time; nothing for a run without match.csv."""
    rows = [r for r in read_matches(run.path) if r.get("at") == "time"]
    if not rows:
        return []
    lines = ["### Equal time", "",
             f"Each technique's budget knob searched to {rows[0]['target']} ms a frame "
             f"(tolerance {rows[0]['tolerance']}); the achieved time is the median of the found "
             "setting's re-measured frames (p5-p95); FLIP of the class, the mean over the found "
             "cell's scored frames.", "",
             f"| scene | setting | status | knob = value | achieved ms (p5-p95) | `{CLASS}` FLIP | "
             "floor |", "|---|---|---|---|---|---|---|"]
    for r in rows:
        cell = run.cell(r["cell"]) if r.get("cell") else None
        flip = floor = math.nan
        if cell is not None:
            # The re-measurement rounds repeat the found setting: their scores pool with its own.
            ids = dict.fromkeys(measured_cells(run.path, r) + [cell.id])
            values = [v for cid in ids if run.cell(cid) is not None
                      for v in run.cell(cid).metric_series("flip", CLASS)[1]]
            floors = cell.metric_series("flip_floor", CLASS)[1]
            flip = float(np.mean(values)) if values else math.nan
            floor = float(np.mean(floors)) if len(floors) else math.nan
        name = label(cell) if cell is not None else r["technique"]
        lines.append(f"| {r['scene']} | {name} | {r['status']} | {r['knob']} = {r['knob_value']} | "
                     f"{r['wall_ms_median']} ({r['wall_ms_p5']}-{r['wall_ms_p95']}) | {fmt(flip)} | "
                     f"{fmt(floor)} |")
    return lines + [""]


def claims(run: Run) -> str:
    scenes = [s for s in run.scenes() if any(c.technique == CP and c.ok for c in run.cells_of(s))]
    if not scenes:
        raise MissingCells(f"no {CP} cell ran ok: run configs/indirect-caustics.yaml")
    out = [f"# Claims: {TITLE}", "", f"Run {run.name}; device {run.device}; commit {run.commit}.", ""]
    out += table1(run, scenes) + temporal_rows(run, scenes) + splat_bvh_rows(run, run.scenes())
    out += accumulation_rows(run, run.scenes()) + equal_time_rows(run)
    return "\n".join(out) + "\n"
