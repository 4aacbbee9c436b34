"""Reading one run directory, exactly as docs/architecture.md "Results" lays it out.

    RUN/run.json                     tool version, git_commit, resolved config, device, driver, CPU, OS, start/end
    RUN/summary.csv                  one row per cell (cell, scene, technique, status, frames, frame_ms_*,
                                     *_mean, param.<name>..., pass.<name>.ms_median...)
    RUN/cells/<cell>/cell.json       status ok|failed, reason, failed_frame, warnings, params, memory
    RUN/cells/<cell>/frames.csv      frame, pass, gpu_ms, cpu_ms  (pass "frame" is the whole frame)
    RUN/cells/<cell>/counters.csv    frame, name, value
    RUN/cells/<cell>/metrics.csv     frame, path_class, reference, flip, ssim, psnr, rmse, relmse,
                                     <metric>_floor..., mse_unbiased, relmse_unbiased
    RUN/cells/<cell>/images/         frame_NNNN.{exr,png}, flip_NNNN_<class>.png, reference_NNNN_<class>.png

Everything here is read-only and tolerant of what a failed or interrupted cell leaves behind (a missing
file is an empty table, an empty CSV field is NaN), because a failed cell must be shown, never dropped.
Nothing in here parses a cell's id: cells are labelled from their scene, technique and param.* columns.
"""

from __future__ import annotations

import csv
import json
import math
import os
import re
from dataclasses import dataclass, field
from typing import Dict, List, Optional

import numpy as np

# The summary's fixed leading columns (docs/architecture.md); anything else is param.* or pass.*.ms_median.
SUMMARY_FIXED = [
    "cell", "scene", "technique", "status", "frames", "frame_ms_median", "frame_ms_p5",
    "frame_ms_p95", "flip_mean", "ssim_mean", "psnr_mean", "flip_floor", "ssim_floor", "psnr_floor",
]
PASS_PREFIX = "pass."
PASS_SUFFIX = ".ms_median"
PARAM_PREFIX = "param."
WHOLE_FRAME_PASS = "frame"
PRIMARY_CLASS = "combined"  # the path class of the composed image, preferred when a cell scores several
# metrics.csv's `reference` column: scores against the full reference, or (when the config asks for
# reference.bounce_matched) against one truncated at the technique's path depth. Runs from before the
# column existed scored against the full reference only.
FULL_REFERENCE = "full"
BOUNCE_MATCHED_REFERENCE = "bounce_matched"

# Metrics: which direction is better. FLIP, RMSE and relMSE are errors; SSIM and PSNR are similarities.
METRIC_LOWER_IS_BETTER = {"flip": True, "rmse": True, "relmse": True, "ssim": False, "psnr": False}
METRIC_LABEL = {"flip": "FLIP", "ssim": "SSIM", "psnr": "PSNR [dB]", "rmse": "RMSE", "relmse": "relMSE"}

_IMAGE_RE = re.compile(r"^(frame|flip|reference)_(\d+)(?:_(.+))?\.(png|exr)$")


class RunError(Exception):
    """A run directory that cannot be read (bad input: the command exits 2)."""


def to_float(text) -> float:
    """CSV field -> float; empty, missing or unparsable fields are NaN (a failed cell leaves them empty)."""
    if text is None:
        return math.nan
    if isinstance(text, (int, float)):
        return float(text)
    text = text.strip()
    if not text:
        return math.nan
    try:
        return float(text)
    except ValueError:
        return math.nan


def param_value(text: str):
    """A param.* field: a number when it reads as one (so sweeps sort numerically), else the string."""
    if text is None:
        return None
    text = text.strip()
    if text == "":
        return None
    try:
        value = float(text)
    except ValueError:
        return text
    if value.is_integer() and not re.search(r"[.eE]", text):
        return int(value)
    return value


def format_param(value) -> str:
    if isinstance(value, float):
        return f"{value:g}"
    return str(value)


def read_csv(path: str) -> List[Dict[str, str]]:
    if not os.path.isfile(path):
        return []
    with open(path, newline="", encoding="utf-8") as f:
        return list(csv.DictReader(f))


@dataclass
class Cell:
    """One row of summary.csv plus what its cells/<cell>/ directory holds (loaded on first use)."""

    run_dir: str
    row: Dict[str, str]
    index: int  # position in summary.csv: the config's order, used for stable colours and sorting
    _json: Optional[dict] = field(default=None, repr=False)
    _frames: Optional[List[Dict[str, str]]] = field(default=None, repr=False)
    _metrics: Optional[List[Dict[str, str]]] = field(default=None, repr=False)
    _counters: Optional[List[Dict[str, str]]] = field(default=None, repr=False)

    # -- summary row -------------------------------------------------------------------------------
    @property
    def id(self) -> str:
        return self.row["cell"]

    @property
    def scene(self) -> str:
        return self.row.get("scene", "")

    @property
    def technique(self) -> str:
        return self.row.get("technique", "")

    @property
    def status(self) -> str:
        return (self.row.get("status") or "").strip() or self.json.get("status", "unknown")

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def value(self, column: str) -> float:
        return to_float(self.row.get(column))

    @property
    def params(self) -> Dict[str, object]:
        """param.<name> columns that this cell sets (empty fields belong to other techniques)."""
        out = {}
        for key, text in self.row.items():
            if key and key.startswith(PARAM_PREFIX):
                v = param_value(text)
                if v is not None:
                    out[key[len(PARAM_PREFIX):]] = v
        return out

    def pass_medians(self) -> Dict[str, float]:
        """pass.<name>.ms_median columns with a value, name -> ms (nested names keep their '/')."""
        out = {}
        for key, text in self.row.items():
            if key and key.startswith(PASS_PREFIX) and key.endswith(PASS_SUFFIX):
                v = to_float(text)
                if not math.isnan(v):
                    out[key[len(PASS_PREFIX):-len(PASS_SUFFIX)]] = v
        return out

    # -- cells/<cell>/ -----------------------------------------------------------------------------
    @property
    def dir(self) -> str:
        return os.path.join(self.run_dir, "cells", self.id)

    @property
    def json(self) -> dict:
        if self._json is None:
            path = os.path.join(self.dir, "cell.json")
            self._json = {}
            if os.path.isfile(path):
                with open(path, encoding="utf-8") as f:
                    self._json = json.load(f)
        return self._json

    @property
    def reason(self) -> str:
        return str(self.json.get("reason") or self.row.get("reason") or "")

    @property
    def failed_frame(self) -> Optional[int]:
        v = self.json.get("failed_frame")
        if v is None or (isinstance(v, float) and math.isnan(v)):
            return None
        try:
            return int(v)
        except (TypeError, ValueError):
            return None

    @property
    def warnings(self) -> List[dict]:
        """cell.json warnings as dicts {frame: int|None, message: str}.

        Accepts objects ({"frame": 3, "message": ...}), [frame, message] pairs and plain strings
        (a warning with no frame is listed in the report but cannot be marked on a time axis)."""
        out = []
        for w in self.json.get("warnings") or []:
            if isinstance(w, dict):
                frame = w.get("frame")
                msg = w.get("message", w.get("text", json.dumps(w)))
            elif isinstance(w, (list, tuple)) and len(w) == 2:
                frame, msg = w
            else:
                frame, msg = None, str(w)
            try:
                frame = int(frame) if frame is not None else None
            except (TypeError, ValueError):
                frame = None
            out.append({"frame": frame, "message": str(msg)})
        return out

    @property
    def frames_rows(self) -> List[Dict[str, str]]:
        if self._frames is None:
            self._frames = read_csv(os.path.join(self.dir, "frames.csv"))
        return self._frames

    @property
    def metrics_rows(self) -> List[Dict[str, str]]:
        if self._metrics is None:
            self._metrics = read_csv(os.path.join(self.dir, "metrics.csv"))
        return self._metrics

    @property
    def counters_rows(self) -> List[Dict[str, str]]:
        if self._counters is None:
            self._counters = read_csv(os.path.join(self.dir, "counters.csv"))
        return self._counters

    def pass_names(self) -> List[str]:
        """Passes in frames.csv, in first-seen order."""
        seen = {}
        for r in self.frames_rows:
            seen.setdefault(r["pass"], None)
        return list(seen)

    def pass_samples(self, name: str, clock: str = "auto") -> (np.ndarray, np.ndarray):
        """(frames, ms) of one pass over the measured frames, sorted by frame.

        clock "gpu" or "cpu" picks that column; "auto" is the harness's own rule for a pass's time (the
        one behind summary.csv's medians): the larger of the two clocks, i.e. where the pass ran. A GPU
        pass's CPU time is only its recording; a CPU pass (Embree photon tracing) still has a timestamp
        pair around it, whose difference is only the barriers'."""
        frames, values = [], []
        for r in self.frames_rows:
            if r.get("pass") != name:
                continue
            gpu, cpu = to_float(r.get("gpu_ms")), to_float(r.get("cpu_ms"))
            if clock == "gpu":
                v = gpu
            elif clock == "cpu":
                v = cpu
            else:
                v = cpu if math.isnan(gpu) else gpu if math.isnan(cpu) else max(gpu, cpu)
            if math.isnan(v):
                continue
            frames.append(int(to_float(r["frame"])))
            values.append(v)
        order = np.argsort(frames, kind="stable")
        return np.asarray(frames, dtype=int)[order], np.asarray(values, dtype=float)[order]

    def metric_classes(self) -> List[str]:
        seen = {}
        for r in self.metrics_rows:
            seen.setdefault(r.get("path_class", ""), None)
        return list(seen)

    def metric_references(self) -> List[str]:
        """The references this cell was scored against (metrics.csv's `reference` column), in order."""
        seen = {}
        for r in self.metrics_rows:
            seen.setdefault(r.get("reference") or FULL_REFERENCE, None)
        return list(seen)

    def primary_class(self) -> Optional[str]:
        """The path class the report shows first: "combined" (the composed image) when scored, else the
        first class in metrics.csv."""
        classes = self.metric_classes()
        if not classes:
            return None
        return PRIMARY_CLASS if PRIMARY_CLASS in classes else classes[0]

    def metric_series(self, metric: str, path_class: Optional[str] = None,
                      reference: str = FULL_REFERENCE) -> (np.ndarray, np.ndarray):
        """(frames, values) of one metrics.csv column (a metric, its <metric>_floor, ...) for one path
        class (default: primary_class()) against one reference (default: the full one)."""
        cls = path_class if path_class is not None else self.primary_class()
        if cls is None:
            return np.zeros(0, dtype=int), np.zeros(0)
        pts = [(int(to_float(r["frame"])), to_float(r.get(metric)))
               for r in self.metrics_rows
               if r.get("path_class", "") == cls and (r.get("reference") or FULL_REFERENCE) == reference]
        pts = [(f, v) for f, v in pts if not math.isnan(v)]
        pts.sort()
        return (np.asarray([p[0] for p in pts], dtype=int), np.asarray([p[1] for p in pts], dtype=float))

    def metric_mean(self, metric: str, path_class: Optional[str] = None,
                    reference: str = FULL_REFERENCE) -> float:
        _, v = self.metric_series(metric, path_class, reference)
        return float(np.mean(v)) if len(v) else math.nan

    def images(self) -> Dict[tuple, str]:
        """(kind, frame, class or None, ext) -> path for every file in images/ that follows the schema."""
        out = {}
        d = os.path.join(self.dir, "images")
        if not os.path.isdir(d):
            return out
        for name in sorted(os.listdir(d)):
            m = _IMAGE_RE.match(name)
            if m:
                out[(m.group(1), int(m.group(2)), m.group(3), m.group(4))] = os.path.join(d, name)
        return out


class Run:
    """A run directory: run.json, summary.csv and its cells."""

    def __init__(self, path: str):
        self.path = os.path.abspath(path)
        if not os.path.isdir(self.path):
            raise RunError(f"{path}: not a directory")
        summary = os.path.join(self.path, "summary.csv")
        if not os.path.isfile(summary):
            raise RunError(f"{summary}: missing (is {path} a photonbench run directory?)")
        run_json = os.path.join(self.path, "run.json")
        self.info: dict = {}
        if os.path.isfile(run_json):
            try:
                with open(run_json, encoding="utf-8") as f:
                    self.info = json.load(f)
            except json.JSONDecodeError as e:
                raise RunError(f"{run_json}:{e.lineno}:{e.colno}: {e.msg}") from e
        with open(summary, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            self.columns: List[str] = list(reader.fieldnames or [])
            rows = list(reader)
        missing = [c for c in ("cell", "scene", "technique", "status") if c not in self.columns]
        if missing:
            raise RunError(f"{summary}:1: missing column(s) {', '.join(missing)}")
        self.cells: List[Cell] = [Cell(self.path, r, i) for i, r in enumerate(rows)]

    @property
    def name(self) -> str:
        return os.path.basename(self.path.rstrip(os.sep))

    @property
    def commit(self) -> str:
        return str(self.info.get("git_commit") or "unknown")

    @property
    def device(self) -> str:
        d = self.info.get("device")
        if isinstance(d, dict):  # tolerate a structured device record: use its name
            d = d.get("name") or json.dumps(d, sort_keys=True)
        return str(d or "unknown")

    @property
    def param_columns(self) -> List[str]:
        return [c[len(PARAM_PREFIX):] for c in self.columns if c.startswith(PARAM_PREFIX)]

    @property
    def pass_columns(self) -> List[str]:
        return [c[len(PASS_PREFIX):-len(PASS_SUFFIX)] for c in self.columns
                if c.startswith(PASS_PREFIX) and c.endswith(PASS_SUFFIX)]

    def scenes(self) -> List[str]:
        return list(dict.fromkeys(c.scene for c in self.cells))

    def techniques(self) -> List[str]:
        return list(dict.fromkeys(c.technique for c in self.cells))

    def cells_of(self, scene: str) -> List[Cell]:
        return [c for c in self.cells if c.scene == scene]

    def cell(self, cell_id: str) -> Optional[Cell]:
        for c in self.cells:
            if c.id == cell_id:
                return c
        return None

    def swept_params(self, cells: List[Cell]) -> List[str]:
        """Parameters that take more than one value among `cells` of one technique (a sweep axis)."""
        out = []
        for p in self.param_columns:
            values = {format_param(c.params[p]) for c in cells if p in c.params}
            if len(values) > 1:
                out.append(p)
        return out

    def label(self, cell: Cell, with_technique: bool = True) -> str:
        """A short human label: technique plus the parameters that are swept within its technique."""
        same = [c for c in self.cells if c.technique == cell.technique and c.scene == cell.scene]
        swept = self.swept_params(same)
        parts = [f"{p}={format_param(cell.params[p])}" for p in swept if p in cell.params]
        setting = ", ".join(parts)
        if not with_technique:
            return setting or cell.technique
        return f"{cell.technique} ({setting})" if setting else cell.technique
