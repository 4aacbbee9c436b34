"""photonbench report RUN_DIR: RUN_DIR/report/index.html plus every figure as SVG, PDF and PNG (and the
numbers behind each figure as CSV), and the summary as CSV and LaTeX tables.

The page is self-contained: inline CSS, no scripts, no external assets; every image is a relative file
under report/, so the folder opens offline, can be zipped as a CI artifact, or served as is. It is
rendered from templates/report.html.j2 with autoescaping (pages.py); this module gathers its values.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import sys
from typing import List, Optional

import pandas as pd

from . import figures as F
from . import images as I
from . import pages, robustness, style, tables
from .rundata import Run, RunError

def _display_width_px(svg_path: str, zoom: float = 1.4) -> Optional[int]:
    """On screen, figures sized for paper (3.4-7 in at 7-8 pt) read small; show them `zoom` times their
    print size, capped by the page width in CSS. The size is the SVG's own width attribute (in pt)."""
    with open(svg_path, encoding="utf-8") as f:
        head = f.read(1200)
    m = re.search(r'<svg[^>]*\swidth="([0-9.]+)pt"', head)
    return int(round(float(m.group(1)) * 96 / 72 * zoom)) if m else None


RUN_INFO_KEYS = [("git_commit", "commit"), ("tool_version", "tool version"), ("device", "device"),
                 ("driver", "driver"), ("cpu", "CPU"), ("os", "OS"), ("start", "start"),
                 ("end", "end"), ("config_hash", "config hash"), ("schema_version", "schema")]


def run_info_view(run: Run) -> List[tuple]:
    """(label, text) of run.json's facts: the known ones first, then anything else the runner
    records (timing fallbacks, flags...) that is not a structure."""
    rows = []
    for key, label in RUN_INFO_KEYS:
        if key in run.info:
            v = run.info[key]
            rows.append((label, json.dumps(v) if isinstance(v, (dict, list)) else str(v)))
    known = dict(RUN_INFO_KEYS)
    rows += [(key, str(v)) for key, v in run.info.items()
             if not (key in known or key == "config" or isinstance(v, (dict, list)))]
    return rows


def config_text(run: Run) -> Optional[str]:
    """The resolved config (run.json's YAML text, or a parsed mapping) as text; None when absent."""
    if "config" not in run.info:
        return None
    config = run.info["config"]
    return config if isinstance(config, str) else json.dumps(config, indent=2)


def status_view(run: Run) -> dict:
    failed = [c for c in run.cells if not c.ok]
    return {
        "cells": len(run.cells), "ok": len(run.cells) - len(failed),
        "failed": [{"scene": c.scene, "label": run.label(c), "reason": c.reason,
                    "frame": "" if c.failed_frame is None else str(c.failed_frame)}
                   for c in failed],
        "warnings": [{"scene": c.scene, "label": run.label(c), "message": w["message"],
                      "frame": "" if w["frame"] is None else str(w["frame"])}
                     for c in run.cells for w in c.warnings]}


def cells_view(run: Run) -> List[dict]:
    """Per-cell resources (memory fields of cell.json) and counter means."""
    out = []
    for c in run.cells:
        res = []
        for k, v in c.json.items():
            if isinstance(v, (int, float)) and not isinstance(v, bool) and "memory" in k:
                res.append(f"{k} = {v / 2**20:.1f} MiB" if "bytes" in k else f"{k} = {v}")
        counters = ", ".join(f"{k} = {v:.6g}" for k, v in c.counter_means().items())
        out.append({"id": c.id, "ok": c.ok, "status": c.status, "resources": "; ".join(res),
                    "counters": counters})
    return out


def _saved(fig: F.Figure, fig_dir: str) -> dict:
    """Writes the figure (SVG, PDF, PNG) and its numbers (CSV); returns what the page shows of it."""
    files = style.save(fig.fig, fig_dir, fig.stem)
    style.close(fig.fig)
    tables.write_csv(os.path.join(fig_dir, fig.stem + ".csv"), pd.DataFrame(fig.rows, columns=fig.header))
    return {"stem": fig.stem, "title": fig.title, "caption": fig.caption, "files": files,
            "shown": files["png"] if fig.kind == "image" else files["svg"],
            "width": _display_width_px(os.path.join(fig_dir, files["svg"]))}


def build(run_dir: str, out_dir: Optional[str] = None, crop: Optional[tuple] = None,
          frame: Optional[int] = None, clock: str = "auto", max_cols: int = 6) -> str:
    """Builds the report; returns the path of index.html. Writes into a temporary folder and swaps it
    in at the end, so a reader never sees half a report."""
    run = Run(run_dir)
    final = os.path.abspath(out_dir or os.path.join(run.path, "report"))
    tmp = final + f".tmp-{os.getpid()}"
    shutil.rmtree(tmp, ignore_errors=True)
    fig_dir, tab_dir = os.path.join(tmp, "figures"), os.path.join(tmp, "tables")
    os.makedirs(fig_dir)
    os.makedirs(tab_dir)
    styles = style.TechniqueStyle(run.techniques())

    tables.write_summary_csv(run, os.path.join(tab_dir, "summary.csv"))
    floor_rows = tables.floor_rows(run)
    tables.write_floors_csv(floor_rows, os.path.join(tab_dir, "floors.csv"))
    with open(os.path.join(tab_dir, "summary.tex"), "w", encoding="utf-8") as f:
        f.write(tables.summary_latex(run))

    sections = []
    for scene in run.scenes():
        figs: List[F.Figure] = []
        for builder in (F.quality_vs_time, F.pass_breakdown):
            fig = builder(run, scene, styles)
            if fig:
                figs.append(fig)
        fig = F.timeline(run, scene, styles, clock=clock)
        if fig:
            figs.append(fig)
        figs += F.sweep_curves(run, scene, styles)
        fig = I.image_grid(run, scene, crop=crop, frame=frame, max_cols=max_cols)
        if fig:
            figs.append(fig)
        shown = [_saved(fig, fig_dir) for fig in figs]
        tex = f"passes_{F.slug(scene)}.tex"
        with open(os.path.join(tab_dir, tex), "w", encoding="utf-8") as f:
            f.write(tables.passes_latex(run, scene))
        sections.append({"name": scene, "slug": F.slug(scene), "figures": shown, "passes_tex": tex})

    # A `photonbench stability` run: its robustness matrix and the cells to look at.
    matrix = robustness.matrix_figure(run.path)
    stability = ({"figure": _saved(matrix, fig_dir), "problems": robustness.problem_rows(run.path)}
                 if matrix else None)

    page = pages.render(
        "report.html.j2", run_name=run.name,
        scenes=[{"name": s, "slug": F.slug(s)} for s in run.scenes()], run_info=run_info_view(run),
        config=config_text(run), status=status_view(run), summary=tables.summary_view(run),
        floors=tables.floors_view(run, floor_rows), sections=sections, cells=cells_view(run),
        clock=clock, stability=stability)
    with open(os.path.join(tmp, "index.html"), "w", encoding="utf-8") as f:
        f.write(page)
    old = final + f".old-{os.getpid()}"
    if os.path.exists(final):
        os.replace(final, old)
    os.replace(tmp, final)
    shutil.rmtree(old, ignore_errors=True)
    return os.path.join(final, "index.html")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="photonbench report",
                                 description="Write RUN_DIR/report/index.html with figures (SVG, PDF, PNG) "
                                             "and tables (CSV, LaTeX) from a run directory.")
    ap.add_argument("run_dir", metavar="RUN_DIR")
    ap.add_argument("--out", metavar="DIR", help="output folder (default RUN_DIR/report)")
    ap.add_argument("--crop", metavar="x,y,w,h",
                    help="zoom region for the image grids, in pixels (or fractions of the image); "
                         "default: the quarter-size window with the most FLIP error")
    ap.add_argument("--frame", type=int, help="frame shown in the image grids (default: the latest "
                                              "frame with reference images)")
    ap.add_argument("--clock", choices=["auto", "gpu", "cpu"], default="auto",
                    help="per-frame times: gpu_ms, cpu_ms, or gpu where present else cpu (default)")
    ap.add_argument("--max-cols", type=int, default=6, help="image grid columns before wrapping")
    a = ap.parse_args(argv)
    try:
        crop = I.parse_crop(a.crop)
        path = build(a.run_dir, a.out, crop=crop, frame=a.frame, clock=a.clock, max_cols=a.max_cols)
    except (RunError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(path)
    return 0
