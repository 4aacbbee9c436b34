"""What the quantities a run records mean, in one place for every tool: which way each metric is
better, how it is labelled and what unit it carries, how a score becomes a distance from the
reference (floors) or the error quantity that compare compares, and the robust noise formulas.

Metrics (metrics.csv columns; summary.csv has <metric>_mean and <metric>_floor):

    metric  better  distance from the reference    error compared by `compare`
    flip    lower   FLIP                           FLIP
    ssim    higher  1 - SSIM                       1 - SSIM
    psnr    higher  10^(-PSNR/20) (display RMS)    10^(-PSNR/10): the MSE it stands for
    rmse    lower   RMSE                           RMSE
    relmse  lower   sqrt(relMSE) (a weighted RMS)  relMSE

The distance is what floors.py reads a score against its floor with (a norm of X - R where one
exists, so the triangle inequality bounds the reference's noise); the error is what a relative
change of a metric means to a reader: PSNR is a log of the MSE, so a drop of d dB is an MSE ratio
of 10^(d/10), and relMSE is already a squared error. Times (frame and pass medians, ms) are
lower-is-better.

Noise: the per-sample standard deviation of a series whose level drifts slowly (frame times over an
animation, a pass's medians over commits) is estimated from successive differences, which a slow
drift or one step in level barely moves: for independent noise of s.d. sigma, x[i] - x[i-1] has
s.d. sigma x sqrt(2), and the normal-consistent MAD of the differences (scipy's
median_abs_deviation, scale "normal": 1.4826 x MAD) estimates that robustly against spikes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Tuple

import numpy as np
from scipy import stats


@dataclass(frozen=True)
class Metric:
    name: str  # the metrics.csv column
    label: str  # axis label in figures
    latex: str  # LaTeX column heading (the direction arrow is added from lower_is_better)
    unit: str  # unit in exported benchmark entries
    lower_is_better: bool
    distance: Callable[[float], float]  # score -> distance from the reference (0: identical)
    from_distance: Callable[[float], float]  # the inverse
    error: Callable[[float], float]  # score -> the error quantity a relative change is taken of


def _psnr_from_distance(d: float) -> float:
    return -20.0 * math.log10(d) if d > 0 else math.inf


METRICS = {m.name: m for m in (
    Metric("flip", "FLIP", r"\textsc{Flip}", "FLIP", True, lambda v: v, lambda d: d, lambda v: v),
    Metric("ssim", "SSIM", "SSIM", "SSIM", False, lambda v: 1.0 - v, lambda d: 1.0 - d,
           lambda v: 1.0 - v),
    Metric("psnr", "PSNR [dB]", "PSNR [dB]", "dB", False, lambda v: 10.0 ** (-v / 20.0),
           _psnr_from_distance, lambda v: 10.0 ** (-v / 10.0)),
    Metric("rmse", "RMSE", "RMSE", "RMSE", True, lambda v: v, lambda d: d, lambda v: v),
    Metric("relmse", "relMSE", "relMSE", "relMSE", True, lambda v: math.sqrt(max(v, 0.0)),
           lambda d: d * d, lambda v: v),
)}


def metric(name: str) -> Metric:
    try:
        return METRICS[name]
    except KeyError:
        raise ValueError(f"unknown metric {name!r} (known: {', '.join(METRICS)})") from None


def lower_is_better(name: str) -> bool:
    return metric(name).lower_is_better


def latex_heading(name: str) -> str:
    """The metric's LaTeX heading with its direction: an arrow pointing to better values."""
    m = metric(name)
    return m.latex + (r"~$\downarrow$" if m.lower_is_better else r"~$\uparrow$")


def distance(name: str, value: float) -> float:
    """A score as a distance from the reference (0: identical); NaN when the value is missing."""
    m = metric(name)
    if value is None or not math.isfinite(value):
        return math.nan
    return m.distance(value)


def from_distance(name: str, d: float) -> float:
    """The inverse of distance(): the score at distance d."""
    m = metric(name)
    if not math.isfinite(d):
        return math.nan
    return m.from_distance(d)


def error_change(name: str, base: float, new: float) -> float:
    """Relative change (%) of the error quantity behind a metric; positive means worse. A base
    error of zero makes any new error an infinite change (and none no change)."""
    if not (math.isfinite(base) and math.isfinite(new)):
        return math.nan
    m = metric(name)
    eb, en = m.error(base), m.error(new)
    if eb <= 0:
        return 0.0 if en <= 0 else math.inf
    return (en / eb - 1.0) * 100.0


def successive_difference_sigma(samples) -> float:
    """Robust per-sample standard deviation of a series from its successive differences (module
    docstring); NaN with fewer than 3 samples."""
    x = np.asarray(samples, dtype=float)
    if len(x) < 3:
        return math.nan
    return float(stats.median_abs_deviation(np.diff(x), scale="normal")) / math.sqrt(2.0)


def robust_sigma(samples) -> float:
    """The normal-consistent MAD (1.4826 x the median absolute deviation from the median) of the
    finite samples: a standard deviation that a few outliers do not inflate; NaN when none."""
    x = np.asarray(samples, float)
    x = x[np.isfinite(x)]
    return float(stats.median_abs_deviation(x, scale="normal")) if len(x) else math.nan


def percentile_range(samples, low: float = 5.0, high: float = 95.0) -> Tuple[float, float]:
    """(p5, p95) of the samples by linear interpolation between order statistics, the rule of the
    harness's summary.csv (harness/src/cell/stats.cpp); NaNs when there are none."""
    x = np.asarray(samples, dtype=float)
    if len(x) == 0:
        return math.nan, math.nan
    lo, hi = np.percentile(x, [low, high])
    return float(lo), float(hi)


def coefficient_of_variation(samples) -> float:
    """s.d. / mean (population s.d.), NaN for fewer than two samples or a non-positive mean."""
    x = np.asarray(samples, dtype=float)
    if len(x) < 2 or not x.mean() > 0:
        return math.nan
    return float(stats.variation(x))
