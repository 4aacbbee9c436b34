"""The report's plots. Each builder returns a Figure: the matplotlib figure, a caption, and the exact
numbers it drew as a table (written beside the figure as CSV, so a reader, a paper's artifact
evaluation and the tests can check a figure against the run's CSV files).

Every drawn data series carries a gid ("points:<technique>:<metric>", "bar:<cell>:<pass>",
"time:<cell>", ...) so tests can find it in the figure and compare it with its source.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence, Tuple

import numpy as np
from matplotlib import ticker

from . import floors, measures, stats, style
from .rundata import WHOLE_FRAME_PASS, Cell, Run, format_param

QUALITY_METRICS = ("flip", "ssim", "psnr")


@dataclass
class Figure:
    stem: str  # file name without extension
    title: str
    caption: str
    fig: object  # matplotlib.figure.Figure
    header: List[str] = field(default_factory=list)
    rows: List[list] = field(default_factory=list)
    kind: str = "plot"  # "plot" (shown as SVG) or "image" (raster grid, shown as PNG)


def slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9._-]+", "_", text).strip("_") or "x"


def pareto_front(x: Sequence[float], y: Sequence[float], y_lower_is_better: bool) -> List[int]:
    """Indices of the points no other point dominates, for minimising x (time) and minimising y (an
    error) or maximising it (a similarity), ordered by x. A point dominates another when it is no worse
    in both and better in one; ties in both keep the first."""
    pts = [(float(a), float(b) if y_lower_is_better else -float(b), i) for i, (a, b) in enumerate(zip(x, y))
           if math.isfinite(a) and math.isfinite(b)]
    pts.sort()
    front, best = [], math.inf
    for a, b, i in pts:
        if b < best:
            front.append(i)
            best = b
    return front


def _short(text: str, n: int = 70) -> str:
    return text if len(text) <= n else text[: n - 1] + "\u2026"


def _failed_note(run: Run, cells: List[Cell]) -> str:
    failed = [c for c in cells if not c.ok]
    if not failed:
        return ""
    parts = []
    for c in failed:
        if c.failed_frame is not None:
            where = f" at frame {c.failed_frame}"
        elif not (c.value("frames") > 0):
            where = " before its first frame"
        else:
            where = ""
        parts.append(f"{run.label(c)} failed{where}")
    return "Failed: " + "; ".join(parts)


def quality_vs_time(run: Run, scene: str, styles: style.TechniqueStyle,
                    metrics: Sequence[str] = QUALITY_METRICS) -> Optional[Figure]:
    cells = run.cells_of(scene)
    metrics = [m for m in metrics if any(math.isfinite(c.value(f"{m}_mean")) for c in cells)]
    if not metrics:
        return None
    n = len(metrics)
    fig, axes = style.new_figure(min(style.TEXT_WIDTH_IN, 2.35 * n), 2.1, 1, n)
    header = ["cell", "technique", "label", "status", "wall_ms_median", "wall_ms_p5", "wall_ms_p95"]
    header += [f"{m}_mean" for m in metrics] + [f"pareto_{m}" for m in metrics]
    header += [f"{m}_floor" for m in metrics] + [f"resolved_{m}" for m in metrics]
    ok = [c for c in cells if c.ok and math.isfinite(c.value("wall_ms_median"))]
    on_front: Dict[str, set] = {}
    any_floor = False
    for k, m in enumerate(metrics):
        ax = axes[0][k]
        xs = [c.value("wall_ms_median") for c in ok]
        ys = [c.value(f"{m}_mean") for c in ok]
        any_floor |= _draw_floor(ax, m, [c.value(f"{m}_floor") for c in ok], label=k == 0)
        front = pareto_front(xs, ys, measures.lower_is_better(m))
        on_front[m] = {ok[i].id for i in front}
        if len(front) >= 1:
            fx = [xs[i] for i in front]
            fy = [ys[i] for i in front]
            # The attainable region's boundary is a staircase: from each front point, time must grow to
            # reach the next better quality.
            ax.plot(fx, fy, drawstyle="steps-post", color=style.PARETO_COLOR, lw=0.8, ls="--", zorder=1,
                    gid=f"pareto:{m}", label="Pareto front" if k == 0 else None)
        for tech in run.techniques():
            tc = [c for c in ok if c.technique == tech and math.isfinite(c.value(f"{m}_mean"))]
            if not tc:
                continue
            color, marker = styles.color(tech), styles.marker(tech)
            tx = np.array([c.value("wall_ms_median") for c in tc])
            ty = np.array([c.value(f"{m}_mean") for c in tc])
            lo = tx - np.array([c.value("wall_ms_p5") for c in tc])
            hi = np.array([c.value("wall_ms_p95") for c in tc]) - tx
            err = np.nan_to_num(np.vstack([lo, hi]), nan=0.0).clip(min=0)
            ax.errorbar(tx, ty, xerr=err, fmt="none", ecolor=color, elinewidth=0.5, alpha=0.6, zorder=2)
            if len(tc) > 1:  # a sweep: connect its settings in time order to show the trade-off path
                order = np.argsort(tx)
                ax.plot(tx[order], ty[order], color=color, lw=0.6, alpha=0.5, zorder=2)
            ax.plot(tx, ty, ls="none", marker=marker, color=color, markeredgecolor="white",
                    markeredgewidth=0.4, zorder=3, gid=f"points:{tech}:{m}", label=tech if k == 0 else None)
            # Scores the floor does not resolve: hollow, over the filled marker.
            loose = [(x, y) for c, x, y in zip(tc, tx, ty) if _resolved(c, m) is False]
            if loose:
                ax.plot([p[0] for p in loose], [p[1] for p in loose], ls="none", marker=marker,
                        markerfacecolor="white", markeredgecolor=color, markeredgewidth=0.8, zorder=4,
                        gid=f"unresolved:{tech}:{m}")
            if 1 < len(tc) <= 8:
                for c, x, y in zip(tc, tx, ty):
                    # Placed after the layout (place_point_labels); a leader line, shown only when
                    # the label has to move away from its point, ties it back.
                    label = ax.annotate(run.label(c, with_technique=False), (x, y), xytext=(3, 2),
                                        textcoords="offset points", fontsize=5, color=color,
                                        gid=f"point-label:{c.id}:{m}", zorder=2.5,  # under the markers
                                        # readable over the error bars and lines it may sit on
                                        bbox={"boxstyle": "square,pad=0.1", "fc": "white", "ec": "none",
                                              "alpha": 0.75},
                                        arrowprops={"arrowstyle": "-", "color": color, "lw": 0.3,
                                                    "alpha": 0.7, "shrinkA": 0.5, "shrinkB": 2.5})
                    label.set_in_layout(False)
        ax.margins(0.08, 0.12)  # room inside the axes for the labels of the outermost points
        ax.set_xlabel("median frame time [ms]")
        lower = " (lower is better)" if measures.lower_is_better(m) else ""
        ax.set_ylabel(measures.metric(m).label + lower)
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, loc="upper center", ncol=min(6, len(labels)), bbox_to_anchor=(0.5, 1.08))
    note = _failed_note(run, cells)
    if note:
        fig.text(0.01, -0.06, _short(note, 160), fontsize=6, color=style.FAILED_COLOR, gid="failed-note")
    fig.tight_layout()
    for ax in axes[0]:
        place_point_labels(fig, ax)
    rows = []
    for c in cells:
        rows.append([c.id, c.technique, run.label(c), c.status, c.value("wall_ms_median"),
                     c.value("wall_ms_p5"), c.value("wall_ms_p95")]
                    + [c.value(f"{m}_mean") for m in metrics]
                    + [int(c.id in on_front[m]) for m in metrics]
                    + [c.value(f"{m}_floor") for m in metrics]
                    + ["" if _resolved(c, m) is None else int(_resolved(c, m)) for m in metrics])
    caption = ("Mean error over the metric frames against median frame time (bars: p5-p95 of frame "
               "time); dashed: the Pareto front of the successful cells. Failed cells cannot be placed "
               "and are listed below the plot.")
    if any_floor:
        caption += (" Grey line: the noise floor (what the true image scores against this reference); "
                    f"shaded up to {floors.RESOLVE_FACTOR:g}x the floor: scores there (hollow markers) "
                    "are not resolved by the reference and may measure its noise.")
    return Figure(f"quality_vs_time_{slug(scene)}", f"{scene}: quality against time", caption, fig, header,
                  rows)


# Where a point's label may go, tried in order: offsets in points from the point at growing distance,
# each with the text alignment that keeps the text on that side of the point (right-above first, as
# labels sat before any collision).
_LABEL_DIRECTIONS = [((1, 0.6), "left", "bottom"), ((1, -0.6), "left", "top"), ((-1, 0.6), "right", "bottom"),
                     ((-1, -0.6), "right", "top"), ((0, 1), "center", "bottom"), ((0, -1), "center", "top"),
                     ((1, 0), "left", "center"), ((-1, 0), "right", "center")]
_LABEL_DISTANCES_PT = [3.5, 8, 13, 19, 26, 34, 44, 56]
_LABEL_GAP_PT = 1.0  # space kept free around a label, so labels never touch at any resolution


def _label_extent(label, renderer):
    """The display box of an annotation's text alone (without its leader line)."""
    import matplotlib.text
    label.update_positions(renderer)
    return matplotlib.text.Text.get_window_extent(label, renderer)


def _overlap_area(a, b) -> float:
    w = min(a.x1, b.x1) - max(a.x0, b.x0)
    h = min(a.y1, b.y1) - max(a.y0, b.y0)
    return w * h if w > 0 and h > 0 else 0.0


def _distance(box, point) -> float:
    x, y = point
    return math.hypot(max(box.x0 - x, 0, x - box.x1), max(box.y0 - y, 0, y - box.y1))


def _leader(anchor, box):
    """The leader line from a point to its label's box (to the box's nearest edge point)."""
    from matplotlib.path import Path
    x, y = anchor
    return Path([(x, y), (min(max(x, box.x0), box.x1), min(max(y, box.y0), box.y1))])


def place_point_labels(fig, ax) -> None:
    """Moves the point labels (gid "point-label:...") of one axes so that none covers another label
    or a marker and all stay inside the axes. Close settings of one technique (a sweep whose points
    nearly coincide) would otherwise print their labels over each other.

    Each label has candidate offsets around its point (_LABEL_DIRECTIONS x _LABEL_DISTANCES_PT),
    measured with the renderer's text extents in the final layout (call after tight_layout). Labels
    take, one after another, their least bad candidate given the ones placed before: covering a label
    or a marker, or leaving the axes, is worst; a leader line (drawn only for a label moved away from
    its point) crossing a label, and a label nearer another point than its own, are lesser faults.
    Greedy placement depends on the order, so four orders (by x and by y, both ways) are tried and
    the arrangement with the least total fault is kept."""
    labels = [t for t in ax.texts if (t.get_gid() or "").startswith("point-label:")]
    if not labels:
        return
    from matplotlib.transforms import Bbox
    renderer = fig.canvas.get_renderer()
    to_px = fig.dpi / 72.0
    gap = _LABEL_GAP_PT * to_px
    frame = ax.get_window_extent(renderer)
    markers = []
    for line in ax.lines:
        if line.get_marker() in (None, "None", "none", "") or not line.get_visible():
            continue
        half = line.get_markersize() * to_px / 2
        for px, py in line.get_transform().transform(np.asarray(line.get_xydata(), float)):
            if np.isfinite(px) and np.isfinite(py):
                markers.append(Bbox.from_extents(px - half, py - half, px + half, py + half))
    centres = [((b.x0 + b.x1) / 2, (b.y0 + b.y1) / 2) for b in markers]
    anchors = [ax.transData.transform(t.xy) for t in labels]

    # Per label: (fault independent of the other labels, placement, padded box, leader or None).
    candidates = []
    for label, anchor in zip(labels, anchors):
        options = []
        for distance in _LABEL_DISTANCES_PT:
            for (dx, dy), ha, va in _LABEL_DIRECTIONS:
                placement = ((dx * distance, dy * distance), ha, va)
                _set_placement(label, placement)
                box = _label_extent(label, renderer).padded(gap)
                area = box.width * box.height
                # Hiding a point even in part is as bad as covering half a label.
                fault = sum(_overlap_area(box, m) + 0.5 * area * (_overlap_area(box, m) > 0) for m in markers)
                # Leaving the axes is nearly as bad as covering a label: it may cover the next panel's ticks.
                fault += 4 * (area - _overlap_area(box, frame))
                if distance > _LABEL_DISTANCES_PT[0]:
                    # The leader tells the label's point, unless it passes (near) another point.
                    leader = _leader(anchor, box)
                    fault += 0.25 * area * sum(leader.intersects_bbox(m.padded(2 * gap), filled=True)
                                               for m in markers if _distance(m, anchor) > 0)
                else:
                    # Without one, a label nearer another point than its own reads as that point's.
                    leader = None
                    own = _distance(box, anchor)
                    fault += 0.1 * area * any(_distance(box, c) < own - gap for c in centres)
                options.append((fault, placement, box, leader))
        candidates.append(options)

    def arrange(order):
        total, chosen, boxes, leaders = 0.0, {}, [], []
        for i in order:
            def fault(option):
                base, _, box, leader = option
                area = box.width * box.height
                crossings = sum(other.intersects_bbox(box, filled=True) for other in leaders)
                if leader is not None:
                    crossings += sum(leader.intersects_bbox(other, filled=True) for other in boxes)
                return base + 8 * sum(_overlap_area(box, other) for other in boxes) + 0.25 * area * crossings
            faults = [fault(o) for o in candidates[i]]
            k = int(np.argmin(faults))  # the first of equals: the nearest to the point
            total += faults[k]
            chosen[i] = candidates[i][k]
            boxes.append(chosen[i][2])
            if chosen[i][3] is not None:
                leaders.append(chosen[i][3])
        return total, chosen

    n = range(len(labels))
    by_x = sorted(n, key=lambda i: (anchors[i][0], anchors[i][1]))
    by_y = sorted(n, key=lambda i: (anchors[i][1], anchors[i][0]))
    _, chosen = min((arrange(order) for order in (by_x, by_x[::-1], by_y, by_y[::-1])),
                    key=lambda result: result[0])
    for i, label in enumerate(labels):
        _, placement, _, leader = chosen[i]
        _set_placement(label, placement)
        label.arrow_patch.set_visible(leader is not None)
        label.set_in_layout(True)  # as placed, for the saved figure's tight bounding box


def _set_placement(label, placement) -> None:
    offset, ha, va = placement
    label.set_position(offset)
    label.set_horizontalalignment(ha)
    label.set_verticalalignment(va)


def _resolved(cell: Cell, metric: str) -> Optional[bool]:
    return floors.resolved(metric, cell.value(f"{metric}_mean"), cell.value(f"{metric}_floor"))


def _draw_floor(ax, metric: str, cell_floors: List[float], label: bool) -> bool:
    """The noise floor of one panel (the median of its cells' floors: one reference per scene, so they
    agree unless cells scored different frames) and the band up to RESOLVE_FACTOR x the floor where
    scores are unresolved. Returns whether there was a floor to draw."""
    known = [f for f in cell_floors if math.isfinite(f)]
    if not known:
        return False
    floor = float(np.median(known))
    edge = floors.unresolved_line(metric, floor)
    ax.axhline(floor, color=style.FLOOR_COLOR, lw=0.9, zorder=1, gid=f"floor:{metric}",
               label="noise floor" if label else None)
    if math.isfinite(edge):
        ax.axhspan(min(floor, edge), max(floor, edge), color=style.FLOOR_COLOR, alpha=0.15, lw=0, zorder=0,
                   gid=f"unresolved-band:{metric}",
                   label=f"< {floors.RESOLVE_FACTOR:g}x floor: unresolved" if label else None)
    return True


def pass_breakdown(run: Run, scene: str, styles: style.TechniqueStyle) -> Optional[Figure]:
    cells = run.cells_of(scene)
    if not cells:
        return None
    top = [p for p in run.pass_columns if "/" not in p]
    used = [p for p in top if any(p in c.pass_medians() for c in cells)]
    colors = style.pass_colors(top)  # from all passes of the run: a pass keeps its colour in every scene
    height = 0.7 + 0.22 * len(cells)
    fig, axes = style.new_figure(style.COLUMN_WIDTH_IN * 1.5, height)
    ax = axes[0][0]
    header = ["cell", "technique", "label", "status"] + used + ["other", "wall_ms_median"]
    rows = []
    labels = []
    xmax = 0.0
    for y, c in enumerate(cells):
        med = c.pass_medians()
        left = 0.0
        failed = not c.ok
        for i, p in enumerate(used):
            v = med.get(p, math.nan)
            if not math.isfinite(v):
                continue
            ax.barh(y, v, left=left, color=colors[p], edgecolor="white", linewidth=0.3,
                    hatch=style.HATCHES[i % len(style.HATCHES)] if failed else None,
                    alpha=0.45 if failed else 1.0, gid=f"bar:{c.id}:{p}")
            left += v
        frame = c.value("wall_ms_median")
        other = frame - left if math.isfinite(frame) else math.nan
        # Time the frame spends outside named passes (submission, fences, waits). Negative only when
        # pass medians do not add up to the frame median (medians are not additive): then nothing.
        if math.isfinite(other) and other > 0:
            ax.barh(y, other, left=left, color=colors["other"], edgecolor="white", linewidth=0.3,
                    alpha=0.45 if failed else 1.0, gid=f"bar:{c.id}:other")
            left += other
        xmax = max(xmax, left)
        if failed:
            where = f" at frame {c.failed_frame}" if c.failed_frame is not None else ""
            if left == 0:
                where += " (no frames)"
            ax.text(left, y, f"  FAILED{where}", va="center", ha="left", fontsize=5.5,
                    color=style.FAILED_COLOR, gid=f"failed:{c.id}")
        labels.append(run.label(c))
        rows.append([c.id, c.technique, run.label(c), c.status] + [med.get(p, math.nan) for p in used]
                    + [other, frame])
    import matplotlib.patches as mpatches
    handles = [mpatches.Patch(color=colors[p], label=p) for p in used]
    if any(math.isfinite(r[-2]) and r[-2] > 0 for r in rows):
        handles.append(mpatches.Patch(color=colors["other"], label="other"))
    ax.set_yticks(range(len(cells)))
    ax.set_yticklabels(labels)
    ax.invert_yaxis()
    ax.set_xlim(0, xmax * 1.25 if xmax > 0 else 1)
    ax.set_xlabel("median time [ms]")
    ax.grid(axis="y", visible=False)
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), ncol=1)
    fig.tight_layout()
    return Figure(f"passes_{slug(scene)}", f"{scene}: time per pass",
                  "Median time of each top-level pass per cell, stacked; 'other' is the rest of the median "
                  "frame time. Hatched, faded bars are failed cells (medians over the frames before the "
                  "failure). Nested passes are in the table beside the figure.", fig, header, rows)


def timeline(run: Run, scene: str, styles: style.TechniqueStyle, clock: str = "auto",
             popping_k: float = stats.POPPING_K) -> Optional[Figure]:
    cells = run.cells_of(scene)
    with_frames = [c for c in cells if len(c.pass_samples(WHOLE_FRAME_PASS, clock)[0])]
    if not with_frames:
        return None
    fig, axes = style.new_figure(style.TEXT_WIDTH_IN, 3.2, 2, 1, sharex=True)
    ax_t, ax_e = axes[0][0], axes[1][0]
    header = ["cell", "technique", "label", "series", "frame", "value"]
    rows = []
    setting_idx: Dict[str, int] = {}
    for c in with_frames:
        color = styles.color(c.technique)
        ls = style.LINESTYLES[setting_idx.setdefault(c.technique, 0) % len(style.LINESTYLES)]
        setting_idx[c.technique] += 1
        f, t = c.pass_samples(WHOLE_FRAME_PASS, clock)
        ax_t.plot(f, t, color=color, ls=ls, lw=0.9, gid=f"time:{c.id}", label=run.label(c))
        rows += [[c.id, c.technique, run.label(c), "frame_ms", int(a), float(b)] for a, b in zip(f, t)]
        mf, mv = c.metric_series("flip")
        if len(mf):
            ax_e.plot(mf, mv, color=color, ls=ls, lw=0.9, marker=styles.marker(c.technique), markersize=3,
                      gid=f"flip:{c.id}")
            rows += [[c.id, c.technique, run.label(c), "flip", int(a), float(b)] for a, b in zip(mf, mv)]
            for pop in stats.popping_frames(mf, mv, popping_k):
                yv = float(mv[list(mf).index(pop)])
                ax_e.plot([pop], [yv], ls="none", marker="o", markersize=7, markerfacecolor="none",
                          markeredgecolor=style.FAILED_COLOR, markeredgewidth=0.9, zorder=6,
                          gid=f"pop:{c.id}:{pop}")
                rows.append([c.id, c.technique, run.label(c), "pop", pop, yv])
        for w in c.warnings:
            if w["frame"] is None:
                continue
            k = np.searchsorted(f, w["frame"])
            yv = t[min(k, len(t) - 1)] if len(t) else 0
            ax_t.plot([w["frame"]], [yv], ls="none", marker="^", markersize=6, color=style.WARNING_COLOR,
                      markeredgecolor="black", markeredgewidth=0.4, zorder=5, gid=f"warning:{c.id}:{w['frame']}")
            rows.append([c.id, c.technique, run.label(c), "warning", w["frame"], yv])
        if not c.ok and c.failed_frame is not None:
            ff = c.failed_frame
            for ax in (ax_t, ax_e):
                ax.axvline(ff, color=style.FAILED_COLOR, lw=0.7, ls=":", zorder=4)
            yv = t[-1] if len(t) else 0
            ax_t.plot([ff], [yv], ls="none", marker="X", markersize=7, color=style.FAILED_COLOR,
                      markeredgecolor="black", markeredgewidth=0.4, zorder=6, gid=f"failure:{c.id}")
            rows.append([c.id, c.technique, run.label(c), "failure", ff, yv])
    # Legend proxies for the event markers.
    ax_t.plot([], [], ls="none", marker="X", color=style.FAILED_COLOR, markeredgecolor="black",
              markeredgewidth=0.4, label="failure")
    ax_t.plot([], [], ls="none", marker="^", color=style.WARNING_COLOR, markeredgecolor="black",
              markeredgewidth=0.4, label="warning")
    ax_t.plot([], [], ls="none", marker="o", markerfacecolor="none", markeredgecolor=style.FAILED_COLOR,
              markeredgewidth=0.9, label=f"popping (FLIP > {popping_k:g} MAD-sd)")
    ax_t.set_ylabel("frame time [ms]")
    ax_e.set_ylabel("FLIP")
    ax_e.set_xlabel("frame")
    ax_t.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), ncol=1)
    no_frames = [c for c in cells if c not in with_frames]
    if no_frames:
        fig.text(0.01, -0.03, _short("No frames: " + "; ".join(
            f"{run.label(c)} ({c.status})" for c in no_frames), 160), fontsize=6, color=style.FAILED_COLOR)
    fig.tight_layout()
    return Figure(f"timeline_{slug(scene)}", f"{scene}: time and error over the animation",
                  "Frame time of every measured frame (top) and FLIP on the metric frames (bottom). "
                  "Triangles: frames with warnings; crosses and dotted lines: the frame a cell failed at; "
                  f"open circles: popping frames, whose FLIP rises above its neighbours' mean by more than "
                  f"{popping_k:g} robust standard deviations (1.4826 MAD) of the cell's jumps.",
                  fig, header, rows)


def _is_number(v) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def sweep_curves(run: Run, scene: str, styles: style.TechniqueStyle) -> List[Figure]:
    """One figure per parameter swept in this scene: median frame time (p5-p95 band) and each quality
    metric against the parameter, one line per technique and combination of its other swept params."""
    cells = run.cells_of(scene)
    figures = []
    by_tech: Dict[str, List[Cell]] = {}
    for c in cells:
        by_tech.setdefault(c.technique, []).append(c)
    swept_by_tech = {t: run.swept_params(cs) for t, cs in by_tech.items()}
    params = list(dict.fromkeys(p for t in by_tech for p in swept_by_tech[t]))
    for p in params:
        metrics = [m for m in QUALITY_METRICS
                   if any(math.isfinite(c.value(f"{m}_mean")) for c in cells if p in c.params)]
        panels = ["time"] + metrics
        fig, axes = style.new_figure(min(style.TEXT_WIDTH_IN, 1.9 * len(panels)), 1.9, 1, len(panels))
        values = [c.params[p] for c in cells if p in c.params]
        numeric = all(_is_number(v) for v in values)
        categories = list(dict.fromkeys(format_param(v) for v in values))

        def xpos(v):
            return float(v) if numeric else float(categories.index(format_param(v)))

        header = ["cell", "technique", "label", "status", p, "wall_ms_median", "wall_ms_p5",
                  "wall_ms_p95"] + [f"{m}_mean" for m in metrics]
        rows = []
        for tech, tcells in by_tech.items():
            if p not in swept_by_tech[tech]:
                continue
            others = [q for q in swept_by_tech[tech] if q != p]
            groups: Dict[tuple, List[Cell]] = {}
            for c in tcells:
                if p in c.params:
                    groups.setdefault(tuple(format_param(c.params.get(q, "")) for q in others), []).append(c)
            for gi, (key, gcells) in enumerate(groups.items()):
                gcells = sorted(gcells, key=lambda c: xpos(c.params[p]))
                name = tech + ("" if not others else " (" + ", ".join(
                    f"{q}={k}" for q, k in zip(others, key)) + ")")
                color, marker, ls = styles.color(tech), styles.marker(tech), style.LINESTYLES[gi % 4]
                ok = [c for c in gcells if c.ok]
                x = np.array([xpos(c.params[p]) for c in ok])
                for k, panel in enumerate(panels):
                    ax = axes[0][k]
                    if panel == "time":
                        y = np.array([c.value("wall_ms_median") for c in ok])
                        lo = np.array([c.value("wall_ms_p5") for c in ok])
                        hi = np.array([c.value("wall_ms_p95") for c in ok])
                        if len(ok) > 1:
                            ax.fill_between(x, lo, hi, color=color, alpha=0.15, lw=0)
                    else:
                        y = np.array([c.value(f"{panel}_mean") for c in ok])
                    ax.plot(x, y, color=color, marker=marker, ls=ls, gid=f"sweep:{p}:{panel}:{name}",
                            label=name if k == 0 else None)
                    for c in gcells:
                        if not c.ok:  # failed settings: a cross on the axis floor at their x
                            ax.plot([xpos(c.params[p])], [0.0], ls="none", marker="X", color=style.FAILED_COLOR,
                                    markersize=6, transform=ax.get_xaxis_transform(), clip_on=False,
                                    gid=f"failed:{c.id}", label="failed" if k == 0 else None)
                for c in gcells:
                    rows.append([c.id, tech, run.label(c), c.status, format_param(c.params[p]),
                                 c.value("wall_ms_median"), c.value("wall_ms_p5"), c.value("wall_ms_p95")]
                                + [c.value(f"{m}_mean") for m in metrics])
        for k, panel in enumerate(panels):
            ax = axes[0][k]
            ax.set_xlabel(p)
            ax.set_ylabel("wall median [ms]" if panel == "time"
                          else measures.metric(panel).label)
            if panel == "time":  # techniques an order of magnitude apart: log time, or the fast ones vanish
                # only the techniques that sweep p are drawn (every technique has, say, a
                # shadow_map_size, but only those that sweep it have a line here)
                times = [c.value("wall_ms_median") for c in cells
                         if c.ok and p in swept_by_tech.get(c.technique, ())]
                times = [t for t in times if math.isfinite(t) and t > 0]
                if times and max(times) / min(times) >= 10:
                    ax.set_yscale("log")
                    ax.yaxis.set_major_formatter(ticker.FormatStrFormatter("%g"))
                    ax.yaxis.set_minor_formatter(ticker.NullFormatter())
            if numeric:
                xs = [float(v) for v in values]
                if min(xs) > 0 and max(xs) / min(xs) >= 10:
                    ax.set_xscale("log")
            else:
                ax.set_xticks(range(len(categories)))
                ax.set_xticklabels(categories, rotation=30, ha="right")
        handles, labels = axes[0][0].get_legend_handles_labels()
        seen = {}
        for h, l in zip(handles, labels):
            seen.setdefault(l, h)
        fig.tight_layout()
        # Below the panels: a sweep can have many lines (technique x other swept parameters), and a legend
        # above them would cover the axes.
        fig.legend(list(seen.values()), list(seen), loc="upper center", ncol=min(3, len(seen)),
                   bbox_to_anchor=(0.5, 0.0), fontsize="small")
        figures.append(Figure(f"sweep_{slug(scene)}_{slug(p)}", f"{scene}: sweep over {p}",
                              f"Median frame time (band: p5-p95) and mean error against {p}. Crosses on "
                              "the axis: settings whose cell failed.", fig, header, rows))
    return figures
