"""photonbench history: a performance history across commits, and its trend plots.

  history append RUN_DIR [--file F] [--label L]
                                           add the run's summary to F (JSON Lines, one run per line),
                                           keyed by (key, device): the key is --label when given (what
                                           the user changed: "radius 0.05", "my-plugin v2"), else
                                           photonbench's commit and a digest of the run's plugin
                                           builds (run.json "plugins": each technique's module path,
                                           byte hash and API version), so a rebuilt plugin is a new
                                           entry; appending the same key again replaces that entry
                                           in place. Each cell's entry holds its plugin's record.
  history append RUN_DIR RUN_DIR...         replicate runs of one build (interleaved with other work):
                                           one entry, each median the median of the runs' medians
  history plot [--file F] [--out DIR]      one figure per device and cell: median frame time and each
                                           pass's median over the history, each with its noise band,
                                           change points and environment changes marked
  history list [--file F]                  one line per entry, per device; an entry whose machine,
                                           driver or build type differs from the previous one's is
                                           marked with what changed

Environment changes: each entry records its run's machine (CPU model and count, llvmpipe's vector
width), Vulkan driver (Mesa version) and build type (pbtools/environment.py; a field the run does not
record is left out and never counts as a change). An entry whose environment differs from the previous
entry's on the same device is marked: a dashed grey line before it in every plot with what changed
(gid "environment:<index>"), a "!" line in `history list` and in `plot`'s output, and a row of
environment.csv. A step there is the machine's, not the code's; change points are still searched across
it (a change point at a marked entry says which of the two it most likely is).

Noise bands: each entry records, per cell, the spread its medians sit in. With replicate runs it is the
p5-p95 of the runs' medians (`band: runs`: the run-to-run noise, which on a shared machine is the larger
one: tools/README.md); with one run, the p5-p95 of that run's measured frames (`band: frames`; entries
appended before bands existed have it for the frame time only, from summary.csv's wall_ms_p5/p95). The
plot shades each series' band and rings a point whose band does not overlap the previous entry's: a
change larger than the noise both builds were measured in (bands.csv lists every band). A band of few
replicates is narrow (p5-p95 of 3 values is nearly their range), so use 5 or more (tools/README.md:
compare's replicate runs).

Change points (binary segmentation, robust): on the log of a series (so shifts are relative),
  1. estimate the series' noise sigma from successive differences (1.4826 * MAD / sqrt 2), which a
     level shift does not inflate;
  2. find the split that most reduces the sum of absolute deviations from the segment medians, each
     side at least MIN_SIZE points long;
  3. accept it when the medians differ by at least MIN_SHIFT (relative) AND by at least
     K * sigma * sqrt(1/n1 + 1/n2) (a z-like test of two segment levels); then recurse into both sides.
MIN_SIZE = 2 keeps one outlying run from being called a change; the newest commit alone is judged by
`photonbench compare`, not here. Defaults MIN_SHIFT = 8%, K = 3 (options --min-shift, --k): on simulated
12-run histories with 3% run-to-run noise, 0.1% of unchanged series get a false change point and a 15% step
is found in 96% (tools/tests/test_history.py checks the detection and the no-change case).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import sys
from typing import Dict, List, Optional, Tuple

import numpy as np

import pandas as pd

from . import environment, measures, pages, style, tables
from .figures import slug
from .rundata import Run, RunError, current_name

DEFAULT_FILE = os.path.join("results", "history.jsonl")
MIN_SIZE = 2
MIN_SHIFT = 0.08  # with K = 3: 0.1% of 12-run series of 3%-noise flagged, a 15% step found 96%
K = 3.0


# ---- data ------------------------------------------------------------------------------------------
def plugins_digest(run: Run) -> str:
    """8 hex digits of the run's plugin builds (run.json "plugins": each technique's byte hash);
    "" for a run that does not record them."""
    plugins = run.info.get("plugins") or {}
    if not plugins:
        return ""
    text = ";".join(f"{name}={(p or {}).get('fnv1a64', '')}" for name, p in sorted(plugins.items()))
    return hashlib.sha256(text.encode()).hexdigest()[:8]


def entry_key(entry: dict) -> str:
    """What an entry is keyed by (with its device): its label; entries from before labels, their
    commit."""
    return str(entry.get("label") or entry.get("commit"))


BAND_PERCENTILES = (5, 95)


def _band(values) -> Optional[List[float]]:
    v = np.array([x for x in values if x is not None and math.isfinite(x)], dtype=float)
    if len(v) < 2:
        return None
    return [float(np.percentile(v, BAND_PERCENTILES[0])), float(np.percentile(v, BAND_PERCENTILES[1]))]


def _cell_entry(run: Run, c, plugins: dict) -> dict:
    def v(col):
        x = c.value(col)
        return x if math.isfinite(x) else None
    passes = c.pass_medians()
    wall_band = [v("wall_ms_p5"), v("wall_ms_p95")]
    return {
        "scene": c.scene, "technique": c.technique, "label": run.label(c), "status": c.status,
        "frames": v("frames"), "wall_ms_median": v("wall_ms_median"), "wall_ms_p5": v("wall_ms_p5"),
        "wall_ms_p95": v("wall_ms_p95"), "flip_mean": v("flip_mean"), "ssim_mean": v("ssim_mean"),
        "psnr_mean": v("psnr_mean"), "passes": passes,
        "plugin": plugins.get(c.technique),
        # The spread of one run: its measured frames (the per-frame samples of each pass).
        "band": "frames", "replicates": 1,
        "wall_ms_band": wall_band if None not in wall_band else None,
        "passes_band": {name: b for name in passes
                        for b in [_band(c.pass_samples(name)[1])] if b is not None},
    }


def _pooled(cells: List[dict]) -> dict:
    """One cell's entry from replicate runs: medians of the runs' medians, bands the p5-p95 across
    the runs (the run-to-run noise)."""
    ok = [c for c in cells if c["status"] == "ok"]
    if not ok:
        return cells[0]
    out = dict(ok[0])

    def median(values):
        v = [x for x in values if x is not None]
        return float(np.median(v)) if v else None
    for key in ("wall_ms_median", "flip_mean", "ssim_mean", "psnr_mean"):
        out[key] = median([c.get(key) for c in ok])
    names = list(dict.fromkeys(n for c in ok for n in c["passes"]))
    out["passes"] = {n: median([c["passes"].get(n) for c in ok]) for n in names}
    out["band"], out["replicates"] = "runs", len(ok)
    out["wall_ms_runs"] = [c.get("wall_ms_median") for c in ok]
    out["wall_ms_band"] = _band(out["wall_ms_runs"])
    out["passes_band"] = {n: b for n in names for b in [_band([c["passes"].get(n) for c in ok])]
                          if b is not None}
    return out


def entry_of(run: Run, label: Optional[str] = None, replicates: Optional[List[Run]] = None) -> dict:
    """The history entry of `run`, or of `run` and its `replicates` (runs of the same build, config
    and device) pooled."""
    runs = [run] + list(replicates or [])
    for other in runs[1:]:
        for what, a, b in (("device", run.device, other.device), ("commit", run.commit, other.commit),
                           ("config hash", run.info.get("config_hash"), other.info.get("config_hash"))):
            if a != b:
                raise RunError(f"{other.path}: its {what} {b} is not {run.path}'s {a}: replicates are "
                               "runs of one build and config on one device")
    plugins = run.info.get("plugins") or {}
    per_run = [{c.id: _cell_entry(r, c, plugins) for c in r.cells} for r in runs]
    cells = {}
    for cell_id in per_run[0]:
        found = [p[cell_id] for p in per_run if cell_id in p]
        cells[cell_id] = found[0] if len(runs) == 1 else _pooled(found)
    digest = plugins_digest(run)
    key = label or (f"{run.commit[:12]}+plugins:{digest}" if digest else run.commit)
    return {"label": key, "commit": run.commit, "device": run.device, "run": run.name,
            "runs": [r.name for r in runs],
            "start": run.info.get("start"),
            "end": run.info.get("end"), "tool_version": run.info.get("tool_version"),
            "config_hash": run.info.get("config_hash"), "environment": environment.of(run.info),
            "cells": cells}


def load(path: str) -> List[dict]:
    if not os.path.isfile(path):
        return []
    out = []
    with open(path, encoding="utf-8") as f:
        for n, line in enumerate(f, 1):
            line = line.strip()
            if not line:
                continue
            try:
                entry = json.loads(line)
            except json.JSONDecodeError as e:
                raise RunError(f"{path}:{n}:{e.colno}: {e.msg}") from e
            # An entry appended before the frame time's keys named their clock (frame_ms_median)
            # reads under the current names.
            for cell in entry.get("cells", {}).values():
                for old in [k for k in cell if current_name(k) != k and current_name(k) not in cell]:
                    cell[current_name(old)] = cell.pop(old)
            out.append(entry)
    return out


def append(run_dir, path: str, label: Optional[str] = None) -> Tuple[dict, bool]:
    """Adds the run (or the replicate runs, a list of folders, as one entry); returns (entry,
    replaced) where replaced says an entry with the same key (entry_key) and device was overwritten
    in place."""
    dirs = [run_dir] if isinstance(run_dir, str) else list(run_dir)
    runs = [Run(d) for d in dirs]
    entry = entry_of(runs[0], label, runs[1:])
    entries = load(path)
    replaced = False
    for i, e in enumerate(entries):
        if entry_key(e) == entry_key(entry) and e.get("device") == entry["device"]:
            entries[i] = entry
            replaced = True
            break
    if not replaced:
        entries.append(entry)
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        for e in entries:
            f.write(json.dumps(e) + "\n")
    os.replace(tmp, path)
    return entry, replaced


# ---- change points ---------------------------------------------------------------------------------
def _noise(x: np.ndarray) -> float:
    """The series' noise (measures.successive_difference_sigma); 0 when too short to tell."""
    sigma = measures.successive_difference_sigma(x)
    return sigma if math.isfinite(sigma) else 0.0


def _sad(x: np.ndarray) -> float:
    return float(np.sum(np.abs(x - np.median(x)))) if len(x) else 0.0


def change_points(values, min_size: int = MIN_SIZE, min_shift: float = MIN_SHIFT, k: float = K) -> List[int]:
    """Indices i (into `values`) where a new level starts. NaN/None and non-positive values are skipped
    (a failed run leaves a gap) and indices refer to the original positions."""
    vals = np.array([np.nan if v is None else float(v) for v in values], dtype=float)
    valid = np.nonzero(np.isfinite(vals) & (vals > 0))[0]
    x = np.log(vals[valid])
    sigma = _noise(x)
    found: List[int] = []

    def split(lo: int, hi: int) -> None:
        if hi - lo < 2 * min_size:
            return
        total = _sad(x[lo:hi])
        best, best_s = 0.0, None
        for s in range(lo + min_size, hi - min_size + 1):
            gain = total - _sad(x[lo:s]) - _sad(x[s:hi])
            if gain > best + 1e-12:
                best, best_s = gain, s
        if best_s is None:
            return
        left, right = x[lo:best_s], x[best_s:hi]
        shift = abs(float(np.median(right) - np.median(left)))
        se = sigma * math.sqrt(1.0 / len(left) + 1.0 / len(right))
        if shift >= math.log1p(min_shift) and shift >= k * se:
            found.append(best_s)
            split(lo, best_s)
            split(best_s, hi)

    split(0, len(x))
    return sorted(int(valid[i]) for i in found)


# ---- environment changes ---------------------------------------------------------------------------
def environment_changes(entries: List[dict]) -> Dict[int, List[Tuple[str, str, str]]]:
    """index -> (field, previous value, value) for each entry whose recorded environment differs from
    the previous entry's (entries of one device, in order)."""
    out = {}
    for i in range(1, len(entries)):
        d = environment.differences(entries[i - 1].get("environment"), entries[i].get("environment"))
        if d:
            out[i] = d
    return out


def _entry_name(e: dict) -> str:
    return e["label"] if e.get("label") and e["label"] != e.get("commit") else str(e.get("commit", ""))[:8]


def listing(entries: List[dict]) -> List[str]:
    """`history list`'s lines: per device, one line per entry, and a "!" line before an entry whose
    environment changed."""
    out = []
    for device in dict.fromkeys(e["device"] for e in entries):
        dev = [e for e in entries if e["device"] == device]
        changes = environment_changes(dev)
        out.append(f"{device}: {len(dev)} entries")
        for i, e in enumerate(dev):
            if i in changes:
                out.append(f"  ! environment changed before entry {i}: {environment.describe(changes[i])}")
            env = e.get("environment") or {}
            recorded = ", ".join(f"{k} {env[k]}" for k in environment.FIELDS if env.get(k))
            out.append(f"  {i:3d} {_entry_name(e)}  {e.get('start') or ''}  {len(e['cells'])} cells"
                       + (f"  [{recorded}]" if recorded else ""))
    return out


# ---- plots -----------------------------------------------------------------------------------------
def series_of(entries: List[dict], cell: str) -> Dict[str, List[Optional[float]]]:
    """name -> values over entries ("frame" then passes in first-seen order); None where absent/failed."""
    names = ["frame"]
    for e in entries:
        c = e["cells"].get(cell)
        if c:
            for p in c.get("passes", {}):
                if p not in names:
                    names.append(p)
    out = {n: [] for n in names}
    for e in entries:
        c = e["cells"].get(cell)
        ok = c is not None and c.get("status") == "ok"
        for n in names:
            if not ok:
                out[n].append(None)
            elif n == "frame":
                out[n].append(c.get("wall_ms_median"))
            else:
                out[n].append(c.get("passes", {}).get(n))
    return out


def bands_of(entries: List[dict], cell: str, names) -> Dict[str, Tuple[np.ndarray, np.ndarray]]:
    """name -> (lo, hi) over entries: each entry's noise band of that series (NaN where it has none)."""
    out = {}
    for n in names:
        lo, hi = [], []
        for e in entries:
            c = e["cells"].get(cell)
            band = None
            if c is not None and c.get("status") == "ok":
                if n == "frame":
                    band = c.get("wall_ms_band")
                    if band is None and c.get("wall_ms_p5") is not None and c.get("wall_ms_p95") is not None:
                        band = [c["wall_ms_p5"], c["wall_ms_p95"]]
                else:
                    band = (c.get("passes_band") or {}).get(n)
            lo.append(np.nan if band is None else float(band[0]))
            hi.append(np.nan if band is None else float(band[1]))
        out[n] = (np.array(lo), np.array(hi))
    return out


def outside_previous_band(y: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> List[int]:
    """Indices i whose band does not overlap entry i-1's (the two levels are apart by more than
    either's noise); where entry i has no band of its own, whose median lies outside i-1's band."""
    out = []
    for i in range(1, len(y)):
        if not (np.isfinite(y[i]) and np.isfinite(lo[i - 1]) and np.isfinite(hi[i - 1])):
            continue
        own_lo, own_hi = (lo[i], hi[i]) if np.isfinite(lo[i]) and np.isfinite(hi[i]) else (y[i], y[i])
        if own_lo > hi[i - 1] or own_hi < lo[i - 1]:
            out.append(i)
    return out


def plot(path: str, out_dir: str, min_shift: float = MIN_SHIFT, k: float = K) -> List[str]:
    entries = load(path)
    if not entries:
        raise RunError(f"{path}: no history (run `photonbench history append RUN_DIR` first)")
    os.makedirs(out_dir, exist_ok=True)
    devices = list(dict.fromkeys(e["device"] for e in entries))
    written, cp_rows, band_rows, env_rows = [], [], [], []
    sections = []  # one per device, for templates/history.html.j2
    for device in devices:
        dev_entries = [e for e in entries if e["device"] == device]
        commits = [_entry_name(e) for e in dev_entries]
        env_changes = environment_changes(dev_entries)
        for i, diffs in env_changes.items():
            for what, before, after in diffs:
                env_rows.append([device, i, dev_entries[i].get("label"), what, before, after])
        cells = list(dict.fromkeys(c for e in dev_entries for c in e["cells"]))
        section = {"name": device, "runs": len(dev_entries), "figures": []}
        sections.append(section)
        for cell in cells:
            info = next(e["cells"][cell] for e in dev_entries if cell in e["cells"])
            series = series_of(dev_entries, cell)
            x = np.arange(len(dev_entries))
            fig, axes = style.new_figure(style.TEXT_WIDTH_IN * 0.75, 2.4)
            ax = axes[0][0]
            colors = style.pass_colors([n for n in series if n != "frame"])
            bands = bands_of(dev_entries, cell, series)
            for name, vals in series.items():
                y = np.array([np.nan if v is None else v for v in vals], dtype=float)
                color = "#000000" if name == "frame" else colors[name]
                lw = 1.4 if name == "frame" else 0.9
                ax.plot(x, y, color=color, lw=lw, marker="o", markersize=2.5, label=name, gid=f"trend:{name}")
                lo, hi = bands[name]
                if np.isfinite(lo).any():
                    ax.fill_between(x, lo, hi, color=color, alpha=0.15, lw=0, gid=f"band:{name}")
                outside = outside_previous_band(y, lo, hi)
                if outside:
                    ax.plot(x[outside], y[outside], ls="none", marker="o", markersize=6, mfc="none",
                            mec=color, mew=0.8, zorder=6, gid=f"outside:{name}")
                for i, e in enumerate(dev_entries):
                    c = e["cells"].get(cell) or {}
                    band_rows.append([device, cell, name, i, e.get("label"), y[i], lo[i], hi[i],
                                      c.get("band", "frames") if np.isfinite(lo[i]) else "",
                                      c.get("replicates", 1), int(i in outside)])
                for i in change_points(vals, min_shift=min_shift, k=k):
                    before = np.nanmedian(y[:i][np.isfinite(y[:i])][-MIN_SIZE * 2:]) if i > 0 else np.nan
                    after = np.nanmedian(y[i:][np.isfinite(y[i:])][:MIN_SIZE * 2])
                    ax.axvline(i - 0.5, color=color, lw=0.6, ls=":", alpha=0.8)
                    ax.plot([i], [y[i]], ls="none", marker="v", markersize=6, color=color,
                            markeredgecolor="black", markeredgewidth=0.4, zorder=5, gid=f"change:{name}:{i}")
                    cp_rows.append([device, cell, name, i, dev_entries[i]["commit"], before, after,
                                    (after / before - 1) * 100 if before else math.nan])
            for i, diffs in env_changes.items():
                ax.axvline(i - 0.5, color="#777777", lw=0.8, ls="--", zorder=1, gid=f"environment:{i}")
                ax.annotate(" / ".join(what for what, _, _ in diffs), (i - 0.5, 1.0),
                            xycoords=("data", "axes fraction"), rotation=90, ha="right", va="top",
                            fontsize=5, color="#555555")
            ax.set_xticks(x)
            ax.set_xticklabels(commits, rotation=60, ha="right", fontsize=5)
            ax.set_xlabel("history entry: --label, or commit and plugin builds")
            ax.set_ylabel("median [ms]: frame wall clock;\npasses max(GPU, CPU)", fontsize=6)
            ax.set_title(f"{info.get('scene', '')} / {info.get('label', cell)}", fontsize=7)
            ax.plot([], [], ls="none", marker="v", color="#777777", markeredgecolor="black",
                    markeredgewidth=0.4, label="change point")
            ax.fill_between([], [], [], color="#777777", alpha=0.15, lw=0, label="noise band (p5-p95)")
            ax.plot([], [], ls="none", marker="o", markersize=6, mfc="none", mec="#777777",
                    label="band apart from the previous one")
            if env_changes:
                ax.plot([], [], color="#777777", lw=0.8, ls="--", label="machine, driver or build changed")
            ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0))
            fig.tight_layout()
            stem = f"history_{slug(device)}_{slug(cell)}"
            files = style.save(fig, out_dir, stem)
            style.close(fig)
            written.append(os.path.join(out_dir, files["svg"]))
            section["figures"].append({"cell": cell, **files})
    tables.write_csv(os.path.join(out_dir, "changepoints.csv"), pd.DataFrame(cp_rows, columns=[
        "device", "cell", "series", "index", "commit", "before_ms", "after_ms", "change_pct"]))
    tables.write_csv(os.path.join(out_dir, "bands.csv"), pd.DataFrame(band_rows, columns=[
        "device", "cell", "series", "index", "label", "median_ms", "band_lo_ms", "band_hi_ms", "band",
        "replicates", "outside_previous"]))
    tables.write_csv(os.path.join(out_dir, "environment.csv"), pd.DataFrame(env_rows, columns=[
        "device", "index", "label", "changed", "before", "after"]))
    with open(os.path.join(out_dir, "index.html"), "w", encoding="utf-8") as f:
        f.write(pages.render("history.html.j2", source=os.path.abspath(path), devices=sections))
    return written


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="photonbench history",
                                 description="Keep a performance history across commits and plot its trends.")
    sub = ap.add_subparsers(dest="action", required=True)
    a_app = sub.add_parser("append", help="add a run's summary, keyed by --label (or commit and plugin builds) and device")
    a_app.add_argument("run_dir", metavar="RUN_DIR", nargs="+",
                       help="a run, or replicate runs of one build pooled into one entry")
    a_app.add_argument("--file", default=DEFAULT_FILE, help="history file, JSON Lines (default %(default)s)")
    a_app.add_argument("--label", help="the entry's key: what you changed (default: photonbench's "
                       "commit and the plugin builds' digest)")
    a_list = sub.add_parser("list", help="one line per entry; environment changes marked")
    a_list.add_argument("--file", default=DEFAULT_FILE, help="history file (default %(default)s)")
    a_plot = sub.add_parser("plot", help="plot the trend of each cell and pass, marking change points")
    a_plot.add_argument("--file", default=DEFAULT_FILE, help="history file (default %(default)s)")
    a_plot.add_argument("--out", metavar="DIR", help="output folder (default: history-plots beside the file)")
    a_plot.add_argument("--min-shift", type=float, default=MIN_SHIFT,
                        help="smallest relative level change marked (default %(default)s)")
    a_plot.add_argument("--k", type=float, default=K,
                        help="a change must exceed K standard errors of the two levels (default %(default)s)")
    a = ap.parse_args(argv)
    try:
        if a.action == "append":
            entry, replaced = append(a.run_dir, a.file, a.label)
            print(f"{'replaced' if replaced else 'appended'} {entry['label']} on {entry['device']} "
                  f"({len(entry['cells'])} cells) in {a.file}")
            dev = [e for e in load(a.file) if e["device"] == entry["device"]]
            at = next(i for i, e in enumerate(dev) if entry_key(e) == entry_key(entry))
            if at in environment_changes(dev):
                print(f"! environment changed since the previous entry: "
                      f"{environment.describe(environment_changes(dev)[at])}")
        elif a.action == "list":
            entries = load(a.file)
            if not entries:
                raise RunError(f"{a.file}: no history (run `photonbench history append RUN_DIR` first)")
            print("\n".join(listing(entries)))
        else:
            out = a.out or os.path.join(os.path.dirname(os.path.abspath(a.file)), "history-plots")
            files = plot(a.file, out, a.min_shift, a.k)
            for line in listing(load(a.file)):
                if line.lstrip().startswith("!"):
                    print(line.strip())
            print(f"{len(files)} figures in {out}")
    except RunError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0
