"""Error statistics of a set of estimates, the way the paper and ISO/IEC 18305 report them.

A missing estimate (``ok=False``) is never a zero error: statistics of the error are taken over the
estimates that exist, availability says how many exist, and the failure rate counts a missing
estimate as a failure.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

FAILURE_DISTANCE = 1.0
"""An estimate further than this from the truth [m] is a failure."""


def summarize_errors(
    position_error: ArrayLike, heading_error: ArrayLike, ok: ArrayLike
) -> dict[str, Any]:
    """Statistics of position errors [m → cm] and heading errors [rad → deg].

    Args:
        position_error: 2-D position error of each run [m]; ignored where not ``ok``.
        heading_error: Absolute heading error of each run [rad]; ignored where not ``ok``.
        ok: Whether each run produced an estimate.

    Returns:
        n, availability, failure_rate, mean/rmse/median/p75/p90/p95/max position error in cm and
        mean/median heading error in degrees (NaN when no run produced an estimate).
    """
    ok = np.asarray(ok, dtype=bool)
    position = np.asarray(position_error, dtype=float)[ok] * 100.0
    heading = np.degrees(np.asarray(heading_error, dtype=float)[ok])
    n = int(ok.size)
    failures = int(np.count_nonzero(~ok)) + int(np.count_nonzero(position > FAILURE_DISTANCE * 100))
    stats: dict[str, Any] = {
        "n": n,
        "availability": float(ok.mean()) if n else math.nan,
        "failure_rate": failures / n if n else math.nan,
    }
    if position.size:
        q50, q75, q90, q95 = np.percentile(position, [50, 75, 90, 95])
        stats.update(
            mean_cm=float(position.mean()),
            rmse_cm=float(np.sqrt(np.mean(position**2))),
            median_cm=float(q50),
            p75_cm=float(q75),
            p90_cm=float(q90),
            p95_cm=float(q95),
            max_cm=float(position.max()),
            heading_mean_deg=float(heading.mean()),
            heading_median_deg=float(np.median(heading)),
        )
    else:
        for key in ("mean_cm", "rmse_cm", "median_cm", "p75_cm", "p90_cm", "p95_cm", "max_cm",
                    "heading_mean_deg", "heading_median_deg"):
            stats[key] = math.nan
    return stats


def confidence_intervals(position: np.ndarray, ok: np.ndarray, resamples: int = 400,
                         seed: int = 0) -> dict[str, list[float]]:
    """95 % bootstrap intervals of the mean and p75 position error [cm] and the failure rate.

    Frames are resampled with replacement (a missing estimate stays a failure), 50 resamples at
    a time to bound memory; the generator is seeded, so the intervals repeat like the figures.
    """
    count = position.size
    if count == 0:
        return {}
    rng = np.random.default_rng(seed)
    error = np.where(ok, position * 100, np.inf)
    means, p75, failures = [], [], []
    for _ in range(0, resamples, 50):
        samples = error[rng.integers(0, count, size=(50, count))]
        available = np.isfinite(samples)
        means += list(np.where(available, samples, 0.0).sum(axis=1)
                      / np.maximum(available.sum(axis=1), 1))
        p75 += [float(np.percentile(row[np.isfinite(row)], 75)) if np.isfinite(row).any()
                else math.nan for row in samples]
        failures += list(((~available) | (samples > FAILURE_DISTANCE * 100)).mean(axis=1))

    def interval(values: list[float]) -> list[float]:
        finite = np.asarray(values, dtype=float)
        finite = finite[np.isfinite(finite)]
        if finite.size == 0:  # no estimate at all: no interval either
            return [math.nan, math.nan]
        return [float(np.percentile(finite, 2.5)), float(np.percentile(finite, 97.5))]

    return {"mean_cm": interval(means), "p75_cm": interval(p75),
            "failure_rate": interval(failures)}
