"""Figures of a σ map over the floor, and the optimizer's objective: the 95th percentile.

A cell where no fix is possible (under three beacons seen, or a singular geometry: σ = inf) or
where the predicted σ exceeds :data:`PENALTY_SIGMA` counts as :data:`PENALTY_SIGMA`: a pose known
to a metre or worse is no fix for a forklift, and a finite penalty keeps the percentile and mean
meaningful while some cells are still uncovered. Every figure (the summary's median and p95 and
the optimizer's objective) is computed over all cells on the floor this way.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from azgym.core import FloatArray

__all__ = ["PENALTY_SIGMA", "capped", "floor_figures", "objective"]

PENALTY_SIGMA = 1.0
"""The σ an undetermined or worse cell counts as [m]."""
PERCENTILE = 95.0
"""The percentile the optimizer lowers."""


def capped(sigma: FloatArray) -> FloatArray:
    """σ with undetermined cells and cells worse than the penalty at :data:`PENALTY_SIGMA`."""
    return np.minimum(sigma, PENALTY_SIGMA)


def objective(sigma: FloatArray) -> FloatArray:
    """The optimizer's score of σ maps over their last axis (P cells): lower is better.

    The p95 of the capped σ, plus a ten-thousandth of its mean as a tie-breaker: once more than
    5 % of the cells are undetermined the p95 is the penalty whatever is added, and the mean
    still tells which beacon fixes the most cells.
    """
    values = capped(sigma)
    return np.percentile(values, PERCENTILE, axis=-1) + 1e-4 * values.mean(axis=-1)


def floor_figures(sigma: FloatArray, visible: FloatArray | None = None) -> dict[str, Any]:
    """Median, p95 and mean of the capped σ [m], undetermined cells, cells under three beacons.

    ``sigma_p95_with_fix_m`` is the p95 over the cells with a fix better than the penalty only
    (None if there is none): how good the covered floor is, whatever the coverage.

    Args:
        sigma: σ per cell [m] (inf: no fix), shape (P,).
        visible: Beacons seen per cell, shape (P,); the count under three is left out without.
    """
    values = capped(sigma)
    figures: dict[str, Any] = {"cells": int(sigma.size),
                               "sigma_median_m": float(np.median(values)),
                               "sigma_p95_m": float(np.percentile(values, PERCENTILE)),
                               "sigma_mean_m": float(values.mean()),
                               "cells_undetermined": int(np.count_nonzero(~np.isfinite(sigma))),
                               "cells_at_penalty": int(np.count_nonzero(sigma >= PENALTY_SIGMA))}
    fixed = sigma[sigma < PENALTY_SIGMA]
    figures["sigma_p95_with_fix_m"] = float(np.percentile(fixed, PERCENTILE)) \
        if fixed.size else None
    if visible is not None:
        figures["cells_under_3_beacons"] = int(np.count_nonzero(visible < 3))
    return figures
