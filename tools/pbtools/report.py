"""photonbench report RUN_DIR: RUN_DIR/report/index.html plus every figure as SVG, PDF and PNG (and the
numbers behind each figure as CSV), and the summary as CSV and LaTeX tables.

The page is self-contained: inline CSS and one inline script (the image viewer, viewer.py), no external
assets; every image is a relative file under report/ (so are the videos of a run with `video:`,
video.py, encoded on its first report), so the folder opens offline, can be zipped as a CI artifact, or
served as is. It is rendered from templates/report.html.j2 with autoescaping (pages.py); this module
gathers its values.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import re
import shutil
import sys
from typing import List, Optional

import pandas as pd

from . import figures as F
from . import images as I
from . import floors, matching, pages, robustness, seeds, stats, style, tables, verdict, video, viewer
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


LOG_LINES_SHOWN = 4  # of a crashed cell's log, in its failed row (the console shows as many)


def log_end(cell) -> dict:
    """Where a cell that ended without its record (a crash, a kill) left its log, and the log's last
    lines: the assertion or the technique's last words. Empty for a cell that failed in an orderly
    way (its reason says it all)."""
    tail = str(cell.json.get("log_tail") or "")
    lines = [line for line in tail.splitlines() if line.strip()]
    if not lines:
        return {}
    return {"log": os.path.join("logs", cell.id + ".log"), "lines": lines[-LOG_LINES_SHOWN:]}


def status_view(run: Run) -> dict:
    """The cells' outcome: ok, failed (with the reason and, for a crash, the log's end), and for a
    run a signal stopped (run.json: interrupted) the cells it did not run."""
    not_run = [c for c in run.cells if c.status == "not_run"]
    failed = [c for c in run.cells if not c.ok and c.status != "not_run"]
    interrupted = run.info.get("interrupted") or {}
    return {
        "cells": len(run.cells), "ok": len(run.cells) - len(failed) - len(not_run),
        "not_run": len(not_run),
        "interrupted": ({"signal": interrupted.get("signal", "?"), "at": interrupted.get("at", "?"),
                         "resume": f"photonbench run --resume --out {run.path}"}
                        if interrupted else None),
        "failed": [{"scene": c.scene, "label": run.label(c), "reason": c.reason,
                    "frame": "" if c.failed_frame is None else str(c.failed_frame),
                    "log_end": log_end(c)}
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


def _g(v) -> str:
    return "" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.4g}"


def stability_view(run: Run, tab_dir: str, image_dir: str, k: float) -> dict:
    """The temporal and seed stability section (seeds.py); writes its tables as CSV and copies the
    standard deviation images into the report."""
    temporal = seeds.temporal_rows(run, k)
    spread = seeds.spread_rows(run)
    z = seeds.z_tests(run)
    tables.write_csv(os.path.join(tab_dir, "temporal.csv"), pd.DataFrame(
        [{**r, "popping_frames": " ".join(map(str, r["popping_frames"]))} for r in temporal],
        columns=["cell", "scene", "label", "seed", "metric_frames", "flicker", "flicker_floor",
                 "pops", "popping_frames"]))
    if spread:
        tables.write_csv(os.path.join(tab_dir, "seed_spread.csv"), pd.DataFrame(spread))
    z_view = []
    if z:
        tables.write_csv(os.path.join(tab_dir, "z_tests.csv"),
                         pd.DataFrame([{k2: v for k2, v in r.items() if k2 != "stddev_image"}
                                       for r in z]))
        os.makedirs(image_dir, exist_ok=True)
    for r in z:
        image = None
        if r["stddev_image"]:
            name = f"{F.slug(r['group'])}_{r['frame']:04d}_{r['path_class']}.png"
            shutil.copyfile(r["stddev_image"], os.path.join(image_dir, name))
            image = f"{os.path.basename(image_dir)}/{name}"
        verdict = "" if r["equal"] is None else ("equal" if r["equal"] else "differs (biased)")
        z_view.append({**r, "p_value": _g(r["p_value"]), "verdict": verdict, "image": image})
    return {"k": f"{k:g}", "alpha": f"{z[0]['alpha']:g}" if z else "",
            "seeds": max((r["seeds"] for r in spread), default=1),
            "temporal": [{**r, "flicker": _g(r["flicker"]), "flicker_floor": _g(r["flicker_floor"]),
                          "seed": "" if r["seed"] is None else r["seed"],
                          "popping_frames": ", ".join(map(str, r["popping_frames"]))}
                         for r in temporal],
            "pops": sum(r["pops"] for r in temporal),
            "popping_cells": sum(1 for r in temporal if r["pops"]),
            "spread": [{**r, **{m: _g(r[m]) for m in ("mean", "std", "min", "max")}} for r in spread],
            "z": z_view}


def videos_view(run: Run, report_dir: str) -> dict:
    """The run's videos (video.py), encoded first when the run captured frames and has none yet:
    per scene slug, the files copied into report_dir/videos/ and named relative to it; `note` says why
    there are none (no ffmpeg) where frames were captured."""
    if not video.has_captures(run):
        return {"scenes": {}, "note": None}
    manifest = video.load_manifest(run.path)
    if manifest is None:
        try:
            manifest = video.encode_run(run.path, log=lambda text: print(text, file=sys.stderr))
        except video.NoFfmpeg:
            print(f"report: {video.NO_FFMPEG}", file=sys.stderr)
            return {"scenes": {}, "note": video.NO_FFMPEG}
    scenes = {}
    for s in manifest["scenes"]:
        # Copied beside the page, so the report folder stays whole on its own (a CI artifact).
        shutil.copytree(os.path.join(run.path, "videos", s["slug"]),
                        os.path.join(report_dir, "videos", s["slug"]))
        folder = f"videos/{s['slug']}"
        scenes[s["slug"]] = {
            "side_by_side": f"{folder}/{s['side_by_side']}", "frames": s.get("frames"),
            "fps": f"{s.get('fps', 0):g}",
            "cells": [{"label": c["label"], "video": f"{folder}/{c['video']}",
                       "crop": f"{folder}/{c['crop']}", "crop_window": c["crop_window"],
                       "crop_scale": c["crop_scale"],
                       "metrics": f"{folder}/{c['metrics']}" if c.get("metrics") else None}
                      for c in s["cells"]]}
    return {"scenes": scenes, "note": None}


def _saved(fig: F.Figure, fig_dir: str) -> dict:
    """Writes the figure (SVG, PDF, PNG) and its numbers (CSV); returns what the page shows of it."""
    files = style.save(fig.fig, fig_dir, fig.stem)
    style.close(fig.fig)
    tables.write_csv(os.path.join(fig_dir, fig.stem + ".csv"), pd.DataFrame(fig.rows, columns=fig.header))
    return {"stem": fig.stem, "title": fig.title, "caption": fig.caption, "files": files,
            "shown": files["png"] if fig.kind == "image" else files["svg"],
            "width": _display_width_px(os.path.join(fig_dir, files["svg"]))}


def build(run_dir: str, out_dir: Optional[str] = None, crop: Optional[tuple] = None,
          frame: Optional[int] = None, clock: str = "auto", max_cols: int = 6,
          popping_k: float = stats.POPPING_K) -> str:
    """Builds the report; returns the path of index.html. Writes into a temporary folder and swaps it
    in at the end, so a reader never sees half a report."""
    run = Run(run_dir)
    # The harness and the tools share one resolve factor (run.json: the harness's kResolveFactor).
    factor = run.info.get("resolve_factor")
    if isinstance(factor, (int, float)) and factor != floors.RESOLVE_FACTOR:
        print(f"report: warning: {run.path}/run.json's resolve_factor {factor:g} is not the tools' "
              f"{floors.RESOLVE_FACTOR:g} (tools/pbtools/floors.py): scores are read with the "
              "tools'", file=sys.stderr)
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
        fig = F.timeline(run, scene, styles, clock=clock, popping_k=popping_k)
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
    robustness_section = ({"figure": _saved(matrix, fig_dir),
                           "problems": robustness.problem_rows(run.path)} if matrix else None)

    # A match run (`match:`): its equal-time or equal-quality tables and the probes' figures.
    matched = matching.view(run.path, styles)
    if matched:
        shutil.copyfile(os.path.join(run.path, "match.csv"), os.path.join(tab_dir, "match.csv"))
        for s in matched["scenes"]:
            s["figure"] = _saved(s["figure"], fig_dir) if s["figure"] else None

    videos = videos_view(run, tmp)
    viewers = {v["slug"]: v for v in viewer.views(run, tmp)}
    page = pages.render(
        "report.html.j2", run_name=run.name,
        scenes=[{"name": s, "slug": F.slug(s)} for s in run.scenes()], run_info=run_info_view(run),
        config=config_text(run), status=status_view(run), summary=tables.summary_view(run),
        floors=tables.floors_view(run, floor_rows), sections=sections, cells=cells_view(run),
        clock=clock,
        stability=stability_view(run, tab_dir, os.path.join(tmp, "seeds"), popping_k),
        robustness=robustness_section, matching=matched, verdicts=verdict.view(run),
        verdict_alpha=stats.ALPHA, videos=videos, viewers=viewers)
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
    ap.add_argument("--popping-k", type=float, default=stats.POPPING_K,
                    help="a metric frame pops when its FLIP rises above its neighbours' by more than "
                         "K robust standard deviations (default %(default)g)")
    a = ap.parse_args(argv)
    try:
        crop = I.parse_crop(a.crop)
        if not a.popping_k > 0:
            raise ValueError(f"--popping-k {a.popping_k:g}: expected a number above 0")
        path = build(a.run_dir, a.out, crop=crop, frame=a.frame, clock=a.clock, max_cols=a.max_cols,
                     popping_k=a.popping_k)
    except (RunError, ValueError) as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    print(path)
    return 0
