"""The summary as tables: CSV (for scripts and spreadsheets), LaTeX with booktabs (for papers;
rendered by pandas' Styler) and the rows of the HTML report's tables (templates/report.html.j2).
The best successful value per scene and column is set in bold; failed cells stay in the table with
their status. A score within RESOLVE_FACTOR times its noise floor (floors.py) is marked unresolved:
a dagger in LaTeX, an asterisk and the class "unresolved" in HTML, resolved_<metric> = 0 in the
CSV. The floor table lists every score of every cell, class and reference beside its floor.

Every CSV file the tools write goes through write_csv, so they share one convention."""

from __future__ import annotations

import math
from typing import Dict, List, Optional, Sequence

import numpy as np
import pandas as pd

from . import floors, measures
from .rundata import Run

# (key, heading, LaTeX heading, decimals, lower is better or None when not ranked). Times are
# lower-is-better; each metric's direction and heading come from measures.py.
SUMMARY_COLUMNS = [
    ("frames", "frames", "frames", 0, None),
    # The frame's wall-clock time (the whole timed region, CPU and GPU), its median and percentiles
    # over the measured frames: named so beside compare's CPU-time floors and history's medians.
    ("wall_ms_median", "wall median ms", r"wall median [ms]", 2, True),
    ("wall_ms_p5", "wall p5 ms", r"wall p5 [ms]", 2, None),
    ("wall_ms_p95", "wall p95 ms", r"wall p95 [ms]", 2, None),
    ("flip_mean", "FLIP", measures.latex_heading("flip"), 4, measures.lower_is_better("flip")),
    ("ssim_mean", "SSIM", measures.latex_heading("ssim"), 4, measures.lower_is_better("ssim")),
    ("psnr_mean", "PSNR dB", measures.latex_heading("psnr"), 2, measures.lower_is_better("psnr")),
    ("flip_floor", "FLIP floor", r"\textsc{Flip} floor", 4, None),
    ("ssim_floor", "SSIM floor", r"SSIM floor", 4, None),
    ("psnr_floor", "PSNR floor", r"PSNR floor", 2, None),
]
# The score columns read against a floor column: summary key -> metric (its floor is <metric>_floor).
FLOORED = {"flip_mean": "flip", "ssim_mean": "ssim", "psnr_mean": "psnr"}
UNRESOLVED_TITLE = f"within {floors.RESOLVE_FACTOR:g}x its noise floor: unresolved"
FAILED_REASON_CHARS = 60  # of a failed cell's reason in the LaTeX table

_LATEX_ESCAPES = {"&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#", "_": r"\_", "{": r"\{", "}": r"\}",
                  "~": r"\textasciitilde{}", "^": r"\textasciicircum{}", "\\": r"\textbackslash{}"}


def latex_escape(text: str) -> str:
    return "".join(_LATEX_ESCAPES.get(ch, ch) for ch in str(text))


def _fmt(v: float, decimals: int) -> str:
    if v is None or not math.isfinite(v):
        return ""
    return f"{v:.{decimals}f}"


def _csv_field(v):
    if v is None:
        return ""
    if isinstance(v, (bool, np.bool_)):
        return int(v)
    if isinstance(v, float):
        return f"{v:.6g}" if math.isfinite(v) else ""
    return v


def _flags(values: pd.Series, test) -> np.ndarray:
    """test() of every value of an object column (resolved: True, False or None) as booleans."""
    return np.fromiter((bool(test(v)) for v in values), dtype=bool, count=len(values))


def write_csv(path: str, table: pd.DataFrame) -> None:
    """The tools' CSV convention: numbers to 6 significant digits, missing and non-finite values
    empty, booleans 0/1, and CRLF line ends (RFC 4180's, and Python's csv module's, which wrote
    these files before pandas did)."""
    table.applymap(_csv_field).to_csv(path, index=False, lineterminator="\r\n", encoding="utf-8")


# -- the summary ----------------------------------------------------------------------------------

def summary_table(run: Run) -> pd.DataFrame:
    """One row per cell, in the run's order: scene, technique, setting (the swept parameters'
    values, "" when none), cell, status, reason, SUMMARY_COLUMNS, and resolved_<metric> (True,
    False, None: no floor) for each FLOORED score."""
    s = run.summary
    settings = [run.label(c, with_technique=False) for c in run.cells]
    table = pd.DataFrame({
        "scene": s["scene"], "technique": s["technique"],
        "setting": [st if st != c.technique else "" for st, c in zip(settings, run.cells)],
        "cell": s["cell"], "status": [c.status for c in run.cells],
        "reason": [c.reason for c in run.cells]})
    for key, *_ in SUMMARY_COLUMNS:
        table[key] = s[key].astype(float) if key in s.columns else np.nan
    for key, metric in FLOORED.items():
        table[f"resolved_{metric}"] = pd.Series(
            [floors.resolved(metric, v, f) for v, f in zip(table[key], table[f"{metric}_floor"])],
            index=table.index, dtype=object)
    return table


def summary_rows(run: Run) -> List[Dict[str, object]]:
    """summary_table as one dict per cell."""
    return summary_table(run).to_dict("records")


def _best_resolved(table: pd.DataFrame, key: str, metric: str, lower: bool) -> pd.Series:
    """Per row: whether its scene's best score in `key` is resolved from the scene's runner-up, the
    gap larger than their two floors together (verdict.py's rule; floors.order_holds_in_worst_case).
    A scene with one scored cell, or without floors, has no resolved best."""
    out = pd.Series(False, index=table.index)
    floor_key = f"{metric}{floors.FLOOR_SUFFIX}"
    usable = (table["status"] == "ok") & np.isfinite(table[key])
    for _, rows in table[usable].groupby("scene", sort=False):
        ranked = rows.sort_values(key, ascending=lower, kind="stable")
        if len(ranked) < 2:
            continue
        a, b = ranked.iloc[0], ranked.iloc[1]
        fa, fb = a.get(floor_key, math.nan), b.get(floor_key, math.nan)
        if math.isfinite(fa) and math.isfinite(fb) and floors.order_holds_in_worst_case(
                metric, a[key], fa, b[key], fb):
            out[table["scene"] == a["scene"]] = True
    return out


def best_mask(table: pd.DataFrame) -> pd.DataFrame:
    """For the ranked columns: True where a successful cell's value is its scene's best among the
    successful cells, to the digits shown (a tie to the digits shown is bold twice). A score is
    bold only where the best is resolved from the runner-up (_best_resolved): an order the
    reference's noise may have made is no best."""
    usable = table["status"] == "ok"
    mask = pd.DataFrame(index=table.index)
    for key, _, _, decimals, lower in SUMMARY_COLUMNS:
        if lower is None:
            continue
        values = table[key].where(usable & np.isfinite(table[key]))
        best = values.groupby(table["scene"], sort=False).transform("min" if lower else "max")
        shown = values.map(lambda v: _fmt(v, decimals))
        mask[key] = values.notna() & (shown == best.map(lambda v: _fmt(v, decimals)))
        if key in FLOORED:
            mask[key] &= _best_resolved(table, key, FLOORED[key], lower)
    return mask


def unresolved_mask(table: pd.DataFrame) -> pd.DataFrame:
    """For the FLOORED columns: True where a successful cell's score is within its floor's reach."""
    usable = table["status"] == "ok"
    return pd.DataFrame({key: usable & _flags(table[f"resolved_{metric}"], lambda r: r is False)
                         for key, metric in FLOORED.items()}, index=table.index)


def write_summary_csv(run: Run, path: str) -> None:
    table = summary_table(run)
    header = (["scene", "technique", "setting", "cell", "status"] + [k for k, *_ in SUMMARY_COLUMNS]
              + [f"resolved_{m}" for m in FLOORED.values()] + ["reason"])
    write_csv(path, table[header])


def _styled_latex(cells: pd.DataFrame, headers: List[str], column_format: str,
                  bold: Optional[pd.DataFrame] = None, escaped: Sequence[int] = ()) -> str:
    """A booktabs tabular by pandas' Styler from a table of display strings: `headers` are the LaTeX
    column headings, `escaped` the columns whose text Styler escapes (tables.latex_escape), `bold` a
    boolean mask of cells set in \\textbf."""
    styler = cells.style.hide(axis="index").format_index(lambda i: headers[i], axis="columns")
    if escaped:
        styler = styler.format(latex_escape, subset=list(escaped))
    if bold is not None:
        props = bold.reindex(index=cells.index, columns=cells.columns, fill_value=False)
        textbf = props.applymap(lambda b: "textbf: --rwrap;" if b else "")  # \textbf{value}
        styler = styler.apply(lambda _: textbf, axis=None)
    return styler.to_latex(column_format=column_format, hrules=True)


def summary_latex(run: Run) -> str:
    """A booktabs table (needs \\usepackage{booktabs}); one block per scene separated by
    \\midrule. A failed cell keeps its row: its frame count, then its reason, set over the empty
    number columns."""
    table = summary_table(run)
    bold, loose = best_mask(table), unresolved_mask(table)
    keys = [k for k, *_ in SUMMARY_COLUMNS]
    # Scene: named on a scene's first row, after a \midrule from the scene before (a \midrule
    # opening a row's first cell is where booktabs expects it: right after the previous row's \\).
    first = table["scene"] != table["scene"].shift()
    scene = [("" if i == 0 else "\\midrule\n") + latex_escape(s) if f else ""
             for i, (s, f) in enumerate(zip(table["scene"], first))]
    cells = pd.DataFrame({0: scene, 1: table["technique"], 2: table["setting"]})
    for j, (key, _, _, decimals, _) in enumerate(SUMMARY_COLUMNS, start=3):
        text = table[key].map(lambda v: _fmt(v, decimals) or "--")
        if key in loose:
            text = text.where(~loose[key], text + r"$^\dagger$")
        cells[j] = text
    for i in np.flatnonzero(table["status"] != "ok"):
        frames = table["frames"].iat[i]
        reason = latex_escape(table["reason"].iat[i][:FAILED_REASON_CHARS])
        cells.iloc[i, 3] = str(int(frames)) if math.isfinite(frames) else "--"
        # \rlap: the reason runs on over the empty cells to its right without widening its column.
        note = r"\emph{failed}" + (": " + reason if reason else "")
        cells.iloc[i, 4] = r"\multicolumn{1}{l}{\rlap{" + note + "}}"
        cells.iloc[i, 5:] = ""
    bold_cells = pd.DataFrame({3 + keys.index(k): bold[k] for k in bold.columns}, index=table.index)
    headers = ["Scene", "Technique", "Setting"] + [h for _, _, h, _, _ in SUMMARY_COLUMNS]
    out = [r"% Generated by photonbench report from summary.csv; needs \usepackage{booktabs}.",
           _styled_latex(cells, headers, "lll" + "r" * len(SUMMARY_COLUMNS), bold_cells,
                         escaped=[1, 2])]
    if loose.to_numpy().any():
        out.append(rf"% $^\dagger$: within {floors.RESOLVE_FACTOR:g}x the reference's noise floor "
                   "(unresolved).\n")
    return "".join(line if line.endswith("\n") else line + "\n" for line in out)


def passes_latex(run: Run, scene: str) -> str:
    """Median ms per pass (columns: top-level passes in run order, then the frame) for one scene."""
    cells = run.cells_of(scene)
    passes = [p for p in run.pass_columns
              if "/" not in p and any(p in c.pass_medians() for c in cells)]
    rows = []
    for c in cells:
        med = c.pass_medians()
        setting = run.label(c, with_technique=False)
        rows.append([latex_escape(c.technique) + ("" if c.ok else r" (\emph{failed})"),
                     "" if setting == c.technique else setting]
                    + [_fmt(med.get(p, math.nan), 2) or "--" for p in passes]
                    + [_fmt(c.value("wall_ms_median"), 2) or "--"])
    headers = ["Technique", "Setting"] + [latex_escape(p) for p in passes] + ["frame"]
    table = pd.DataFrame(rows, columns=range(len(headers)))
    return (r"% Generated by photonbench report; median ms per pass; needs \usepackage{booktabs}."
            + "\n" + _styled_latex(table, headers, "ll" + "r" * (len(passes) + 1), escaped=[1]))


def summary_view(run: Run) -> dict:
    """The summary table of the HTML report: headings, and per cell its text fields and each
    column's shown value, bold (best in its scene) and unresolved flags."""
    table = summary_table(run)
    bold, loose = best_mask(table), unresolved_mask(table)
    rows = []
    for i, r in enumerate(table.to_dict("records")):
        values = []
        for key, _, _, decimals, _ in SUMMARY_COLUMNS:
            values.append({"text": _fmt(r[key], decimals),
                           "bold": bool(key in bold and bold[key].iat[i]),
                           "unresolved": bool(key in loose and loose[key].iat[i])})
        rows.append({"ok": r["status"] == "ok", "scene": r["scene"], "technique": r["technique"],
                     "setting": r["setting"], "status": r["status"], "reason": r["reason"],
                     "values": values})
    headers = ["scene", "technique", "setting", "status"] + [h for _, h, *_ in SUMMARY_COLUMNS]
    return {"headers": headers, "rows": rows, "unresolved_title": UNRESOLVED_TITLE}


# -- noise floors ------------------------------------------------------------------------------------

FLOOR_HEADER = ["scene", "technique", "setting", "cell", "reference", "path_class", "metric", "mean",
                "floor", "floor_ratio", "resolved"]


def floor_rows(run: Run) -> pd.DataFrame:
    """Every successful cell's mean score of each metric, path class and reference beside its mean floor
    (metrics.csv), with floor_ratio (floors.floor_ratio) and resolved (True, False, None: no floor)."""
    rows = []
    columns = [m + suffix for m in floors.FLOOR_METRICS for suffix in ("", floors.FLOOR_SUFFIX)]
    for c in run.cells:
        if not c.ok:
            continue
        setting = run.label(c, with_technique=False)
        metrics = c.metrics.reindex(columns=list(c.metrics.columns) + [
            col for col in columns if col not in c.metrics.columns])
        # Means over the metric frames (NaNs skipped) per reference and path class.
        means = metrics.groupby(["reference", "path_class"], sort=False)[columns].mean()
        for reference in c.metric_references():
            for cls in c.metric_classes():
                if (reference, cls) not in means.index:
                    continue
                for m in floors.FLOOR_METRICS:
                    mean = float(means.at[(reference, cls), m])
                    if not math.isfinite(mean):
                        continue
                    floor = float(means.at[(reference, cls), m + floors.FLOOR_SUFFIX])
                    rows.append({"scene": c.scene, "technique": c.technique,
                                 "setting": "" if setting == c.technique else setting, "cell": c.id,
                                 "reference": reference, "path_class": cls, "metric": m, "mean": mean,
                                 "floor": floor, "floor_ratio": floors.floor_ratio(m, mean, floor),
                                 "resolved": floors.resolved(m, mean, floor)})
    table = pd.DataFrame(rows, columns=FLOOR_HEADER)
    table["resolved"] = table["resolved"].astype(object)
    return table


def write_floors_csv(rows: pd.DataFrame, path: str) -> None:
    write_csv(path, rows[FLOOR_HEADER])


def _unresolved_why(run: Run, row: dict) -> str:
    """An unresolved score's reason from its reference's record in cell.json (the frame whose
    reference stopped at the largest error), with the reference that would resolve it."""
    records = [r for r in run.cell(row["cell"]).json.get("references", [])
               if r.get("reference") == row["reference"] and r.get("path_class") == row["path_class"]]
    if not records:
        return "its reference's record is missing from cell.json"
    worst = max(records, key=lambda r: r.get("rel_error", 0.0))
    return floors.finer_reference(row["floor_ratio"], worst.get("rel_error", 0.0),
                                  max(r.get("seconds", 0.0) for r in records),
                                  worst.get("stopped_by", ""))


def floors_view(run: Run, rows: pd.DataFrame) -> dict:
    """The report's noise-floor section: counts, the unresolved FLIP scores named up front (the
    issue's criterion), then every score against its floor, one row per cell, reference and
    class."""
    floored = rows.loc[_flags(rows["resolved"], lambda r: r is not None)]
    loose = floored.loc[_flags(floored["resolved"], lambda r: r is False)]
    flip_loose = loose[loose["metric"] == "flip"]
    metrics = [m for m in floors.FLOOR_METRICS if (rows["metric"] == m).any()]
    groups = []
    by_score = rows.groupby(["cell", "reference", "path_class"], sort=False)
    for (cell_id, reference, cls), group in by_score:
        cell = run.cell(cell_id)
        by_metric = {r["metric"]: r for r in group.to_dict("records")}
        scores = []
        for m in metrics:
            r = by_metric.get(m)
            if r is None:
                scores.append(None)
                continue
            floor = "" if not math.isfinite(r["floor"]) else f" / {r['floor']:.4g}"
            ratio = "" if not math.isfinite(r["floor_ratio"]) else f" ({r['floor_ratio']:.1f}x)"
            scores.append({"text": f"{r['mean']:.4g}{floor}{ratio}",
                           "unresolved": r["resolved"] is False})
        groups.append({"scene": cell.scene, "label": run.label(cell), "reference": reference,
                       "path_class": cls, "scores": scores})
    return {
        "any": len(floored) > 0, "factor": f"{floors.RESOLVE_FACTOR:g}", "loose": len(loose),
        "floored": len(floored), "flip_loose": len(flip_loose),
        "flip_floored": int((floored["metric"] == "flip").sum()),
        "flip_rows": [{"scene": r["scene"], "label": run.label(run.cell(r["cell"])),
                       "reference": r["reference"], "path_class": r["path_class"],
                       "mean": f"{r['mean']:.4f}", "floor": f"{r['floor']:.4f}",
                       "ratio": f"{r['floor_ratio']:.2f}x", "why": _unresolved_why(run, r)}
                      for r in flip_loose.to_dict("records")],
        "metrics": metrics, "groups": groups}
