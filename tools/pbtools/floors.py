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


def finer_reference(ratio: float, rel_error: float, seconds: float, stopped_by: str,
                    factor: float = RESOLVE_FACTOR) -> str:
    """Why a score at `ratio` x its floor is unresolved, and the reference that would resolve it,
    from how its reference stopped (cell.json's `references`: its estimated relative error, its
    seconds a frame, the stop rule that ended it).

    A floor is the reference's own noise seen through the metric, so it scales with the reference's
    relative error: exactly for the norms; FLIP's falls a little slower (on cornell-box, from 10% to
    5%, as the error's 0.82th power), so for FLIP the error and time given are a lower bound. The
    technique's distance from the true image t and the floor f add in quadrature (module docstring):
    d^2 = t^2 + f^2, so t = f sqrt(ratio^2 - 1) stays and the score resolves once f' <= t /
    sqrt(factor^2 - 1). A Monte Carlo reference's error falls as 1/sqrt(time): the new error costs
    (f / f')^2 the time."""
    limit = "its time limit" if stopped_by == "max_seconds" else (
        "its error target" if stopped_by == "rel_error" else "its sample count")
    how = f"reference at {100 * rel_error:.3g}% after {seconds:.3g} s a frame (stopped by {limit})"
    if not (math.isfinite(ratio) and ratio > 1 and rel_error > 0):
        return f"{how}; the score is within its floor, so no finer reference can be sized from it"
    shrink = math.sqrt(ratio * ratio - 1) / math.sqrt(factor * factor - 1)
    needed, time_factor = rel_error * shrink, 1 / (shrink * shrink)
    return (f"{how}: about {100 * needed:.3g}% would resolve it, about {time_factor:.3g}x its time "
            f"({seconds * time_factor:.3g} s a frame)")
