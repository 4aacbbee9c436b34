#!/usr/bin/python3
"""Synthetic run directories in exactly the results schema (docs/architecture.md), for testing the
tools before (and beside) real runs.

The data are synthetic but shaped like a real run on a noisy machine:
  * a fixed *layout* (scenes, techniques, parameter sweeps, per-pass base times, metric levels) that does
    not depend on the seed, so two fixtures with different seeds are two runs of the same build (A/A);
  * per-frame times that follow the animation (a smooth per-frame complexity curve shared by all runs),
    multiplied by per-sample log-normal noise, occasional spikes (another process stealing the core), and
    a run-level drift (the machine's state differs from one run to the next);
  * a cell that fails mid-animation (reason + failed_frame), a technique whose plugin fails to load
    (failed at setup, no frames), and a cell with warnings on given frames;
  * metrics every `metrics_every` measured frames per path class, each with its noise floors (the same
    for every cell of a scene: one reference; pillars' FLIP floor 0.033 leaves its best tiled setting,
    FLIP ~0.11, unresolved, within 4x), and images: frame_NNNN.exr (linear, uncompressed OpenEXR),
    frame_NNNN.png (tonemapped), reference_NNNN_<class>.png, flip_NNNN_<class>.png;
  * with `bounce_matched`, every metric row again against a bounce-matched reference (reference column
    "bounce_matched"): scores 20% lower, the same floors.

`slow` injects a slowdown, {pass name: factor}, into every cell that has that pass, the way the
runner's test-only delay injection would, so compare can be checked against a known regression.

`load` (a number >= 0) writes the run as lavapipe's fenced timing does (cell.json and run.json "timing":
"fenced", frames.csv's process_cpu_ms column): process_cpu_ms is the pass's work (the noise above), and
gpu_ms, the fenced wall time, adds waiting for a core: x (1 + load x U(0, 2)) per frame, the run's load.

Command line:  fixture.py OUT_DIR [--seed N] [--frames N] [--slow PASS=FACTOR] [--no-images]
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import json
import math
import os
import struct
import sys
from typing import Dict, List, Optional

import numpy as np

SCENES = ["cornell-box", "pillars"]

# technique -> (swept params as a list of dicts, top-level passes with base ms, nested passes, classes)
# Base times are for the first scene; the second is 1.4x heavier. "trace" is CPU-only (Embree): it has
# no GPU timestamps, so its gpu_ms is empty, as a real CPU pass would be.
TECHNIQUES = [
    {
        "technique": "direct",
        "settings": [{}],
        "passes": {"scene-update": 0.35, "gbuffer": 2.1, "shadow-map": 1.6, "shade": 1.3, "tonemap": 0.45},
        "cpu_only": {"scene-update"},
        "nested": {},
        "classes": ["combined"],
        "flip": 0.31,
    },
    {
        "technique": "tiled",
        "settings": [{"photons": p, "radius": 0.05} for p in (50000, 100000, 200000)],
        "passes": {"scene-update": 0.35, "gbuffer": 2.1, "trace": 3.0, "splat": 2.4, "shade": 1.3,
                   "tonemap": 0.45},
        "cpu_only": {"scene-update", "trace"},
        "nested": {"splat": {"sort": 0.45, "accumulate": 0.5}},  # fractions of the outer pass
        "classes": ["combined", "caustics"],
        "flip": 0.12,
    },
    {
        "technique": "cluster",
        "settings": [{"variant": v} for v in ("plain", "cone", "trivial")],
        "passes": {"scene-update": 0.35, "gbuffer": 2.1, "trace": 2.6, "cluster": 1.1, "splat": 1.9,
                   "shade": 1.3, "tonemap": 0.45},
        "cpu_only": {"scene-update", "trace"},
        "nested": {},
        "classes": ["combined", "indirect"],
        "flip": 0.15,
    },
    {
        "technique": "broken",
        "settings": [{}],
        "passes": {},
        "cpu_only": set(),
        "nested": {},
        "classes": ["combined"],
        "flip": math.nan,
    },
]

PARAM_NAMES = ["photons", "radius", "variant"]
MID_FAIL = ("pillars", "cluster", {"variant": "trivial"}, 13,
            "VK_ERROR_OUT_OF_DEVICE_MEMORY allocating the cluster buffer (pass cluster)")
SETUP_FAIL_REASON = ("cannot load plugin techniques/broken: broken.so: undefined symbol: "
                     "pb_technique_entry")
WARN = ("pillars", "tiled", {"photons": 200000, "radius": 0.05}, [5, 17],
        "photon buffer full: 3% of photons dropped")
# FLIP floor of the combined class per scene; every metric's floor follows from it as the scores do
# from FLIP (below), so each metric's floor ratio is FLIP's.
FLIP_FLOOR = {"cornell-box": 0.01, "pillars": 0.033}
# How each scene's references stopped (cell.json "references"): (relative error, seconds a frame,
# stop rule); pillars' ran into its time limit, as a caustic scene's does.
REFERENCE_STOP = {"cornell-box": (0.1, 2.0, "rel_error"), "pillars": (0.14, 60.0, "max_seconds")}
METRICS_HEADER = ["frame", "path_class", "reference", "flip", "ssim", "psnr", "rmse", "relmse", "flip_floor",
                  "ssim_floor", "psnr_floor", "rmse_floor", "relmse_floor", "mse_unbiased", "relmse_unbiased"]


def metric_values(fl: float) -> List[float]:
    """flip, ssim, psnr, rmse, relmse of a score (or floor) with FLIP fl: all the same distance."""
    mse = (fl * 0.35) ** 2
    return [fl, max(0.0, 1 - 1.6 * fl), -10 * math.log10(mse), math.sqrt(mse), mse / 0.25]


def cell_id(index: int, scene: str, technique: str, params: dict) -> str:
    parts = [f"{k}={v}" for k, v in params.items()]
    return f"{index:03d}-{scene}-{technique}" + ("-" + "-".join(parts) if parts else "")


def write_csv(path: str, header: List[str], rows: List[list]) -> None:
    tmp = path + ".tmp"
    with open(tmp, "w", newline="", encoding="utf-8") as f:
        w = csv.writer(f)
        w.writerow(header)
        w.writerows(rows)
    os.replace(tmp, path)  # atomic, as the runner writes its files


def write_json(path: str, obj) -> None:
    tmp = path + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        json.dump(obj, f, indent=2)
    os.replace(tmp, path)


def fmt(v: float) -> str:
    return "" if v is None or (isinstance(v, float) and math.isnan(v)) else f"{v:.6g}"


def write_exr(path: str, rgb: np.ndarray) -> None:
    """Minimal single-part scanline OpenEXR, uncompressed FLOAT channels B, G, R (OpenEXR file layout:
    magic, version, header attributes, line offset table, one scanline per chunk)."""
    h, w, _ = rgb.shape

    def attr(name: str, typ: str, data: bytes) -> bytes:
        return name.encode() + b"\0" + typ.encode() + b"\0" + struct.pack("<i", len(data)) + data

    chlist = b"".join(c.encode() + b"\0" + struct.pack("<iB3xii", 2, 0, 1, 1) for c in "BGR") + b"\0"
    box = struct.pack("<iiii", 0, 0, w - 1, h - 1)
    header = (struct.pack("<ii", 20000630, 2) + attr("channels", "chlist", chlist)
              + attr("compression", "compression", b"\0") + attr("dataWindow", "box2i", box)
              + attr("displayWindow", "box2i", box) + attr("lineOrder", "lineOrder", b"\0")
              + attr("pixelAspectRatio", "float", struct.pack("<f", 1.0))
              + attr("screenWindowCenter", "v2f", struct.pack("<ff", 0.0, 0.0))
              + attr("screenWindowWidth", "float", struct.pack("<f", 1.0)) + b"\0")
    line_bytes = 3 * 4 * w
    chunk = 8 + line_bytes
    first = len(header) + 8 * h
    offsets = struct.pack(f"<{h}Q", *[first + y * chunk for y in range(h)])
    data = bytearray()
    img = rgb.astype("<f4")
    for y in range(h):
        data += struct.pack("<ii", y, line_bytes)
        for c in (2, 1, 0):  # B, G, R: channels are stored in name order
            data += img[y, :, c].tobytes()
    tmp = path + ".tmp"
    with open(tmp, "wb") as f:
        f.write(header + offsets + bytes(data))
    os.replace(tmp, path)


def reference_image(scene: str, frame: int, cls: str, w: int, h: int) -> np.ndarray:
    """A smooth linear-radiance picture: walls, a floor, a moving bright caustic ellipse."""
    y, x = np.mgrid[0:h, 0:w].astype(float)
    u, v = x / w, y / h
    img = np.zeros((h, w, 3))
    img[...] = (0.55 + 0.25 * v)[..., None] * np.array([0.8, 0.78, 0.72])
    img[u < 0.15] *= np.array([1.0, 0.25, 0.2])
    img[u > 0.85] *= np.array([0.25, 0.9, 0.3])
    if scene == "pillars":
        for cx in (0.35, 0.65):
            img[(abs(u - cx) < 0.04) & (v > 0.2)] *= 0.35
    cx = 0.5 + 0.18 * math.sin(frame / 9.0)
    caustic = np.exp(-(((u - cx) / 0.08) ** 2 + ((v - 0.78) / 0.05) ** 2)) * 3.0
    if cls == "caustics":
        return caustic[..., None] * np.array([1.0, 0.95, 0.8])
    if cls == "indirect":
        return 0.3 * img
    return img + caustic[..., None] * np.array([1.0, 0.95, 0.8])


def tonemap(img: np.ndarray) -> np.ndarray:
    return np.clip(img / (1.0 + img), 0, 1) ** (1 / 2.2)


def magma_map(err: np.ndarray) -> np.ndarray:
    import matplotlib
    return matplotlib.colormaps["magma"](np.clip(err, 0, 1))[..., :3]


def save_png(path: str, img: np.ndarray) -> None:
    import matplotlib.image
    tmp = path + ".tmp.png"
    matplotlib.image.imsave(tmp, np.clip(img, 0, 1), format="png")
    os.replace(tmp, path)


def make_run(out_dir: str, seed: int = 0, frames: int = 24, warmup: int = 4, metrics_every: int = 8,
             slow: Optional[Dict[str, float]] = None, noise: float = 0.05, drift: float = 0.02,
             spike_rate: float = 0.03, images: bool = True, resolution=(96, 54),
             commit: Optional[str] = None, device: str = "llvmpipe (LLVM 15.0.6, 256 bits)",
             scenes: Optional[List[str]] = None, techniques: Optional[List[str]] = None,
             load: Optional[float] = None, bounce_matched: bool = False,
             settings: Optional[Dict[str, List[dict]]] = None) -> str:
    """Writes a run directory at out_dir and returns its path. Layout is seed-independent; `seed` drives
    only the noise, so two seeds are an A/A pair. `settings` replaces techniques' parameter settings,
    {technique: [params, ...]} (e.g. direct at two shadow map sizes); new parameter names get their
    param.<name> columns."""
    slow = slow or {}
    scenes = scenes or SCENES
    chosen = [{**t, "settings": (settings or {}).get(t["technique"], t["settings"])} for t in TECHNIQUES
              if techniques is None or t["technique"] in techniques]
    param_names = PARAM_NAMES + [k for k in dict.fromkeys(k for t in chosen for s in t["settings"] for k in s)
                                 if k not in PARAM_NAMES]
    layout = np.random.default_rng(12345)  # the "build": identical for every seed
    rng = np.random.default_rng(seed)  # the "machine": differs per run
    run_drift = math.exp(rng.normal(0.0, drift))
    os.makedirs(os.path.join(out_dir, "cells"), exist_ok=True)
    w, h = resolution

    config = {
        "name": "fixture",
        "resolution": [w, h],
        "frames": {"warmup": warmup, "count": frames, "metrics_every": metrics_every},
        "seed": 1,
        "scenes": scenes,
        "techniques": [{"technique": t["technique"],
                        "params": {k: sorted({s[k] for s in t["settings"]}, key=str)
                                   if len({s[k] for s in t["settings"]}) > 1 else t["settings"][0][k]
                                   for k in t["settings"][0]}} for t in chosen],
        "metrics": ["flip", "ssim", "psnr"],
        "reference": {"samples": 64},
    }
    config_text = json.dumps(config, sort_keys=True)
    summary_rows, pass_columns = [], []
    index = 0
    # Animation complexity along the camera path: part of the layout, so A/A runs share it.
    anim = 1.0 + 0.12 * np.sin(np.arange(frames) * 2 * math.pi / max(frames, 1)) + 0.03 * layout.normal(
        size=frames)
    metric_frames = [f for f in range(frames) if f % metrics_every == 0]

    for scene in scenes:
        scene_i = SCENES.index(scene)
        scene_scale = 1.0 + 0.4 * scene_i
        for tech in chosen:
            for params in tech["settings"]:
                cid = cell_id(index, scene, tech["technique"], params)
                index += 1
                cdir = os.path.join(out_dir, "cells", cid)
                os.makedirs(os.path.join(cdir, "images"), exist_ok=True)
                setting_scale = 1.0
                if "photons" in params:
                    setting_scale = (params["photons"] / 100000.0) ** 0.6
                if params.get("variant") == "cone":
                    setting_scale = 1.15
                if params.get("variant") == "trivial":
                    setting_scale = 0.8
                fail_frame, reason = None, ""
                if tech["technique"] == "broken":
                    fail_frame, reason = 0, SETUP_FAIL_REASON
                elif (scene, tech["technique"], params) == MID_FAIL[:3]:
                    fail_frame, reason = MID_FAIL[3], MID_FAIL[4]
                warnings = []
                if (scene, tech["technique"], params) == WARN[:3]:
                    warnings = [{"frame": f, "message": WARN[4]} for f in WARN[3]]
                n_frames = frames if fail_frame is None else (0 if not tech["passes"] else fail_frame)

                # Per-pass base ms for this cell (layout) and the cell's own structure jitter.
                base = {}
                for p, ms in tech["passes"].items():
                    s = setting_scale if p in ("trace", "splat", "cluster") else 1.0
                    if p == "shadow-map" and "shadow_map_size" in params:  # a sweep given by `settings`
                        s = (params["shadow_map_size"] / 1024.0) ** 0.5
                    base[p] = ms * scene_scale * s * float(layout.uniform(0.95, 1.05))
                frame_rows, counter_rows = [], []
                per_pass: Dict[str, List[float]] = {}
                for f in range(n_frames):
                    total = 0.0
                    for p, ms in base.items():
                        spike = rng.uniform(1.3, 2.5) if rng.random() < spike_rate else 1.0
                        t0 = ms * anim[f] * run_drift * math.exp(rng.normal(0, noise)) * spike
                        # An injected delay slows the named pass only, not the passes nested in it.
                        t = t0 * slow.get(p, 1.0)
                        total += t
                        cpu = t * 1.02 + 0.01
                        gpu = None if p in tech["cpu_only"] else t
                        if load is not None:  # fenced: gpu_ms is wall time, waiting for a core included
                            wait = 1.0 + load * float(rng.uniform(0.0, 2.0))
                            gpu = None if p in tech["cpu_only"] else t * wait
                            cpu = t * 1.02 + 0.01 if p in tech["cpu_only"] else 0.02
                            total += (gpu or cpu) - t
                        frame_rows.append([f, p, fmt(gpu), fmt(cpu)] + ([fmt(t)] if load is not None else []))
                        per_pass.setdefault(p, []).append(t)
                        for inner, frac in tech["nested"].get(p, {}).items():
                            name = f"{p}/{inner}"
                            ti = t0 * frac * math.exp(rng.normal(0, noise / 2)) * slow.get(name, 1.0)
                            frame_rows.append([f, name, fmt(ti), fmt(ti * 1.02 + 0.005)]
                                              + ([fmt(ti)] if load is not None else []))
                            per_pass.setdefault(name, []).append(ti)
                    total += 0.05 * math.exp(rng.normal(0, noise))  # submission/fence overhead
                    work = sum(float(r[4]) for r in frame_rows if r[0] == f and "/" not in r[1]) \
                        if load is not None else 0.0
                    frame_rows.append([f, "frame", fmt(total), fmt(total * 1.01 + 0.02)]
                                      + ([fmt(work + 0.05)] if load is not None else []))
                    per_pass.setdefault("frame", []).append(total)
                    if "photons" in params:
                        counter_rows.append([f, "photons_emitted", params["photons"]])
                        counter_rows.append([f, "photons_stored", int(params["photons"] * 0.62)])
                    if tech["technique"] == "cluster":
                        counter_rows.append([f, "clusters", 1200 + int(40 * math.sin(f / 5))])
                if tech["passes"] or frame_rows:
                    write_csv(os.path.join(cdir, "frames.csv"), ["frame", "pass", "gpu_ms", "cpu_ms"]
                              + (["process_cpu_ms"] if load is not None else []), frame_rows)
                    write_csv(os.path.join(cdir, "counters.csv"), ["frame", "name", "value"], counter_rows)
                for p in per_pass:
                    if p != "frame" and p not in pass_columns:
                        pass_columns.append(p)

                # Metrics: deterministic given the layout (real runs use fixed seeds), per path class.
                flip_level = tech["flip"]
                if "photons" in params:
                    flip_level = 0.07 + 0.05 * math.sqrt(100000.0 / params["photons"])
                if params.get("variant") == "cone":
                    flip_level *= 0.85
                if params.get("variant") == "trivial":
                    flip_level *= 1.3
                if "shadow_map_size" in params:  # smaller maps alias the shadow edges a little
                    flip_level *= (1024.0 / params["shadow_map_size"]) ** 0.05
                flip_level *= 1.0 + 0.1 * scene_i
                metric_rows, reference_records = [], []
                mframes = [f for f in metric_frames if f < n_frames]
                references = ["full", "bounce_matched"] if bounce_matched else ["full"]
                for reference in references:
                    for f in mframes:
                        for ci, cls in enumerate(tech["classes"]):
                            rel_error, seconds, stopped_by = REFERENCE_STOP[scene]
                            reference_records.append({
                                "frame": f, "path_class": cls, "reference": reference,
                                "rel_error": rel_error, "seconds": seconds,
                                "stopped_by": stopped_by})
                            fl = flip_level * (1 + 0.3 * ci) * (1 + 0.1 * math.sin(f / 7.0))
                            fl = float(np.clip(fl * float(layout.uniform(0.97, 1.03)), 0.001, 0.99))
                            if reference == "bounce_matched":
                                fl *= 0.8
                            floor = FLIP_FLOOR[scene] * (1 + 0.3 * ci) * (1 + 0.05 * math.cos(f / 5.0))
                            score, floors = metric_values(fl), metric_values(floor)
                            unbiased = [score[3] ** 2 - floors[3] ** 2, score[4] - floors[4]]
                            metric_rows.append([f, cls, reference] + [fmt(v) for v in score + floors + unbiased])
                if tech["passes"]:
                    write_csv(os.path.join(cdir, "metrics.csv"), METRICS_HEADER, metric_rows)
                if images and tech["passes"]:
                    img_rng = np.random.default_rng(index)
                    for f in mframes:
                        ref_full = reference_image(scene, f, "combined", w, h)
                        noisy = ref_full + img_rng.normal(0, flip_level * 0.6, ref_full.shape) * ref_full
                        noisy = np.maximum(noisy, 0)
                        write_exr(os.path.join(cdir, "images", f"frame_{f:04d}.exr"), noisy)
                        save_png(os.path.join(cdir, "images", f"frame_{f:04d}.png"), tonemap(noisy))
                        for cls in tech["classes"]:
                            ref = reference_image(scene, f, cls, w, h)
                            test = ref + img_rng.normal(0, flip_level * 0.6, ref.shape) * ref
                            err = np.abs(tonemap(np.maximum(test, 0)) - tonemap(ref)).mean(axis=2) * 12
                            save_png(os.path.join(cdir, "images", f"reference_{f:04d}_{cls}.png"),
                                     tonemap(ref))
                            save_png(os.path.join(cdir, "images", f"flip_{f:04d}_{cls}.png"),
                                     magma_map(err))

                status = "ok" if fail_frame is None else "failed"
                write_json(os.path.join(cdir, "cell.json"), {
                    "cell": cid, "scene": scene, "technique": tech["technique"], "status": status,
                    # A setup failure (plugin load) happens before any frame: failed_frame is null.
                    "reason": reason, "failed_frame": None if reason == SETUP_FAIL_REASON else fail_frame,
                    "warnings": warnings,
                    "params": params, "frames": n_frames,
                    "peak_host_memory_bytes": int(layout.uniform(2e8, 6e8)),
                    "gpu_memory_bytes": int(layout.uniform(5e7, 3e8)) if tech["passes"] else 0,
                    **({"timing": "fenced"} if load is not None else {}),
                    **({"references": reference_records} if tech["passes"] else {}),
                })

                ft = np.asarray(per_pass.get("frame", []))
                full = [r for r in metric_rows if r[1] == tech["classes"][0] and r[2] == "full"]

                def mean_of(col: int) -> float:
                    return float(np.mean([float(r[col]) for r in full])) if full else math.nan

                row = {
                    "cell": cid, "scene": scene, "technique": tech["technique"], "status": status,
                    "frames": n_frames,
                    "wall_ms_median": float(np.median(ft)) if len(ft) else math.nan,
                    "wall_ms_p5": float(np.percentile(ft, 5)) if len(ft) else math.nan,
                    "wall_ms_p95": float(np.percentile(ft, 95)) if len(ft) else math.nan,
                    "flip_mean": mean_of(3), "ssim_mean": mean_of(4), "psnr_mean": mean_of(5),
                    "flip_floor": mean_of(8), "ssim_floor": mean_of(9), "psnr_floor": mean_of(10),
                    "params": params,
                    "passes": {p: float(np.median(v)) for p, v in per_pass.items() if p != "frame"},
                }
                summary_rows.append(row)

    fixed = ["cell", "scene", "technique", "status", "frames", "wall_ms_median", "wall_ms_p5",
             "wall_ms_p95", "flip_mean", "ssim_mean", "psnr_mean", "flip_floor", "ssim_floor", "psnr_floor"]
    header = fixed + [f"param.{p}" for p in param_names] + [f"pass.{p}.ms_median" for p in pass_columns]
    rows = []
    for r in summary_rows:
        out = [r["cell"], r["scene"], r["technique"], r["status"], r["frames"]]
        out += [fmt(r[k]) for k in fixed[5:]]
        out += [fmt(r["params"][p]) if isinstance(r["params"].get(p), float) else
                str(r["params"].get(p, "")) for p in param_names]
        out += [fmt(r["passes"].get(p)) for p in pass_columns]
        rows.append(out)
    write_csv(os.path.join(out_dir, "summary.csv"), header, rows)

    commit = commit or hashlib.sha1(b"fixture-build").hexdigest()
    write_json(os.path.join(out_dir, "run.json"), {
        "schema_version": 1,
        "tool_version": "0.1.0",
        "git_commit": commit,
        "config": config,
        "config_hash": hashlib.sha256(config_text.encode()).hexdigest()[:16],
        "device": device,
        "driver": "Mesa 22.3.6",
        "cpu": "synthetic 2-core CPU",
        "os": "Debian GNU/Linux 12 (bookworm)",
        "start": f"2024-05-01T12:00:{seed % 60:02d}Z",
        "end": f"2024-05-01T12:05:{seed % 60:02d}Z",
        "fixture": {"seed": seed, "slow": slow, "load": load},
        **({"timing": "fenced: each pass boundary submits and waits"} if load is not None else {}),
    })
    return out_dir


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out_dir")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--frames", type=int, default=24)
    ap.add_argument("--metrics-every", type=int, default=8)
    ap.add_argument("--slow", action="append", default=[], metavar="PASS=FACTOR")
    ap.add_argument("--commit")
    ap.add_argument("--device", default="llvmpipe (LLVM 15.0.6, 256 bits)")
    ap.add_argument("--no-images", action="store_true")
    a = ap.parse_args(argv)
    slow = {}
    for s in a.slow:
        name, _, factor = s.partition("=")
        slow[name] = float(factor)
    make_run(a.out_dir, seed=a.seed, frames=a.frames, metrics_every=a.metrics_every, slow=slow,
             images=not a.no_images, commit=a.commit, device=a.device)
    print(a.out_dir)
    return 0


if __name__ == "__main__":
    sys.exit(main())
