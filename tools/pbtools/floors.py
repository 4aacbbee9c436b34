"""Scores read against their noise floors: when a score measures the technique, and when it measures
the reference's own noise.

A metric row of metrics.csv carries, beside each score m(R, X) of a technique X against the reference
R, the score's floor <metric>_floor = E m(R, T): what the true image T itself would score against this
reference (harness/src/metrics/noise_floor.h says how the harness estimates it). Reading a score
against its floor needs a common scale, so every metric is first turned into a *distance* from the
reference, zero for a perfect match (measures.distance, which holds every metric's definitions):

    flip    FLIP itself                        rmse    RMSE itself
    ssim    1 - SSIM                           relmse  sqrt(relMSE)  (a weighted RMS error)
    psnr    10^(-PSNR / 20)  (the RMS error of the display-encoded values PSNR is computed from)

RMSE, the display RMS error and sqrt(relMSE) are norms of X - R, so the triangle inequality bounds
what the reference's noise can do to a score: |d(R, X) - d(T, X)| <= d(R, T), the floor. FLIP and
1 - SSIM are not norms but behave alike (they grow with the difference and saturate); the same rules
are applied to them as to the norms.

    resolved score       d(score) >= RESOLVE_FACTOR x d(floor): the technique's own error is at least
                         RESOLVE_FACTOR times what noise alone scores. For a norm, the noise then
                         inflates the score by at most 1/RESOLVE_FACTOR (25%), and by about
                         1 - sqrt(1 - 1/16) = 3% when the two errors are independent (they add in
                         quadrature). Below, the cell is "unresolved": its score may be the reference's.
    resolved comparison  the order of two scores holds against the true image, by either of:
                         * worst case: |d(a) - d(b)| > d(floor a) + d(floor b). By the triangle
                           inequality each score is within its floor of the score against the true
                           image, so a difference beyond both floors has the same sign against it,
                           whatever the noise;
                         * both scores resolved and different. A technique's error is independent of
                           the reference's noise, so the two add in quadrature, d^2 = t^2 + f^2 (t the
                           distance from the true image), and t = sqrt(d^2 - f^2) keeps the order of d
                           when the floors are equal (one reference), or is checked when they are not.
                           Near the floor this model fails (FLIP saturates, the cross term of error and
                           noise is no longer small), hence the RESOLVE_FACTOR condition.
                         Otherwise the comparison is "unresolved": the order may be the noise's.

A score without a floor (a run from before floors existed, or an empty field) is neither resolved nor
unresolved: None.
"""

from __future__ import annotations

import math
from typing import Optional

from .measures import METRICS, distance, from_distance

RESOLVE_FACTOR = 4.0
FLOOR_SUFFIX = "_floor"
FLOOR_METRICS = tuple(METRICS)  # flip, ssim, psnr, rmse, relmse: every metric has a floor


def floor_ratio(metric: str, value: float, floor: float) -> float:
    """d(score) / d(floor): how many times its noise floor a score lies; inf for a noiseless
    reference, NaN when either is missing."""
    dv, df = distance(metric, value), distance(metric, floor)
    if math.isnan(dv) or math.isnan(df):
        return math.nan
    if df <= 0:
        return math.inf if dv > 0 else math.nan
    return dv / df


def resolved(metric: str, value: float, floor: float, factor: float = RESOLVE_FACTOR) -> Optional[bool]:
    """True when the score is at least `factor` times its floor, False when within it, None when
    unknown (no floor)."""
    r = floor_ratio(metric, value, floor)
    return None if math.isnan(r) else r >= factor


def order_holds_in_worst_case(metric: str, a: float, floor_a: float, b: float, floor_b: float) -> bool:
    """|d(a) - d(b)| > d(floor_a) + d(floor_b): the triangle-inequality rule (module docstring)."""
    return abs(distance(metric, a) - distance(metric, b)) > distance(metric, floor_a) + distance(metric, floor_b)


def comparison_resolved(metric: str, a: float, floor_a: float, b: float, floor_b: float) -> Optional[bool]:
    """True when the order of a and b holds against the true image (module docstring: the worst-case
    rule, or both scores resolved with their quadrature-corrected distances in the same order), False
    when it may be the reference's noise (equal scores included), None without floors."""
    da, db = distance(metric, a), distance(metric, b)
    fa, fb = distance(metric, floor_a), distance(metric, floor_b)
    if any(math.isnan(v) for v in (da, db, fa, fb)):
        return None
    if order_holds_in_worst_case(metric, a, floor_a, b, floor_b):
        return True
    if da == db or not (resolved(metric, a, floor_a) and resolved(metric, b, floor_b)):
        return False
    ta, tb = math.sqrt(da * da - fa * fa), math.sqrt(db * db - fb * fb)
    return (ta < tb) == (da < db) and ta != tb


def unresolved_line(metric: str, floor: float, factor: float = RESOLVE_FACTOR) -> float:
    """The score at `factor` times the floor: scores on the floor's side of it are unresolved."""
    return from_distance(metric, factor * distance(metric, floor))
