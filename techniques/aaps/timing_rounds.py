#!/usr/bin/env python3
"""Alternating rounds of AAPS's msaa modes on one scene; per round the median frame time of the
technique's own passes (photon-trace, rasterize, apply, task-update; max of gpu_ms and cpu_ms, as
pbtools' claims read it); the ratio of each mode to `none` per round; after each round the mean
ratio's 90% interval (Student t); stops when every interval is within +-10% of its mean or at
max_rounds (the study scenes' timing ratios). Ratios, not times: the machine is shared, and a load that
slows one round slows its three modes alike.

    python3 techniques/aaps/timing_rounds.py build/photonbench OUT_DIR [MAX_ROUNDS]

Cornell-glass at configs/aaps.yaml's 320x160, density 128^2 and its smallest target area (2 px^2);
OUT_DIR/ratios.json keeps the rounds, so a second call with a larger MAX_ROUNDS continues them."""
import csv, json, math, os, statistics, subprocess, sys
PB = sys.argv[1]; OUT = sys.argv[2]; MAX_ROUNDS = int(sys.argv[3]) if len(sys.argv) > 3 else 16
MODES = ["none", "all_per_sample", "small_per_sample"]
PASSES = {"photon-trace", "rasterize", "apply", "task-update"}
T90 = {1: 6.314, 2: 2.920, 3: 2.353, 4: 2.132, 5: 2.015, 6: 1.943, 7: 1.895, 8: 1.860, 9: 1.833,
       10: 1.812, 11: 1.796, 12: 1.782, 13: 1.771, 14: 1.761, 15: 1.753, 16: 1.746, 17: 1.740,
       18: 1.734, 19: 1.729, 20: 1.725, 21: 1.721, 22: 1.717, 23: 1.714, 24: 1.711, 25: 1.708,
       26: 1.706, 27: 1.703, 28: 1.701, 29: 1.699}
CONFIG = """name: aaps-timing
resolution: [320, 160]
seed: 1
scenes: [cornell-glass]
frames: {{warmup: 4, count: 6, metrics_every: 0}}
metrics: [psnr]
techniques:
  - technique: aaps
    params: {{density_resolution: 128, target_area: 2, msaa: {mode}}}
"""
def frame_ms(cell):
    per = {}
    with open(os.path.join(cell, "frames.csv")) as f:
        for r in csv.DictReader(f):
            if r["pass"] not in PASSES: continue
            v = max(float(r["gpu_ms"] or -1), float(r["cpu_ms"] or -1))  # where the pass ran
            per[r["frame"]] = per.get(r["frame"], 0) + v
    return statistics.median(per.values())
ratios = {m: [] for m in MODES[1:]}
os.makedirs(OUT, exist_ok=True)
RESUME = os.path.join(OUT, 'ratios.json')
if os.path.exists(RESUME): ratios = json.load(open(RESUME))  # earlier rounds of the same study
for rnd in range(len(ratios['all_per_sample']), MAX_ROUNDS):
    order = MODES if rnd % 2 == 0 else MODES[::-1]
    ms = {}
    for mode in order:
        d = os.path.join(OUT, f"r{rnd}_{mode}")
        cfg = os.path.join(OUT, f"r{rnd}_{mode}.yaml")
        open(cfg, "w").write(CONFIG.format(mode=mode))
        subprocess.run([PB, "run", cfg, "--out", d], check=True, stdout=subprocess.DEVNULL,
                       stderr=subprocess.DEVNULL)
        cell = os.path.join(d, "cells", os.listdir(os.path.join(d, "cells"))[0])
        ms[mode] = frame_ms(cell)
    line = f"round {rnd}: " + ", ".join(f"{m} {ms[m]:.1f} ms" for m in MODES)
    done = rnd >= 2
    for m in MODES[1:]:
        ratios[m].append(ms[m] / ms["none"])
        n = len(ratios[m]); mean = statistics.mean(ratios[m])
        if n > 1:
            half = T90[n - 1] * statistics.stdev(ratios[m]) / math.sqrt(n)
            line += f"; {m}/none {mean:.3f} [{mean - half:.3f}, {mean + half:.3f}] (+-{half / mean * 100:.1f}%)"
            done = done and half / mean <= 0.10
        else:
            done = False
    print(line, flush=True)
    json.dump(ratios, open(RESUME, 'w'))
    if done: break
json.dump(ratios, open(os.path.join(OUT, "ratios.json"), "w"))
