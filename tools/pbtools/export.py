"""photonbench export RUN_DIR --format github-action-benchmark

Writes the run in the JSON that github-action-benchmark reads for its `customSmallerIsBetter` and
`customBiggerIsBetter` tools: a list of {"name", "unit", "value", "range", "extra"}. The action takes one
tool per file, so there are two files:
  customSmallerIsBetter.json   median frame time and pass times [ms], FLIP and relMSE means
  customBiggerIsBetter.json    SSIM and PSNR means
Names are "<scene>/<technique and swept params>/<quantity>"; the dashboard groups charts by them.
Failed cells are left out (a partial median would read as a speed-up) and listed on stderr.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from typing import Dict, List, Tuple

from . import measures
from .rundata import Run, RunError

FORMATS = ("github-action-benchmark",)
SMALLER_FILE = "customSmallerIsBetter.json"
BIGGER_FILE = "customBiggerIsBetter.json"
# The metric means exported, in this order; each goes to the file its direction (measures.py) names.
EXPORTED_METRICS = ("flip", "relmse", "ssim", "psnr")


def _range(lo: float, hi: float) -> str:
    if not (math.isfinite(lo) and math.isfinite(hi)):
        return ""
    return f"p5-p95 {lo:.4g}-{hi:.4g}"


def entries(run: Run, clock: str = "auto") -> Tuple[List[dict], List[dict], List[str]]:
    """(smaller-is-better entries, bigger-is-better entries, ids of skipped failed cells)."""
    smaller, bigger, skipped = [], [], []
    names: Dict[str, int] = {}
    for c in run.cells:
        if not c.ok:
            skipped.append(c.id)
            continue
        label = run.label(c).replace(" (", " ").replace(")", "")
        prefix = f"{c.scene}/{label}"
        names[prefix] = names.get(prefix, 0) + 1
        if names[prefix] > 1:  # two cells with the same visible setting: keep names unique by id
            prefix = f"{c.scene}/{c.id}"
        extra = (f"cell {c.id}; frames {c.text('frames')}; commit {run.commit[:12]}; "
                 f"device {run.device}")
        v = c.value("wall_ms_median")  # times: lower is better
        if math.isfinite(v):
            smaller.append({"name": f"{prefix}/frame", "unit": "ms", "value": v,
                            "range": _range(c.value("wall_ms_p5"), c.value("wall_ms_p95")), "extra": extra})
        for p, ms in c.pass_medians().items():
            _, samples = c.pass_samples(p, clock)
            smaller.append({"name": f"{prefix}/pass {p}", "unit": "ms", "value": ms,
                            "range": _range(*measures.percentile_range(samples)), "extra": extra})
        cls = c.primary_class()
        for metric in EXPORTED_METRICS:
            value = c.value(f"{metric}_mean")
            if not math.isfinite(value):
                value = c.metric_mean(metric, cls)
            if math.isfinite(value):
                target = smaller if measures.lower_is_better(metric) else bigger
                target.append({"name": f"{prefix}/{metric}", "unit": measures.metric(metric).unit,
                               "value": value,
                               "extra": extra + (f"; path class {cls}" if cls else "")})
    return smaller, bigger, skipped


def write(run_dir: str, out_dir: str = None, clock: str = "auto") -> Tuple[str, str]:
    run = Run(run_dir)
    out_dir = out_dir or os.path.join(run.path, "export")
    os.makedirs(out_dir, exist_ok=True)
    smaller, bigger, skipped = entries(run, clock)
    paths = []
    for name, data in ((SMALLER_FILE, smaller), (BIGGER_FILE, bigger)):
        path = os.path.join(out_dir, name)
        with open(path + ".tmp", "w", encoding="utf-8") as f:
            json.dump(data, f, indent=2)
        os.replace(path + ".tmp", path)
        paths.append(path)
    for cid in skipped:
        print(f"export: left out failed cell {cid}", file=sys.stderr)
    return paths[0], paths[1]


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(prog="photonbench export",
                                 description="Export a run's medians and metric means for a CI dashboard.")
    ap.add_argument("run_dir", metavar="RUN_DIR")
    ap.add_argument("--format", required=True, choices=FORMATS,
                    help="github-action-benchmark: writes customSmallerIsBetter.json (times, FLIP, relMSE) and "
                         "customBiggerIsBetter.json (SSIM, PSNR)")
    ap.add_argument("--out", metavar="DIR", help="output folder (default RUN_DIR/export)")
    ap.add_argument("--clock", choices=["auto", "gpu", "cpu"], default="auto",
                    help="per-frame column used for the pass ranges (default: gpu where present)")
    a = ap.parse_args(argv)
    try:
        for path in write(a.run_dir, a.out, a.clock):
            print(path)
    except RunError as e:
        print(f"error: {e}", file=sys.stderr)
        return 2
    return 0
