#!/usr/bin/python3
"""Checks that two run folders hold the same results, cell for cell, apart from timings and host
fields: what `merge` of a sharded run must give against the same config run in one place.

    shard_compare_runs.py RUN_A RUN_B     exit 0 when equal; else each difference on stdout, exit 1

Compared: the set of cells; each cell.json without its timings (summary, memory, stages_ms, the references'
render seconds) and host (device); metrics.csv and counters.csv exactly; frames.csv's (frame, pass)
rows without their times; the same image files, EXRs pixel for pixel (idiff: their headers hold
the time they were written), PNGs byte for byte; summary.csv's rows without the timing columns.
Used by tests/e2e/shard_merge.sh and slurm_sweep.sh."""
import csv
import json
import os
import subprocess
import sys

TIMING_COLUMNS = ("wall_ms_median", "wall_ms_p5", "wall_ms_p95", "harness_overhead_pct")


def cell_record(path):
    with open(path, encoding="utf-8") as f:
        record = json.load(f)
    for key in ("summary", "memory", "stages_ms", "device", "log_tail"):
        record.pop(key, None)
    for ref in record.get("references", []):
        ref.pop("seconds", None)
    return record


def rows(path, keep=None):
    with open(path, newline="", encoding="utf-8") as f:
        table = list(csv.reader(f))
    if keep is None:
        return table
    columns = [i for i, name in enumerate(table[0]) if keep(name)]
    return [[row[i] for i in columns] for row in table]


def files_under(root):
    out = set()
    for folder, _, names in os.walk(root):
        out.update(os.path.relpath(os.path.join(folder, n), root) for n in names)
    return out


def compare_cell(a, b, cell, problems):
    record_a = cell_record(os.path.join(a, "cell.json"))
    record_b = cell_record(os.path.join(b, "cell.json"))
    if record_a != record_b:
        keys = sorted(k for k in set(record_a) | set(record_b) if record_a.get(k) != record_b.get(k))
        problems.append(f"{cell}: cell.json differs beyond timings and host fields, in {keys}: "
                        + "; ".join(f"{k}: {record_a.get(k)} vs {record_b.get(k)}" for k in keys))
    names_a, names_b = files_under(a), files_under(b)
    if names_a != names_b:
        problems.append(f"{cell}: files differ: {sorted(names_a ^ names_b)}")
    for name in sorted(names_a & names_b):
        fa, fb = os.path.join(a, name), os.path.join(b, name)
        if name == "cell.json":
            continue
        if name == "frames.csv":
            same = rows(fa, lambda c: c in ("frame", "pass")) == rows(fb, lambda c: c in ("frame", "pass"))
        elif name.endswith(".exr"):
            same = subprocess.run(["idiff", "-q", fa, fb], capture_output=True).returncode == 0
        else:
            with open(fa, "rb") as x, open(fb, "rb") as y:
                same = x.read() == y.read()
        if not same:
            problems.append(f"{cell}: {name} differs")


def main(a, b):
    problems = []
    cells_a = set(os.listdir(os.path.join(a, "cells")))
    cells_b = set(os.listdir(os.path.join(b, "cells")))
    if cells_a != cells_b:
        problems.append(f"cells differ: only in {a}: {sorted(cells_a - cells_b)}; "
                        f"only in {b}: {sorted(cells_b - cells_a)}")
    for cell in sorted(cells_a & cells_b):
        compare_cell(os.path.join(a, "cells", cell), os.path.join(b, "cells", cell), cell, problems)
    keep = lambda c: c not in TIMING_COLUMNS and not c.startswith("pass.")
    sa, sb = rows(os.path.join(a, "summary.csv"), keep), rows(os.path.join(b, "summary.csv"), keep)
    if sa != sb:
        problems.append(f"summary.csv differs beyond timings:\n  {sa}\n  {sb}")
    for p in problems:
        print(p)
    print(f"compared {len(cells_a & cells_b)} cells: {len(problems)} difference(s)")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2]))
