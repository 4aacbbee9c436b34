"""Reading one run directory, exactly as docs/architecture.md "Results" lays it out.

    RUN/run.json                     tool version, git_commit, resolved config, device, driver, CPU, OS, start/end
    RUN/summary.csv                  one row per cell (cell, scene, technique, status, frames, wall_ms_*,
                                     *_mean, param.<name>..., pass.<name>.ms_median...)
    RUN/cells/<cell>/cell.json       status ok|failed, reason, failed_frame, warnings, params, memory
    RUN/cells/<cell>/frames.csv      frame, pass, gpu_ms, cpu_ms  (pass "frame" is the whole frame)
    RUN/cells/<cell>/counters.csv    frame, name, value
    RUN/cells/<cell>/metrics.csv     frame, path_class, reference, the config's metrics (flip, ssim,
                                     psnr, rmse, relmse, mae: those named), <metric>_floor...,
                                     mse_unbiased, relmse_unbiased, flicker (a metric not named has
                                     no column: read as empty)
    RUN/cells/<cell>/images/         frame_NNNN.{exr,png}, flip_NNNN_<class>.png, reference_NNNN_<class>.png

The CSV files are read with pandas (read_table): the schema's text columns stay text, param.* are
parsed by param_value, everything else is numeric. Everything here is read-only and tolerant of
what a failed or interrupted cell leaves behind (a missing, empty or header-only file is an empty
table with the schema's columns, an empty or unparsable field is NaN, a column the file lacks reads
as empty), because a failed cell must be shown, never dropped; a row with more fields than its
header is bad input. Nothing in here parses a cell's id: cells are labelled from their scene,
technique and param.* columns.
"""

from __future__ import annotations

import json
import math
import os
import re
from typing import Dict, List, Optional, Sequence

import numpy as np
import pandas as pd
from pandas.api.types import is_bool_dtype, is_numeric_dtype

# The summary's fixed leading columns (docs/architecture.md); anything else is param.* or pass.*.ms_median.
SUMMARY_FIXED = [
    "cell", "scene", "technique", "status", "frames", "wall_ms_median", "wall_ms_p5",
    "wall_ms_p95", "flip_mean", "ssim_mean", "psnr_mean", "flip_floor", "ssim_floor", "psnr_floor",
]
SUMMARY_REQUIRED = ("cell", "scene", "technique", "status")
# Columns of summary.csv, match.csv and match_probes.csv that runs written before the frame time's
# columns named their clock and statistic still carry: each old name reads as the new one, so that
# compare, history and report still read an older run.
RENAMED_COLUMNS = {
    "frame_ms_median": "wall_ms_median", "frame_ms_p5": "wall_ms_p5", "frame_ms_p95": "wall_ms_p95",
    "frame_ms_n": "wall_ms_n", "probe_frame_ms": "probe_wall_ms_median",
}
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

# Columns of the run's CSV files that hold text; every other column (but param.*) is numeric.
TEXT_COLUMNS = frozenset({"cell", "scene", "technique", "status", "reason", "pass", "path_class",
                          "reference", "name"})
# What each per-cell file always has once read, whatever the file held.
FRAMES_COLUMNS = ("frame", "pass", "gpu_ms", "cpu_ms")
METRICS_COLUMNS = ("frame", "path_class", "reference")
COUNTERS_COLUMNS = ("frame", "name", "value")

# frames.csv's column behind each named clock (Cell.pass_times; "auto" is the harness's rule).
CLOCK_COLUMNS = {"gpu": "gpu_ms", "cpu": "cpu_ms", "process": "process_cpu_ms"}

_IMAGE_RE = re.compile(r"^(frame|flip|reference)_(\d+)(?:_(.+))?\.(png|exr)$")



class RunError(Exception):
    """A run directory that cannot be read (bad input: the command exits 2)."""


def param_value(text: str):
    """A param.* field: a number when it reads as one (so sweeps sort numerically), an int when
    written as one (no '.' or exponent), else the string; None when empty."""
    if text is None:
        return None
    text = str(text).strip()
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


def _frozen(a: np.ndarray) -> np.ndarray:
    a.flags.writeable = False
    return a


def _read_csv(path: str, **options) -> pd.DataFrame:
    """pd.read_csv, with a missing or empty file as an empty table and a malformed one (a row with
    more fields than the header, bytes that are not UTF-8) a RunError naming the file and line."""
    if not os.path.isfile(path):
        return pd.DataFrame()
    try:
        return pd.read_csv(path, encoding="utf-8", **options)
    except pd.errors.EmptyDataError:
        return pd.DataFrame()
    except (pd.errors.ParserError, UnicodeDecodeError) as e:
        raise RunError(f"{path}: {e}".strip()) from e


def current_name(column: str) -> str:
    """A run CSV's column under its current name (RENAMED_COLUMNS: an older run's name mapped)."""
    return RENAMED_COLUMNS.get(column, column)


def read_text_table(path: str) -> pd.DataFrame:
    """A CSV file as a table of text fields ("" where empty), its columns under their current
    names (an older run's frame_ms_median is wall_ms_median)."""
    table = _read_csv(path, dtype=str, keep_default_na=False, na_filter=False)
    return table.rename(columns={c: current_name(c) for c in table.columns
                                 if current_name(c) not in table.columns})


def _numeric(column: pd.Series) -> pd.Series:
    """A column as numbers, NaN where a field is empty or not a number (a column pandas read as
    booleans, "True"/"False", is not one)."""
    return pd.to_numeric(column.astype(str).where(column.notna(), ""), errors="coerce")


def typed(text: pd.DataFrame) -> pd.DataFrame:
    """A table read as text with its numeric columns converted (empty or unparsable fields NaN)."""
    out = text.copy()
    for col in out.columns:
        if col not in TEXT_COLUMNS and not col.startswith(PARAM_PREFIX):
            out[col] = _numeric(out[col])
    return out


def read_table(path: str, columns: Sequence[str] = ()) -> pd.DataFrame:
    """A per-cell CSV file: TEXT_COLUMNS as text ("" where empty), every other column parsed as
    numbers by pandas (NaN where empty or unparsable), `columns` added where the file lacks them."""
    table = _read_csv(path, dtype={c: str for c in TEXT_COLUMNS}, keep_default_na=False,
                      na_values=[""])
    for col in table.columns:
        column = table[col]
        if col in TEXT_COLUMNS:
            if column.isna().any():
                table[col] = column.fillna("")
        elif not is_numeric_dtype(column) or is_bool_dtype(column):
            table[col] = _numeric(column)
    for col in columns:
        if col not in table.columns:
            table[col] = "" if col in TEXT_COLUMNS else np.nan
    return table


class Cell:
    """One row of summary.csv plus what its cells/<cell>/ directory holds (loaded on first use)."""

    def __init__(self, run_dir: str, text: Dict[str, str], values: Dict[str, object],
                 params: Dict[str, object], index: int):
        self.run_dir = run_dir
        self._text = text  # the summary row as written
        self._values = values  # the same row, numeric columns converted
        # param.<name> columns this cell sets (other techniques' are empty)
        self.params: Dict[str, object] = params
        # Position in summary.csv: the config's order, for stable colours and sorting.
        self.index = index
        self._json: Optional[dict] = None
        self._frames: Optional[pd.DataFrame] = None
        self._metrics: Optional[pd.DataFrame] = None
        self._counters: Optional[pd.DataFrame] = None
        # Per-cell caches: pass samples by clock, metric series by (metric, class, reference).
        self._samples: Dict[str, Dict[str, tuple]] = {}
        self._metric_groups: Optional[Dict[tuple, np.ndarray]] = None  # (class, reference) -> rows
        self._series: Dict[tuple, tuple] = {}
        self._match_round: Optional[int] = None

    def __repr__(self) -> str:
        return f"Cell({self.id!r})"

    # -- summary row -------------------------------------------------------------------------------
    @property
    def id(self) -> str:
        return self._text["cell"]

    @property
    def scene(self) -> str:
        return self._text.get("scene", "")

    @property
    def technique(self) -> str:
        return self._text.get("technique", "")

    @property
    def status(self) -> str:
        return self._text.get("status", "").strip() or self.json.get("status", "unknown")

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    @property
    def match_round(self) -> Optional[int]:
        """A match run's re-measurement round r (1, 2, ...) of a found cell, None for any other
        cell: the same setting and seed again, for the time's spread; no seed of its own (Run reads
        the roles from RUN/match/cells.json)."""
        return self._match_round

    def text(self, column: str) -> str:
        """A summary.csv field as written ("" when the column is absent)."""
        return self._text.get(column, "")

    def value(self, column: str) -> float:
        """A numeric summary.csv field; NaN when empty, unparsable, absent or a text column."""
        v = self._values.get(column)
        return float(v) if isinstance(v, (int, float)) and not isinstance(v, bool) else math.nan

    def pass_medians(self) -> Dict[str, float]:
        """pass.<name>.ms_median columns with a value, name -> ms (nested names keep their '/')."""
        out = {}
        for key, v in self._values.items():
            is_pass = key.startswith(PASS_PREFIX) and key.endswith(PASS_SUFFIX)
            if is_pass and not math.isnan(self.value(key)):
                out[key[len(PASS_PREFIX):-len(PASS_SUFFIX)]] = float(v)
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
        return str(self.json.get("reason") or self._text.get("reason") or "")

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
    def frames(self) -> pd.DataFrame:
        """frames.csv: frame, pass, gpu_ms, cpu_ms (and process_cpu_ms on fenced runs)."""
        if self._frames is None:
            self._frames = read_table(os.path.join(self.dir, "frames.csv"), FRAMES_COLUMNS)
        return self._frames

    @property
    def metrics(self) -> pd.DataFrame:
        """metrics.csv, its `reference` column "full" where empty or absent (older runs)."""
        if self._metrics is None:
            m = read_table(os.path.join(self.dir, "metrics.csv"), METRICS_COLUMNS)
            m.loc[m["reference"] == "", "reference"] = FULL_REFERENCE
            self._metrics = m
        return self._metrics

    @property
    def counters(self) -> pd.DataFrame:
        if self._counters is None:
            self._counters = read_table(os.path.join(self.dir, "counters.csv"), COUNTERS_COLUMNS)
        return self._counters

    def counter_means(self) -> pd.Series:
        """Mean per frame of every counter with a value, name -> mean, in first-seen order."""
        c = self.counters.dropna(subset=["value"])
        return c.groupby("name", sort=False)["value"].mean()

    def pass_names(self) -> List[str]:
        """Passes in frames.csv, in first-seen order."""
        return list(pd.unique(self.frames["pass"]))

    def pass_times(self, clock: str = "auto") -> pd.DataFrame:
        """frame, pass, ms of every frames.csv row with a time on `clock`.

        clock "gpu", "cpu" or "process" picks gpu_ms, cpu_ms or process_cpu_ms (the CPU time of the
        cell's process in the pass, recorded on fenced runs; NaN where absent); "auto" is the
        harness's own rule for a pass's time (the one behind summary.csv's medians): the larger of
        gpu_ms and cpu_ms, i.e. where the pass ran. A GPU pass's CPU time is only its recording; a
        CPU pass (Embree photon tracing) still has a timestamp pair around it, whose difference is
        only the barriers'."""
        f = self.frames
        if clock in CLOCK_COLUMNS:
            column = CLOCK_COLUMNS[clock]
            ms = f[column].to_numpy(float) if column in f.columns else np.full(len(f), np.nan)
        else:
            ms = np.fmax(f["gpu_ms"].to_numpy(float), f["cpu_ms"].to_numpy(float))  # fmax skips NaN
        out = pd.DataFrame({"frame": f["frame"].to_numpy(float), "pass": f["pass"].to_numpy(),
                            "ms": ms})
        return out[~np.isnan(out["ms"]) & np.isfinite(out["frame"])]

    def pass_sums(self, passes, clock: str = "auto") -> pd.Series:
        """frame -> the summed time of the named passes the cell has in that frame (pass_times'
        clocks): a group of passes timed as one, such as a paper's stage."""
        t = self.pass_times(clock)
        return t[t["pass"].isin(passes)].groupby("frame")["ms"].sum()

    def pass_samples(self, name: str, clock: str = "auto") -> (np.ndarray, np.ndarray):
        """(frames, ms) of one pass over the measured frames, sorted by frame (pass_times' clocks).
        The arrays are shared between calls and read-only."""
        if clock not in self._samples:
            t = self.pass_times(clock).sort_values("frame", kind="stable")
            frames, ms = t["frame"].to_numpy(int), t["ms"].to_numpy(float)
            self._samples[clock] = {name: (_frozen(frames[rows]), _frozen(ms[rows]))
                                    for name, rows in t.groupby("pass", sort=False).indices.items()}
        none = (_frozen(np.zeros(0, dtype=int)), _frozen(np.zeros(0)))
        return self._samples[clock].get(name, none)

    def metric_classes(self) -> List[str]:
        return list(pd.unique(self.metrics["path_class"]))

    def metric_references(self) -> List[str]:
        """The references this cell was scored against (metrics.csv's `reference` column), in order."""
        return list(pd.unique(self.metrics["reference"]))

    def primary_class(self) -> Optional[str]:
        """The path class the report shows first: "combined" (the composed image) when scored, else the
        first class in metrics.csv."""
        classes = self.metric_classes()
        if not classes:
            return None
        return PRIMARY_CLASS if PRIMARY_CLASS in classes else classes[0]

    def metric_series(self, metric: str, path_class: Optional[str] = None,
                      reference: str = FULL_REFERENCE) -> (np.ndarray, np.ndarray):
        """(frames, values) of one metrics.csv column (a metric, its <metric>_floor, ...) for one
        path class (default: primary_class()) against one reference (default: the full one), sorted
        by frame. The arrays are shared between calls and read-only."""
        cls = path_class if path_class is not None else self.primary_class()
        key = (metric, cls, reference)
        if key not in self._series:
            m = self.metrics
            if self._metric_groups is None:
                self._metric_groups = m.groupby(["path_class", "reference"], sort=False).indices
            rows = self._metric_groups.get((cls, reference))
            frames, values = np.zeros(0), np.zeros(0)
            if rows is not None and metric in m.columns and metric not in TEXT_COLUMNS:
                frames, values = m["frame"].to_numpy(float)[rows], m[metric].to_numpy(float)[rows]
                keep = ~(np.isnan(frames) | np.isnan(values))
                frames, values = frames[keep], values[keep]
                order = np.lexsort((values, frames))
                frames, values = frames[order], values[order]
            self._series[key] = (_frozen(frames.astype(int)), _frozen(values))
        return self._series[key]

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


def match_rounds(run_dir: str) -> Dict[str, int]:
    """cell id -> its round number, for a match run's re-measurement cells (RUN/match/cells.json,
    role "round", numbered per setting in the order they ran); empty for any other run."""
    path = os.path.join(run_dir, "match", "cells.json")
    if not os.path.isfile(path):
        return {}
    with open(path, encoding="utf-8") as f:
        entries = json.load(f)
    counts: Dict[tuple, int] = {}
    out = {}
    for e in entries:
        if e.get("role") != "round":
            continue
        key = (e.get("scene"), e.get("technique"), json.dumps(e.get("params"), sort_keys=True))
        counts[key] = counts.get(key, 0) + 1
        out[str(e.get("id"))] = counts[key]
    return out


class Run:
    """A run directory: run.json, summary.csv (as `text`, the fields as written, and `summary`,
    numeric columns converted; one row per cell in the config's order) and its cells."""

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
        self.text = read_text_table(summary)
        self.columns: List[str] = [str(c) for c in self.text.columns]
        missing = [c for c in SUMMARY_REQUIRED if c not in self.columns]
        if missing:
            raise RunError(f"{summary}:1: missing column(s) {', '.join(missing)}")
        self.summary = typed(self.text)
        param_columns = [c for c in self.columns if c.startswith(PARAM_PREFIX)]
        # Object columns of int, float, str, or None where the cell does not set the parameter (kept
        # as objects: pandas would turn a column of ints and Nones into floats and NaNs).
        self.params = pd.DataFrame(
            {c: pd.Series([param_value(t) for t in self.text[c]], dtype=object)
             for c in param_columns}, index=self.text.index)
        self.cells: List[Cell] = []
        # (A frame without columns gives no records at all: a run whose techniques have no
        # parameters still has one cell per row.)
        param_rows = (self.params.to_dict("records") if param_columns
                      else [{} for _ in range(len(self.text))])
        for i, (text, values, params) in enumerate(zip(self.text.to_dict("records"),
                                                       self.summary.to_dict("records"),
                                                       param_rows)):
            set_params = {k[len(PARAM_PREFIX):]: v for k, v in params.items() if v is not None}
            self.cells.append(Cell(self.path, text, values, set_params, i))
        self._by_id: Dict[str, Cell] = {}
        for c in self.cells:
            self._by_id.setdefault(c.id, c)
        for cell_id, r in match_rounds(self.path).items():
            if cell_id in self._by_id:
                self._by_id[cell_id]._match_round = r
        self._label_params: Optional[Dict[tuple, List[str]]] = None

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
        return list(pd.unique(self.summary["scene"]))

    def techniques(self) -> List[str]:
        return list(pd.unique(self.summary["technique"]))

    def cells_of(self, scene: str) -> List[Cell]:
        return [self.cells[i] for i in np.flatnonzero(self.summary["scene"].to_numpy() == scene)]

    def cell(self, cell_id: str) -> Optional[Cell]:
        return self._by_id.get(cell_id)

    def swept_params(self, cells: List[Cell]) -> List[str]:
        """Parameters that take more than one value among `cells` of one technique (a sweep axis)."""
        rows = self.params.iloc[[c.index for c in cells]]
        return [p for p in self.param_columns
                if rows[PARAM_PREFIX + p].dropna().map(format_param).nunique() > 1]

    def distinguishing_params(self, cells: List[Cell]) -> List[str]:
        """Parameters that tell `cells` of one technique apart: swept ones, and ones that some of them
        set and others leave unset (a technique listed twice, once with a parameter and once
        without, is two settings however few values the parameter takes)."""
        rows = self.params.iloc[[c.index for c in cells]]
        return [p for p in self.param_columns
                if rows[PARAM_PREFIX + p].map(lambda v: "" if v is None else format_param(v)).nunique() > 1]

    def _seed_axis(self) -> bool:
        """Whether summary.csv's `seed` column holds more than one seed (a seed axis)."""
        return "seed" in self.columns and self.text["seed"].replace("", np.nan).dropna().nunique() > 1

    def label(self, cell: Cell, with_technique: bool = True, with_seed: bool = True) -> str:
        """A short human label: technique plus the parameters that tell the cell from the
        technique's other cells in its scene (distinguishing_params)."""
        if self._label_params is None:
            groups = self.summary.groupby(["scene", "technique"], sort=False).indices
            self._label_params = {key: self.distinguishing_params([self.cells[i] for i in rows])
                                  for key, rows in groups.items()}
        named = self._label_params[(cell.scene, cell.technique)]
        parts = [f"{p}={format_param(cell.params[p])}" for p in named if p in cell.params]
        # `run --seeds K`: K cells of one setting (with_seed False: the setting, for all K)
        if with_seed and cell.text("seed") and self._seed_axis():
            parts.append(f"seed={cell.text('seed')}")
        # A match run's re-measurement: the found cell's setting again, marked as its round.
        if cell.match_round is not None:
            parts.append(f"round {cell.match_round}")
        setting = ", ".join(parts)
        if not with_technique:
            return setting or cell.technique
        return f"{cell.technique} ({setting})" if setting else cell.technique
