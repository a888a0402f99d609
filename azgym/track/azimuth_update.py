"""The trackers' correction: raw azimuths, each gated by its Mahalanobis distance, then one update.

The measurement model is the paper's (Rátosi & Simon 2021, eq. 19-22): beacon i at (x_i, y_i)
is seen at α_i = atan2(y_i − y, x_i − x) − φ, with the Jacobian row
[(y_i − y)/r², −(x_i − x)/r², −1, 0] over the state [x, y, φ, b]. Its noise is the error model's
(eq. 1-3: two uniform errors, variance (Δα_d² + Δα_c,i²)/3 with the coverage bound
Δα_c,i = atan2(W_i/2, r_i) of eq. 2), plus ``extra_sigma``² for what the model leaves out (the
camera's sway on bumps, a blob centre on a rendered image).

Gating (Packi & Hanebeck: a Gaussian density filter that tests each measurement against the
prediction): the innovation ν_i of each measurement has variance S_i = H_i P H_iᵀ + R_i; it is
accepted when ν_i²/S_i is below the gate (chi-square, one degree of freedom). A mirror ghost,
a misread id and a moved beacon sit far from where the prediction puts their beacon, so they
fail it once the track is tight. A beacon is measured at most once: of two detections with one
id (a ghost beside the real beacon) only the nearer to the prediction may pass. The accepted
azimuths then correct the state jointly: K = P Hᵀ (H P Hᵀ + R)⁻¹, x⁺ = x + K ν, P⁺ = P − K H P.
"""

from __future__ import annotations

import numpy as np

from azgym.core import BoolArray, FloatArray, IntArray
from azgym.localize.base import ROW_AZIMUTH, ROW_BX, ROW_BY, ROW_WIDTH
from azgym.track.unicycle import IPHI, IX, IY


def innovations(state: FloatArray, cov: FloatArray, floats: FloatArray, delta_d: float,
                extra_sigma: float) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
    """Innovation ν, Jacobian H (K, 4), noise variance R and squared Mahalanobis distance ν²/S.

    ``floats`` are a :class:`~azgym.localize.base.Problem`'s packed rows (azimuth, beacon x, y,
    width by the ``ROW_*`` constants).
    """
    dx = floats[ROW_BX] - state[IX]
    dy = floats[ROW_BY] - state[IY]
    r2 = dx * dx + dy * dy
    nu = floats[ROW_AZIMUTH] - np.arctan2(dy, dx) + state[IPHI]
    nu = nu - 2.0 * np.pi * np.round(nu / (2.0 * np.pi))
    h = np.zeros((dx.size, state.size))
    h[:, IX] = dy / r2
    h[:, IY] = -dx / r2
    h[:, IPHI] = -1.0
    coverage = np.arctan2(0.5 * floats[ROW_WIDTH], np.sqrt(r2))
    r = (delta_d * delta_d + coverage * coverage) / 3.0 + extra_sigma * extra_sigma
    s = ((h @ cov) * h).sum(axis=1) + r
    return nu, h, r, nu * nu / s


def gate(d2: FloatArray, beacon_index: IntArray, threshold: float) -> BoolArray:
    """Which measurements pass: below the threshold, and the nearest of any that share a beacon."""
    passed = d2 < threshold
    taken = beacon_index[passed].tolist()
    if len(set(taken)) < len(taken):
        order = np.argsort(np.where(passed, d2, np.inf), kind="stable")
        taken = beacon_index[order[:int(passed.sum())]]
        _, first = np.unique(taken, return_index=True)
        keep = np.zeros_like(passed)
        keep[order[first]] = True
        passed = keep
    return passed


def correct(state: FloatArray, cov: FloatArray, nu: FloatArray, h: FloatArray,
            r: FloatArray) -> None:
    """The joint update on the accepted rows, in place (module docstring)."""
    ph = cov @ h.T
    innovation_cov = h @ ph
    innovation_cov[np.diag_indices_from(innovation_cov)] += r
    gain = ph @ np.linalg.inv(innovation_cov)
    state += gain @ nu
    posterior = cov - gain @ ph.T
    state[IPHI] = np.remainder(state[IPHI] + np.pi, 2.0 * np.pi) - np.pi
    cov[:] = 0.5 * (posterior + posterior.T)
