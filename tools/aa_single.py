#!/usr/bin/python3
"""Measures `photonbench compare`'s false-alarm rate on single-run A/A pairs on this machine.

The simplest use of compare is `run` once with each build, then `compare A B`. With one run a side there
is no run-to-run information, so compare only flags a timing change beyond its single-run limit
(pbtools/compare.py, SINGLE_RUN_LIMIT); smaller significant changes are "inconclusive" (exit 0). This
script makes N runs of one small config with one build, one after the other (the machine keeps doing
whatever else it does: that noise is the point), pairs them, and counts how many A/A pairs compare
flags (exit 1: a false alarm, since both sides are the same build and config).

Pairs: the disjoint consecutive pairs (run 1 vs 2, 3 vs 4, ...: independent verdicts, the headline
figure) and, as a larger but correlated sample, every ordered pair (i, j), i != j, of the N runs.

Detection (optional, --slow PASS=FACTOR): M more runs with the test-only delay hook
(testing.slow_pass / testing.slow_factor), each compared with the A run of the same index; counts how
many compare flags PASS slower.

usage: /usr/bin/python3 tools/aa_single.py [-n RUNS] [-b PHOTONBENCH] [-o DIR] [-c CONFIG]
                                           [--slow PASS=FACTOR [-m M]] [--reuse] [-- COMPARE ARGS]
  defaults: 20 runs, build/photonbench, /tmp/aa-single-<UTC time>, the built-in config below
  (two techniques, 320x180, 4 warm-up + 20 measured frames, no metric frames: about 7 s a run).
  --reuse: analyse the runs already in DIR (run01, ..., slow01, ...) without making new ones.
exit: 0 when the disjoint pairs' false-alarm rate is at most 1 in 20, 1 otherwise, 2 bad usage.
"""

from __future__ import annotations

import argparse
import itertools
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

from pbtools import compare as C  # noqa: E402

CONFIG = """# tools/aa_single.py's A/A config: small, two techniques with different pass structures.
name: aa-single
resolution: [320, 180]
frames: {warmup: 4, count: 20, metrics_every: 0}
seed: 1
scenes: [cornell-box]
techniques:
  - technique: direct
    params: {shadow_map_size: 512}
  - technique: directional
    params: {photons: 5000, radius: 0.08}
"""
MAX_RATE = 1 / 20


def make_runs(pb: str, config: str, out: str, n: int, prefix: str = "run", extra=()) -> None:
    for i in range(1, n + 1):
        run_dir = os.path.join(out, f"{prefix}{i:02d}")
        t0 = time.time()
        with open(run_dir + ".log", "w") as log:
            rc = subprocess.call([pb, "run", config, "--out", run_dir] + list(extra), stdout=log,
                                 stderr=subprocess.STDOUT, cwd=out)
        load = open("/proc/loadavg").read().split()[0]
        print(f"  run {i}/{n}: exit {rc}, {time.time() - t0:.1f} s, load {load}", flush=True)


def verdict(a, b, settings: dict) -> tuple:
    """(compare's exit code for `compare a b`, flagged passes, inconclusive passes, the largest |change|
    of a pass that the U test found significant); a and b are loaded RunSets."""
    result = C.compare(a, b, **settings)
    rc = 1 if result.regressions else 0  # what `photonbench compare` exits with
    flagged = [f"{r.label}:{r.pass_name}" for r in result.passes if r.verdict in ("slower", "faster")]
    unsure = [r for r in result.passes if r.verdict == "inconclusive"]
    significant = [abs(r.change_pct) for r in result.passes if r.p == r.p and r.p < result.settings["alpha"]
                   and abs(r.new_ms - r.base_ms) > result.settings["single_run_min_ms"]]
    return rc, flagged, len(unsure), max(significant, default=0.0)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-n", type=int, default=20, help="runs (default 20)")
    ap.add_argument("-b", default=os.path.join(os.path.dirname(HERE), "build", "photonbench"),
                    help="photonbench executable")
    ap.add_argument("-o", help="output folder")
    ap.add_argument("-c", help="config (default: the built-in one, written to the output folder)")
    ap.add_argument("--slow", metavar="PASS=FACTOR", help="also measure detection: runs with PASS x FACTOR")
    ap.add_argument("-m", type=int, default=10, help="slowed runs with --slow (default 10)")
    ap.add_argument("--reuse", action="store_true", help="analyse the runs already in the output folder")
    ap.add_argument("compare_args", nargs="*", help="after --: extra compare options")
    a = ap.parse_args(argv)
    out = os.path.abspath(a.o or f"/tmp/aa-single-{time.strftime('%Y%m%dT%H%M%SZ', time.gmtime())}")
    os.makedirs(out, exist_ok=True)
    if not a.reuse:
        if not os.access(a.b, os.X_OK):
            print(f"aa_single: no photonbench executable at {a.b} (give -b)", file=sys.stderr)
            return 2
        config = a.c or os.path.join(out, "config.yaml")
        if not a.c:
            with open(config, "w") as f:
                f.write(CONFIG)
        print(f"aa_single: {a.n} runs of {config} with {a.b} into {out}; load at start "
              f"{open('/proc/loadavg').read().split()[0]}", flush=True)
        make_runs(a.b, config, out, a.n)
        if a.slow:
            pass_name, _, factor = a.slow.partition("=")
            make_runs(a.b, config, out, a.m, "slow", ["--set", f"testing.slow_pass={pass_name}", "--set",
                                                       f"testing.slow_factor={factor or '2'}"])

    def finished(prefix):
        return sorted(os.path.join(out, d) for d in os.listdir(out)
                      if d.startswith(prefix) and os.path.isfile(os.path.join(out, d, "summary.csv")))
    runs, slowed = finished("run"), finished("slow")
    if len(runs) < 2:
        print(f"aa_single: fewer than two finished runs in {out}", file=sys.stderr)
        return 2
    commits = sorted({C.RunSet(r).commit[:12] for r in runs + slowed})
    print(f"{len(runs)} A runs, {len(slowed)} slowed runs; photonbench commit(s): {', '.join(commits)}")
    settings = C.settings_of(C.parse_args(["A", "B"] + list(a.compare_args)))
    sets = {r: C.RunSet(r) for r in runs}
    print(f"compare settings: {' '.join(a.compare_args) or '(defaults)'}; single-run limit "
          f"{settings['single_run_limit']:g}% and {settings['single_run_min_ms']:g} ms, threshold "
          f"{settings['threshold']:g}%, alpha {settings['alpha']:g}")
    print("| pair | exit | flagged | inconclusive passes | largest significant change |")
    print("|---|--:|---|--:|--:|")
    disjoint_alarms = 0
    disjoint = list(zip(runs[0::2], runs[1::2]))
    for x, y in disjoint:
        rc, flagged, unsure, largest = verdict(sets[x], sets[y], settings)
        disjoint_alarms += rc != 0
        print(f"| {os.path.basename(x)} vs {os.path.basename(y)} | {rc} | {', '.join(flagged) or '-'} | "
              f"{unsure} | {largest:.1f}% |")
    all_pairs = list(itertools.permutations(runs, 2))
    all_alarms, worst = 0, 0.0
    for x, y in all_pairs:
        rc, _, _, largest = verdict(sets[x], sets[y], settings)
        all_alarms += rc != 0
        worst = max(worst, largest)
    detected = 0
    if slowed:
        print()
        print("| slowed run | exit | flagged | verdicts of the slowed pass |")
        print("|---|--:|---|---|")
        for x, y in zip(runs, slowed):
            result = C.compare(sets[x], C.RunSet(y), **settings)
            hook = [o for o in C.RunSet(y).info.get("overrides") or [] if "slow_pass" in str(o)]
            name = str(hook[0]).split("=", 1)[-1] if hook else ""
            verdicts = [f"{r.verdict} {r.change_pct:+.0f}%" for r in result.passes if r.pass_name == name]
            hit = any(r.verdict == "slower" for r in result.passes if r.pass_name == name)
            detected += hit
            flagged = [f"{r.label}:{r.pass_name}" for r in result.passes if r.verdict == "slower"]
            print(f"| {os.path.basename(y)} vs {os.path.basename(x)} | {1 if result.regressions else 0} | "
                  f"{', '.join(flagged) or '-'} | {', '.join(verdicts)} |")
    print()
    if slowed:
        print(f"slowed runs whose slowed pass was flagged slower: {detected} of {min(len(runs), len(slowed))}")
    print(f"disjoint A/A pairs flagged (exit 1): {disjoint_alarms} of {len(disjoint)}")
    print(f"all ordered A/A pairs flagged: {all_alarms} of {len(all_pairs)} "
          f"({100.0 * all_alarms / len(all_pairs):.1f}%); largest significant A/A change {worst:.1f}%")
    ok = disjoint_alarms <= MAX_RATE * len(disjoint) and all_alarms <= MAX_RATE * len(all_pairs)
    print(f"target at most 1 in 20: {'met' if ok else 'NOT met'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
