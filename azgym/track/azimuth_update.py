"""The trackers' correction: raw azimuths, each gated by its Mahalanobis distance, then one update.

The measurement model is the paper's (Rátosi & Simon 2021, eq. 19-22): beacon i at (x_i, y_i)
is seen at α_i = atan2(y_i − y, x_i − x) − φ, with the Jacobian row
[(y_i − y)/r², −(x_i − x)/r², −1, 0, 0] over the state [x, y, φ, b, k]. Its noise is the error
model's (eq. 1-3: two uniform errors, variance (Δα_d² + Δα_c,i²)/3 with the coverage bound
Δα_c,i = atan2(W_i/2, r_i) of eq. 2, unless ``coverage`` is off), plus ``extra_sigma``² for
what the model leaves out (the camera's sway on bumps, a blob centre on a rendered image).

Gating (Packi & Hanebeck: a Gaussian density filter that tests each measurement against the
prediction): the innovation ν_i of each measurement has variance S_i = H_i P H_iᵀ + R_i; it is
accepted when ν_i²/S_i is below the gate (chi-square, one degree of freedom). A mirror ghost,
a misread id and a moved beacon sit far from where the prediction puts their beacon, so they
fail it once the track is tight. A beacon is measured at most once: of two detections with one
id (a ghost beside the real beacon) only the nearer to the prediction may pass (the smaller
ν²/S; on a tie, the earlier detection).

Passing the gate against the prediction is not enough when the prediction is wide (after a
start, an outage, a relocalization): a beacon moved since the map was made then passes too, and
outweighs the few lit beacons beside it, pulling the track tens of centimetres to where its
azimuth fits; once there, the track is tight and the good beacons fail the gate. What gives it
away is that the others agree with each other and not with it. So each accepted azimuth also
faces Packi & Hanebeck's leave-one-out test, against the prediction corrected by all the other
accepted ones: for the accepted innovations ν with joint covariance S = H P Hᵀ + R (the shared
pose's cross terms included) and w = S⁻¹ ν, azimuth i's residual given the others, over its
variance, is w_i² / (S⁻¹)_ii, chi-square with one degree of freedom, held to the gate's own
threshold. The worst offender is withheld and the gate run again without it (a detection of its
beacon that lost to it may take its place), until every remaining one passes; one azimuth alone
has no others to face. Each statistic is at most νᵀ S⁻¹ ν ≤ Σ ν_i² / R_i (S ⪰ R), so a set whose
innovations are within their noise (a tight track's usual frame) passes without forming S.

The accepted azimuths then correct the state jointly, K = P Hᵀ (H P Hᵀ + R)⁻¹, x⁺ = x + K ν,
P⁺ = P − K H P, with H linearized at the prediction. Because R is diagonal, this is computed as
one scalar update per accepted azimuth in turn, each innovation corrected by H_i (x − x⁻) for
the updates before it: the same posterior without a matrix inverse. The whole step is one
compiled loop: as numpy calls on a frame's handful of azimuths the gate and the update alone
cost about 35 µs, over the 30 µs a Kalman update may take beside a per-frame fix.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.core import BoolArray, FloatArray, IntArray
from azgym.jit import jit, wrap_compiled
from azgym.localize.base import ROW_AZIMUTH, ROW_BX, ROW_BY, ROW_WIDTH
from azgym.track.unicycle import IPHI, IX, IY

__all__ = ["azimuth_variance", "gated_update"]

_NO_COLUMNS = np.empty(0, dtype=np.int64)
"""``gated_update``'s columns when no beacon is in the state (no array made a frame)."""


def gated_update(state: FloatArray, cov: FloatArray, floats: FloatArray, beacon_index: IntArray,
                 delta_d: float, coverage: bool, extra_sigma: float, threshold: float,
                 columns: IntArray | None = None) -> tuple[BoolArray, FloatArray]:
    """Gate a frame's azimuths and correct ``state`` and ``cov`` with those that pass, in place.

    Args:
        state: The predicted state [x, y, φ, b, k] (``azgym.track.unicycle``).
        cov: Its covariance (5 × 5).
        floats: A :class:`~azgym.localize.base.Problem`'s packed rows (azimuth, beacon x, y,
            width by the ``ROW_*`` constants), one column per measurement.
        beacon_index: The measured beacon's row in the map, per measurement.
        delta_d: Δα_d, half-width of the centre-detection error [rad] (eq. 1).
        coverage: Whether the noise includes eq. 2's coverage term Δα_c,i.
        extra_sigma: Azimuth noise beyond the error model [rad].
        threshold: The gate: the largest ν²/S accepted.
        columns: Per measurement, the state's column of its beacon's x (y the next) for a
            beacon kept in the state (a repaired one, :mod:`azgym.track.repair_state`), or −1
            for one at its map position; None: every one at its map position. A beacon in the
            state is seen where the state has it, and its Jacobian row has
            [−(y_i − y)/r², (x_i − x)/r²] in those columns, so the update corrects it too.

    Returns:
        Which measurements passed the gate and the leave-one-out test, and each one's squared
        Mahalanobis distance ν²/S at the prediction.
    """
    passed = np.zeros(floats.shape[1], dtype=np.bool_)
    distance = np.empty(floats.shape[1])
    _gated_update(state, cov, floats, beacon_index, delta_d, bool(coverage), extra_sigma,
                  threshold, passed, distance, _NO_COLUMNS if columns is None else columns)
    return passed, distance


@jit(inline="always")
def azimuth_variance(distance, width, delta_d, coverage, extra_sigma):
    """An azimuth's variance in a compiled loop [rad²], plus ``extra_sigma``².

    Eq. 3's (Δα_d² + Δα_c²) / 3 with the coverage bound Δα_c = atan2(W/2, D) unless
    ``coverage`` is off: the compiled twin of :meth:`~azgym.site.error_model.ErrorModel.variance`.
    """
    cover = math.atan2(0.5 * width, distance) if coverage else 0.0
    return (delta_d * delta_d + cover * cover) / 3.0 + extra_sigma * extra_sigma


@jit
def _gated_update(state, cov, floats, beacon_index, delta_d, coverage, extra_sigma, threshold,
                  passed, distance, columns):
    """The compiled step of :func:`gated_update`; writes ``passed`` and ``distance``."""
    count, size = floats.shape[1], state.size
    nu = np.empty(count)
    noise = np.empty(count)
    rows = np.zeros((count, size))
    for i in range(count):
        column = columns[i] if columns.size else -1
        bx = state[column] if column >= 0 else floats[ROW_BX, i]
        by = state[column + 1] if column >= 0 else floats[ROW_BY, i]
        dx = bx - state[IX]
        dy = by - state[IY]
        r2 = dx * dx + dy * dy
        nu[i] = wrap_compiled(floats[ROW_AZIMUTH, i] - math.atan2(dy, dx) + state[IPHI])
        rows[i, IX] = dy / r2
        rows[i, IY] = -dx / r2
        rows[i, IPHI] = -1.0
        if column >= 0:
            rows[i, column] = -dy / r2
            rows[i, column + 1] = dx / r2
        noise[i] = azimuth_variance(math.sqrt(r2), floats[ROW_WIDTH, i], delta_d, coverage,
                                    extra_sigma)
        spread = noise[i]
        for a in range(size):
            for b in range(size):
                spread += rows[i, a] * cov[a, b] * rows[i, b]
        distance[i] = nu[i] * nu[i] / spread
    withheld = np.zeros(count, dtype=np.bool_)
    _gate(distance, beacon_index, threshold, withheld, passed)
    while _withhold_worst(nu, rows, noise, cov, threshold, passed, withheld):
        _gate(distance, beacon_index, threshold, withheld, passed)
    _update(state, cov, nu, rows, noise, passed)


@jit
def _gate(distance, beacon_index, threshold, withheld, passed):
    """``passed``: under the threshold, not withheld, and the nearest of its beacon's detections."""
    count = distance.size
    for i in range(count):
        passed[i] = distance[i] < threshold and not withheld[i]
    for i in range(count):
        for j in range(count):
            if passed[i] and j != i and beacon_index[j] == beacon_index[i] and \
                    distance[j] < threshold and not withheld[j] and \
                    (distance[j] < distance[i] or (distance[j] == distance[i] and j < i)):
                passed[i] = False


@jit
def _withhold_worst(nu, rows, noise, cov, threshold, passed, withheld):
    """The leave-one-out test (module docstring): withhold the worst offender; whether one was."""
    chosen = np.flatnonzero(passed)
    count, size = chosen.size, cov.shape[0]
    if count < 2:
        return False
    bound = 0.0
    for i in chosen:
        bound += nu[i] * nu[i] / noise[i]
    if bound < threshold:
        return False
    spread = np.zeros((count, count))
    for p in range(count):
        for q in range(count):
            total = noise[chosen[p]] if p == q else 0.0
            for a in range(size):
                for b in range(size):
                    total += rows[chosen[p], a] * cov[a, b] * rows[chosen[q], b]
            spread[p, q] = total
    information = np.linalg.inv(spread)
    worst, largest = 0, -1.0
    for p in range(count):
        w = 0.0
        for q in range(count):
            w += information[p, q] * nu[chosen[q]]
        statistic = w * w / information[p, p]
        if statistic > largest:
            worst, largest = p, statistic
    if largest < threshold:
        return False
    withheld[chosen[worst]] = True
    return True


@jit
def _update(state, cov, nu, rows, noise, passed):
    """The joint update on the passed azimuths, as scalar updates in turn (module docstring)."""
    size = state.size
    moved = np.zeros(size)
    gain = np.empty(size)
    for i in range(nu.size):
        if not passed[i]:
            continue
        innovation = nu[i]
        for a in range(size):
            innovation -= rows[i, a] * moved[a]
        spread = noise[i]
        for a in range(size):
            gain[a] = 0.0
            for b in range(size):
                gain[a] += cov[a, b] * rows[i, b]
            spread += rows[i, a] * gain[a]
        for a in range(size):
            step = gain[a] / spread * innovation
            state[a] += step
            moved[a] += step
        for a in range(size):
            for b in range(size):
                cov[a, b] -= gain[a] * gain[b] / spread
    state[IPHI] = wrap_compiled(state[IPHI])
    for a in range(size):
        for b in range(a + 1, size):
            mean = 0.5 * (cov[a, b] + cov[b, a])
            cov[a, b] = mean
            cov[b, a] = mean
