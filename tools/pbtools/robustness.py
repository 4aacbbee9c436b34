"""The robustness matrix of a `photonbench stability` run: technique x scenario, each cell coloured by
its class (ok, degraded, failed; unrated and skipped in grey) with the reason written in it, from
RUN_DIR/stability.csv (harness/src/run/stability.h writes it and gives the rules)."""

from __future__ import annotations

import math
import os
import textwrap
from typing import Dict, List, Optional, Tuple

import pandas as pd
from matplotlib.colors import ListedColormap

from . import style
from .figures import Figure

# Worst first: a (scenario, technique) square with several cells (a swept parameter) shows its worst.
CLASSES = ["failed", "degraded", "unrated", "ok", "skipped"]
COLOURS = {"failed": "#D55E00", "degraded": "#E69F00", "unrated": "#BBBBBB", "ok": "#009E73",
           "skipped": "#F2F2F2"}


def read(run_dir: str) -> Optional[pd.DataFrame]:
    """stability.csv as text columns (empty fields stay empty strings), or None when the run has none."""
    path = os.path.join(run_dir, "stability.csv")
    if not os.path.exists(path):
        return None
    table = pd.read_csv(path, dtype=str, keep_default_na=False)
    unknown = sorted(set(table["class"]) - set(CLASSES))
    if unknown:
        raise ValueError(f"{path}: unknown class {unknown[0]!r} (expected one of {', '.join(CLASSES)})")
    return table


def worst_cells(table: pd.DataFrame) -> Tuple[List[str], List[str], Dict[Tuple[str, str], dict]]:
    """Scenarios and techniques in file order, and per (scenario, technique) the row of its worst
    class (the first such row)."""
    scenarios = list(dict.fromkeys(table["scenario"]))
    techniques = list(dict.fromkeys(table["technique"]))
    worst: Dict[Tuple[str, str], dict] = {}
    for row in table.to_dict("records"):
        key = (row["scenario"], row["technique"])
        if key not in worst or CLASSES.index(row["class"]) < CLASSES.index(worst[key]["class"]):
            worst[key] = row
    return scenarios, techniques, worst


def short_reason(row: dict, width: int = 22) -> str:
    """What fits in a square: the ratio to the baseline where there is one, else the reason cut to
    two lines."""
    ratio = row.get("ratio", "")
    if ratio and row["class"] in ("ok", "degraded") and math.isfinite(float(ratio)):
        return f"{float(ratio):.2f}x baseline"
    lines = textwrap.wrap(row.get("reason", ""), width) or [""]
    if len(lines) > 2:
        lines = lines[:2]
        lines[1] = lines[1][: width - 1] + "\u2026"
    return "\n".join(lines)


def matrix_figure(run_dir: str) -> Optional[Figure]:
    table = read(run_dir)
    if table is None or table.empty:
        return None
    scenarios, techniques, worst = worst_cells(table)
    fig, axes = style.new_figure(1.8 + 1.75 * len(techniques), 0.8 + 0.48 * len(scenarios))
    ax = axes[0][0]
    grid = [[CLASSES.index(worst[(s, t)]["class"]) if (s, t) in worst else CLASSES.index("skipped")
             for t in techniques] for s in scenarios]
    ax.imshow(grid, cmap=ListedColormap([COLOURS[c] for c in CLASSES]), vmin=-0.5,
              vmax=len(CLASSES) - 0.5, aspect="auto")
    for i, s in enumerate(scenarios):
        for j, t in enumerate(techniques):
            row = worst.get((s, t))
            text = f"{row['class']}\n{short_reason(row)}" if row else "-"
            dark = row is not None and row["class"] in ("failed", "ok")
            ax.text(j, i, text, ha="center", va="center", fontsize=5.5,
                    color="white" if dark else "black")
    ax.set_xticks(range(len(techniques)), techniques)
    ax.set_yticks(range(len(scenarios)), scenarios)
    ax.xaxis.tick_top()
    ax.tick_params(length=0)
    ax.grid(False)
    for spine in ax.spines.values():
        spine.set_visible(False)
    header = ["scenario", "technique", "class", "reason", "flip", "baseline_flip", "ratio", "cell"]
    rows = [[r.get(h, "") for h in header] for r in table.to_dict("records")]
    counts = table["class"].value_counts()
    caption = ("Every technique through every stress scenario (configs/stress/). Each square is the "
               "worst class of its cells: failed (crash, time-out, NaN/Inf, validation error, a "
               "warning during a frame such as an overflow), degraded (FLIP beyond the stated factor "
               "of the same technique's FLIP on the scenario's baseline, and resolved from the "
               "reference's noise), ok, unrated (no score, or its baseline failed), skipped (a "
               "technique not built). Counts: " +
               ", ".join(f"{counts.get(c, 0)} {c}" for c in CLASSES) + ".")
    return Figure("robustness", "Robustness matrix", caption, fig, header, rows)


def problem_rows(run_dir: str) -> List[dict]:
    """The cells a reader must look at (failed, degraded, unrated), with their full reasons."""
    table = read(run_dir)
    if table is None:
        return []
    keep = table[table["class"].isin(["failed", "degraded", "unrated"])]
    return [{"scenario": r["scenario"], "technique": r["technique"], "class": r["class"],
             "reason": r["reason"], "aims_at": r["aims_at"]} for r in keep.to_dict("records")]
