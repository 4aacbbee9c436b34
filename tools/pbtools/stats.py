"""The statistics behind "A beats B", "A equals B" and "this frame pops": Welch's t-test across
seeds, robust jump detection over an animation, and the spread of a metric across seeds.

Welch's t-test (Welch 1947; scipy.stats.ttest_ind with equal_var=False). With `seeds: K`, each seed
of a cell is an independent Monte Carlo run of the technique, so a metric's mean over the metric
frames of each seed is one independent sample of that cell's score; two cells' K samples are compared
without assuming equal variances. The per-frame values themselves are not independent samples (the
same frame of two seeds shares its scene content, consecutive frames their photons' scramble), which
is why the test is on per-seed means. "A beats B" is the one-sided test of A's mean score being better
(lower FLIP: `alternative` "less"), "A equals B" the two-sided one: a p-value below alpha rejects
equality. With one seed per cell no such test exists (the variance of the score is unknown), and
welch() says so rather than inventing a p-value.

Popping (popping_frames): a frame whose error jumps up from its neighbours by more than k robust
standard deviations of the series' jumps. The jump of frame i is v_i - max(v_{i-1}, v_{i+1}), its
rise above both neighbours, so a steady trend gives every frame the same jump and a dip makes no
pop of the frames beside it (the first and last frames, with one neighbour each, have no jump and
are never marked). A pop lowers the jumps of its two neighbours too, so it takes three of the
jumps: with fewer than about eight metric frames per cell the MAD is no longer robust to one pop
(score every frame or every few for a temporal study: frames.metrics_every). The robust standard deviation is 1.4826 times the median
absolute deviation of the jumps from their median (the MAD, a consistent estimator of the normal's
sigma that a few pops do not inflate). A frame pops when its jump exceeds the median jump by more
than k of them; k defaults to POPPING_K. Only rises count: a pop is a sudden error, and the frame
after it falls back by the same amount.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import List, Optional, Sequence

import numpy as np

from . import measures

POPPING_K = 4.0
ALPHA = 0.05  # the level a claim's p-value is read at


@dataclass
class Welch:
    test: str  # "Welch's t-test (one-sided)" / "(two-sided)", or why no test was possible
    p: float  # NaN when no test was possible
    t: float = math.nan
    df: float = math.nan
    n_a: int = 0
    n_b: int = 0

    @property
    def possible(self) -> bool:
        return math.isfinite(self.p)


def welch(a: Sequence[float], b: Sequence[float], alternative: str = "two-sided") -> Welch:
    """Welch's t-test of mean(a) against mean(b): alternative "two-sided" (equal means), "less"
    (mean(a) < mean(b)) or "greater". NaN values are dropped; each side needs two or more values."""
    from scipy import stats

    a = np.asarray([v for v in a if math.isfinite(v)], float)
    b = np.asarray([v for v in b if math.isfinite(v)], float)
    if len(a) < 2 or len(b) < 2:
        return Welch(f"not possible: {min(len(a), len(b))} seed(s) per cell (run with --seeds K, "
                     "K >= 2)", math.nan, n_a=len(a), n_b=len(b))
    sides = "two-sided" if alternative == "two-sided" else "one-sided"
    if np.var(a) == 0 and np.var(b) == 0:
        # No spread on either side (a deterministic technique): the means are equal or not, exactly.
        equal = a[0] == b[0]
        holds = {"two-sided": not equal, "less": a[0] < b[0], "greater": a[0] > b[0]}[alternative]
        return Welch(f"exact: no spread across seeds ({sides})", 0.0 if holds else 1.0,
                     n_a=len(a), n_b=len(b))
    r = stats.ttest_ind(a, b, equal_var=False, alternative=alternative)
    # Welch-Satterthwaite degrees of freedom.
    va, vb = np.var(a, ddof=1) / len(a), np.var(b, ddof=1) / len(b)
    df = (va + vb) ** 2 / (va ** 2 / (len(a) - 1) + vb ** 2 / (len(b) - 1))
    return Welch(f"Welch's t-test ({sides})", float(r.pvalue), float(r.statistic), float(df),
                 len(a), len(b))


def jumps(values: Sequence[float]) -> np.ndarray:
    """Each value's rise above both neighbours; NaN at the ends."""
    v = np.asarray(values, float)
    out = np.full(len(v), np.nan)
    if len(v) < 3:
        return out
    out[1:-1] = v[1:-1] - np.maximum(v[:-2], v[2:])
    return out


def popping_frames(frames: Sequence[int], values: Sequence[float], k: float = POPPING_K) -> List[int]:
    """The frames of a series (frame order) whose error pops (the module's rule). Needs three or more
    values; only the interior frames can pop; a series whose jumps all equal the median has none, and when the MAD is zero any rise
    above the median jump by more than 1e-9 of the series' scale pops."""
    v = np.asarray(values, float)
    if len(v) < 3:
        return []
    j = jumps(v)
    centre = float(np.nanmedian(j))
    sigma = measures.robust_sigma(j)
    tolerance = max(k * sigma, 1e-9 * float(np.max(np.abs(v))))
    return [int(f) for f, x in zip(frames, j) if np.isfinite(x) and x - centre > tolerance]


@dataclass
class Spread:
    n: int
    mean: float
    std: float  # sample standard deviation (ddof 1); NaN for one value
    min: float
    max: float


def spread(values: Sequence[float]) -> Optional[Spread]:
    v = np.asarray([x for x in values if math.isfinite(x)], float)
    if not len(v):
        return None
    std = float(np.std(v, ddof=1)) if len(v) > 1 else math.nan
    return Spread(len(v), float(np.mean(v)), std, float(np.min(v)), float(np.max(v)))
