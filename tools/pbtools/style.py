"""Paper styling for every figure.

Why matplotlib: it is the plotting library graphics and systems papers use, Debian packages it
(python3-matplotlib, no network at build or run time), and one figure object writes SVG (the HTML
report), PDF (LaTeX, with TrueType fonts embedded, as publishers require) and PNG from the same code.

Choices, each for a reason:
  * sizes in inches at a two-column paper's widths (3.39 in column, 7.0 in full text width), fonts 7-8 pt,
    so a figure dropped into a paper at 100% needs no rescaling and stays readable;
  * the Okabe-Ito palette (Okabe & Ito 2008, "Color Universal Design"), distinguishable under the common
    colour-vision deficiencies; yellow is left last because it vanishes on white;
  * every technique has a colour AND a marker (and settings of one technique a line style), so the
    figure survives greyscale printing and colour-blind readers;
  * deterministic output (no dates in PDF/SVG metadata, a fixed SVG hash salt), so re-running the
    report on the same data gives the same files.
"""

from __future__ import annotations

import os
from typing import Dict, Iterable, List, Tuple

import matplotlib

matplotlib.use("Agg")  # headless: never needs a display
import matplotlib.pyplot as plt  # noqa: E402

COLUMN_WIDTH_IN = 3.39
TEXT_WIDTH_IN = 7.0

# Okabe-Ito, reordered so the first colours are the most separable on white.
OKABE_ITO = ["#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#000000", "#F0E442"]
MARKERS = ["o", "s", "^", "D", "v", "P", "X", "*", "h", "<"]
LINESTYLES = ["-", "--", ":", "-."]
FAILED_COLOR = "#B00000"
WARNING_COLOR = "#E69F00"
PARETO_COLOR = "#555555"
FLOOR_COLOR = "#8C8C8C"  # noise floors and the band of scores they do not resolve

RC = {
    "font.family": "DejaVu Sans",
    "font.size": 7.5,
    "axes.titlesize": 8,
    "axes.labelsize": 7.5,
    "xtick.labelsize": 6.5,
    "ytick.labelsize": 6.5,
    "legend.fontsize": 6.5,
    "legend.frameon": False,
    "axes.linewidth": 0.6,
    "axes.spines.top": False,
    "axes.spines.right": False,
    "axes.grid": True,
    "grid.linewidth": 0.4,
    "grid.alpha": 0.35,
    "lines.linewidth": 1.1,
    "lines.markersize": 4.5,
    "xtick.major.width": 0.6,
    "ytick.major.width": 0.6,
    "savefig.dpi": 300,
    "savefig.bbox": "tight",
    "savefig.pad_inches": 0.02,
    "pdf.fonttype": 42,  # TrueType, not Type 3: publishers reject Type 3 fonts
    "ps.fonttype": 42,
    "svg.fonttype": "path",  # glyphs as paths: the SVG renders identically without the font installed
    "svg.hashsalt": "photonbench",
    "figure.dpi": 100,
}


def apply() -> None:
    plt.rcParams.update(RC)


class TechniqueStyle:
    """Colour and marker per technique, assigned in the run's technique order (the config's order), so
    a technique looks the same in every figure of one report."""

    def __init__(self, techniques: Iterable[str]):
        self.order: List[str] = list(dict.fromkeys(techniques))

    def index(self, technique: str) -> int:
        if technique not in self.order:
            self.order.append(technique)
        return self.order.index(technique)

    def color(self, technique: str) -> str:
        return OKABE_ITO[self.index(technique) % len(OKABE_ITO)]

    def marker(self, technique: str) -> str:
        return MARKERS[self.index(technique) % len(MARKERS)]

    def linestyle(self, setting_index: int) -> str:
        return LINESTYLES[setting_index % len(LINESTYLES)]


def pass_colors(names: List[str]) -> Dict[str, str]:
    """Stacked-bar segment colours, one per pass name across the whole report: Okabe-Ito without black
    and yellow (too heavy / too faint as areas), then Paul Tol's 'muted' scheme when there are more
    passes; the remainder "other" is always light grey."""
    palette = [c for c in OKABE_ITO if c not in ("#000000", "#F0E442")] + [
        "#332288", "#117733", "#999933", "#882255", "#44AA99", "#DDCC77", "#AA4499", "#88CCEE"]
    out = {n: palette[i % len(palette)] for i, n in enumerate(n for n in names if n != "other")}
    out["other"] = "#BBBBBB"
    return out


HATCHES = ["", "///", "...", "xxx", "\\\\\\", "ooo", "---", "+++"]


def save(fig, out_dir: str, stem: str) -> Dict[str, str]:
    """Writes stem.svg, stem.pdf and stem.png under out_dir; returns {ext: relative file name}."""
    os.makedirs(out_dir, exist_ok=True)
    files = {}
    for ext in ("svg", "pdf", "png"):
        name = f"{stem}.{ext}"
        path = os.path.join(out_dir, name)
        tmp = path + f".tmp.{ext}"
        metadata = {"Date": None} if ext in ("svg", "pdf") else {}
        if ext == "pdf":
            metadata["CreationDate"] = None
            metadata.pop("Date")
        fig.savefig(tmp, format=ext, metadata=metadata)
        os.replace(tmp, path)
        files[ext] = name
    return files


def new_figure(width: float, height: float, nrows: int = 1, ncols: int = 1, **kw) -> Tuple:
    apply()
    fig, axes = plt.subplots(nrows, ncols, figsize=(width, height), squeeze=False, **kw)
    return fig, axes


def close(fig) -> None:
    plt.close(fig)
