"""photonbench report RUN_DIR: RUN_DIR/report/index.html plus every figure as SVG, PDF and PNG (and the
numbers behind each figure as CSV), and the summary as CSV and LaTeX tables.

The page is self-contained: inline CSS, no scripts, no external assets; every image is a relative file
under report/, so the folder opens offline, can be zipped as a CI artifact, or served as is.
"""

from __future__ import annotations

import argparse
import csv
import html
import json
import math
import os
import shutil
import sys
from typing import List, Optional

from . import figures as F
from . import images as I
from . import style, tables
from .rundata import Run, RunError

CSS = """
body{font:14px/1.45 system-ui,-apple-system,"DejaVu Sans",sans-serif;margin:0 auto;max-width:1180px;
padding:1em 2em;color:#1a1a1a}
h1{font-size:1.5em;margin-bottom:.2em}h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:1.8em}
h3{margin-bottom:.3em}
table{border-collapse:collapse;font-size:12.5px;margin:.5em 0}
th,td{padding:2px 8px;border-bottom:1px solid #e3e3e3;text-align:left;vertical-align:top}
th{border-bottom:1.5px solid #555}td.num{text-align:right;font-variant-numeric:tabular-nums}
tr.failed td{background:#fff1f0}td.failed{color:#b00000;font-weight:bold}td.ok{color:#1b6e20}
td.unresolved{background:#eeeeee;color:#666}
figure{margin:1em 0 1.6em 0}figure img{max-width:100%;height:auto;border:0}
figcaption{font-size:12.5px;color:#444;max-width:60em}figcaption a{margin-right:.6em}
.muted{color:#666}.bad{color:#b00000}.warn{color:#8a5a00}
pre{background:#f6f6f6;padding:.6em;overflow:auto;font-size:12px}
nav a{margin-right:1em}
"""


def _write_table_csv(path: str, header: List[str], rows: List[list]) -> None:
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(header)
        for r in rows:
            w.writerow(["" if isinstance(v, float) and not math.isfinite(v) else
                        (f"{v:.6g}" if isinstance(v, float) else v) for v in r])


def _display_width_px(svg_path: str, zoom: float = 1.4) -> Optional[int]:
    """On screen, figures sized for paper (3.4-7 in at 7-8 pt) read small; show them `zoom` times their
    print size, capped by the page width in CSS. The size is the SVG's own width attribute (in pt)."""
    import re
    with open(svg_path, encoding="utf-8") as f:
        head = f.read(1200)
    m = re.search(r'<svg[^>]*\swidth="([0-9.]+)pt"', head)
    return int(round(float(m.group(1)) * 96 / 72 * zoom)) if m else None


def _figure_html(fig: F.Figure, files: dict, fig_dir: str) -> str:
    shown = files["png"] if fig.kind == "image" else files["svg"]
    width = _display_width_px(os.path.join(fig_dir, files["svg"]))
    size = f' style="width:{width}px"' if width else ""
    links = " ".join(f'<a href="figures/{html.escape(files[e])}">{e.upper()}</a>' for e in ("svg", "pdf", "png"))
    links += f' <a href="figures/{html.escape(fig.stem)}.csv">data (CSV)</a>'
    return (f'<figure id="{html.escape(fig.stem)}"><img src="figures/{html.escape(shown)}" '
            f'alt="{html.escape(fig.title)}"{size}>'
            f"<figcaption><b>{html.escape(fig.title)}.</b> {html.escape(fig.caption)}<br>{links}"
            "</figcaption></figure>")


def _run_info_html(run: Run) -> str:
    keys = [("git_commit", "commit"), ("tool_version", "tool version"), ("device", "device"),
            ("driver", "driver"), ("cpu", "CPU"), ("os", "OS"), ("start", "start"), ("end", "end"),
            ("config_hash", "config hash"), ("schema_version", "schema")]
    rows = []
    for key, label in keys:
        if key in run.info:
            v = run.info[key]
            v = json.dumps(v) if isinstance(v, (dict, list)) else str(v)
            rows.append(f"<tr><th>{html.escape(label)}</th><td>{html.escape(v)}</td></tr>")
    for key, v in run.info.items():  # anything else the runner records (timing fallbacks, flags...)
        if key in dict(keys) or key == "config" or isinstance(v, (dict, list)):
            continue
        rows.append(f"<tr><th>{html.escape(key)}</th><td>{html.escape(str(v))}</td></tr>")
    out = "<table>" + "".join(rows) + "</table>"
    if "config" in run.info:
        config = run.info["config"]  # the resolved config: YAML text, or a parsed mapping
        text = config if isinstance(config, str) else json.dumps(config, indent=2)
        out += ("<details><summary>resolved config</summary><pre>" + html.escape(text) + "</pre></details>")
    return out


def _status_html(run: Run) -> str:
    ok = [c for c in run.cells if c.ok]
    failed = [c for c in run.cells if not c.ok]
    out = [f"<p>{len(run.cells)} cells: {len(ok)} ok, "
           f'<span class="{"bad" if failed else "muted"}">{len(failed)} failed</span>.</p>']
    if failed:
        out.append("<h3>Failed cells</h3><table><tr><th>scene</th><th>cell</th><th>frame</th><th>reason</th></tr>")
        for c in failed:
            ff = "" if c.failed_frame is None else str(c.failed_frame)
            out.append(f"<tr class=\"failed\"><td>{html.escape(c.scene)}</td><td>{html.escape(run.label(c))}"
                       f"</td><td class=\"num\">{ff}</td><td>{html.escape(c.reason)}</td></tr>")
        out.append("</table>")
    warned = [(c, w) for c in run.cells for w in c.warnings]
    if warned:
        out.append("<h3>Warnings</h3><table><tr><th>scene</th><th>cell</th><th>frame</th><th>message</th></tr>")
        for c, w in warned:
            f = "" if w["frame"] is None else str(w["frame"])
            out.append(f"<tr><td>{html.escape(c.scene)}</td><td>{html.escape(run.label(c))}</td>"
                       f"<td class=\"num\">{f}</td><td class=\"warn\">{html.escape(w['message'])}</td></tr>")
        out.append("</table>")
    return "\n".join(out)


def _cells_html(run: Run) -> str:
    """Per-cell resources (memory fields of cell.json) and counter means."""
    out = ["<table><tr><th>cell</th><th>status</th><th>resources</th><th>counters (mean per frame)</th></tr>"]
    for c in run.cells:
        res = []
        for k, v in c.json.items():
            if isinstance(v, (int, float)) and not isinstance(v, bool) and "memory" in k:
                res.append(f"{k} = {v / 2**20:.1f} MiB" if "bytes" in k else f"{k} = {v}")
        sums = {}
        for r in c.counters_rows:
            try:
                sums.setdefault(r["name"], []).append(float(r["value"]))
            except (KeyError, ValueError):
                pass
        counters = ", ".join(f"{k} = {sum(v) / len(v):.6g}" for k, v in sums.items())
        out.append(f"<tr><td>{html.escape(c.id)}</td><td class=\"{'ok' if c.ok else 'failed'}\">"
                   f"{html.escape(c.status)}</td><td>{html.escape('; '.join(res))}</td>"
                   f"<td>{html.escape(counters)}</td></tr>")
    out.append("</table>")
    return "\n".join(out)


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
        parts = [f'<h2 id="scene-{html.escape(F.slug(scene))}">Scene: {html.escape(scene)}</h2>']
        for fig in figs:
            files = style.save(fig.fig, fig_dir, fig.stem)
            style.close(fig.fig)
            _write_table_csv(os.path.join(fig_dir, fig.stem + ".csv"), fig.header, fig.rows)
            parts.append(_figure_html(fig, files, fig_dir))
        tex = f"passes_{F.slug(scene)}.tex"
        with open(os.path.join(tab_dir, tex), "w", encoding="utf-8") as f:
            f.write(tables.passes_latex(run, scene))
        parts.append(f'<p>Per-pass table: <a href="tables/{html.escape(tex)}">LaTeX</a>.</p>')
        sections.append("\n".join(parts))

    nav = " ".join(f'<a href="#scene-{html.escape(F.slug(s))}">{html.escape(s)}</a>' for s in run.scenes())
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>photonbench report: {html.escape(run.name)}</title>
<style>{CSS}</style></head>
<body>
<h1>photonbench report: {html.escape(run.name)}</h1>
<nav>{nav} <a href="#summary">summary</a> <a href="#floors">noise floors</a> <a href="#cells">cells</a></nav>
<h2>Run</h2>
{_run_info_html(run)}
{_status_html(run)}
<h2 id="summary">Summary</h2>
<p>Median, p5 and p95 over the measured frames (warm-up excluded); metric means over the metric frames.
Bold: best successful value in the scene. Floors: what the true image scores against the reference
(its noise alone); * and grey: within {tables.floors.RESOLVE_FACTOR:g}x the floor, unresolved (see
<a href="#floors">noise floors</a>). Tables: <a href="tables/summary.csv">CSV</a>,
<a href="tables/summary.tex">LaTeX (booktabs)</a>. Source: <code>summary.csv</code>.</p>
{tables.summary_html(run)}
<h2 id="floors">Noise floors</h2>
{tables.floors_html(run, floor_rows)}
{"".join(sections)}
<h2 id="cells">Cells</h2>
{_cells_html(run)}
<p class="muted">Figures: matplotlib, Okabe-Ito palette, techniques by colour and marker. Times are GPU
timestamps where a pass has them, else CPU clock ({html.escape(clock)}).</p>
</body></html>
"""
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
