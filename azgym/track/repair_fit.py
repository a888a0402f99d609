"""Moved beacons the track fits: a likelihood-ratio test of each beacon's accepted azimuths.

A beacon moved mostly along the line of sight turns its azimuths by a degree or less. They pass
the tracker's gate, the track leans towards them, and no run of rejections begins
(:mod:`azgym.track.repair`). What gives the move away is over seconds: from the camera positions
the track gives, the beacon's azimuths keep pointing past its map position towards one other
point, while the other beacons' do not.

**The test.** For each beacon the detections the tracker used in confident frames over the last
:data:`WINDOW_S` seconds are kept: each one's residual r_k = φ_k + α_k − θ_k (the track's heading
plus the azimuth, less the bearing from the track's camera to the map position), its
sensitivity to the beacon's position J_k = n_k / D_k (n_k the unit normal to the line of sight,
D_k the range) and its covariance

    Σ = diag(σ_k²) + (A P̄ Aᵀ) ∘ exp(−|t_k − t_l| / SHARED_ERROR_S),

σ_k² the error model's variance (eq. 3 at D_k, the map's width) plus ``extra_sigma``², A_k =
[J_k, 1] the residual's sensitivity to the track's position and heading, P̄ their mean
covariance over the window: the track's error is shared by sightings taken seconds apart, and
a few centimetres of it turn every azimuth by about a standard deviation. The generalized
likelihood ratio of "the beacon is at some other point" (linearized at its map position)
against "it is where the map has it" is

    Λ = rᵀ Σ⁻¹ J (Jᵀ Σ⁻¹ J)⁻¹ Jᵀ Σ⁻¹ r,

chi-square with two degrees of freedom while the beacon is where the map has it.

**Which one moved.** Every :data:`TEST_EVERY_S` the beacons used since the last test and seen at
least :data:`MIN_SIGHTINGS` times in their window are tested. The one with the largest Λ is
taken as moved when its Λ exceeds :data:`THRESHOLD` while at least :data:`OTHERS_AGREE` others
tested with it are below :data:`AGREE`: a track that is off (or dragged by a moved beacon
elsewhere) raises every beacon's Λ, and with fewer beacons in view no test can tell which one
moved. A beacon taken as moved is set aside and located from a track re-run without it, as a
beacon suspected after rejections is; its window starts afresh.

**Bounded.** The detections are kept in one ring of :data:`MAX_DETECTIONS` rows (one a beacon a
frame), and a test weighs at most :data:`TESTED` of a beacon's (evenly spaced over its window):
the memory and a test's cost are bounded at any frame rate. Keeping a frame's detections and a
test (of every beacon due, at most once a second) are each one compiled pass: together about
6 µs a tracked frame on the route suites (``python baselines/map_repair.py --part speed``).
"""

from __future__ import annotations

import math

import numpy as np

from azgym.core import BeaconMap, FloatArray, Measurements
from azgym.errors import InvalidInputError
from azgym.jit import jit, wrap_compiled
from azgym.site.error_model import ErrorModel
from azgym.track.azimuth_update import azimuth_variance

__all__ = ["AGREE", "MAX_DETECTIONS", "MIN_SIGHTINGS", "OTHERS_AGREE", "SHARED_ERROR_S", "TESTED",
           "TEST_EVERY_S", "THRESHOLD", "WINDOW_S", "FitTest", "likelihood_ratio"]

WINDOW_S = 10.0
"""Seconds of a beacon's accepted detections a test weighs [s]."""
TEST_EVERY_S = 1.0
"""Seconds between tests [s]."""
MIN_SIGHTINGS = 5
"""Fewest detections in a beacon's window for it to be tested."""
MAX_DETECTIONS = 2048
"""Most accepted detections kept, of every beacon (the latest)."""
TESTED = 30
"""Most detections one test weighs (evenly spaced over the window)."""
SHARED_ERROR_S = 2.0
"""Time constant of the correlation of the track's error between two sightings [s]: robust's
position and heading errors, measured on the route suites against the truth, keep 0.2-0.7 of
their autocorrelation after 1 s and none after 5 s."""
THRESHOLD = 20.0
"""Λ above which a beacon is taken as moved: a chi-square with two degrees of freedom exceeds it
with probability 4.5 × 10⁻⁵. Σ is wider than the track's error (robust's covariance is
cautious): on the route suites no beacon in place that was the worst of a test with two others
agreeing reached 11 (docs/trackers.md)."""
AGREE = 10.0
"""Λ below which another beacon agrees with the track (chi-square, two degrees of freedom:
probability 0.007 of exceeding it)."""
OTHERS_AGREE = 2
"""Fewest other beacons that must agree for one to be taken as moved."""

_TIME, _CAMERA, _BEARING, _COVARIANCE = 0, 1, 3, 4
"""The ring's columns (:class:`FitTest`): time, camera x (and y), world bearing, then the
track's six covariance entries xx, xy, xφ, yy, yφ, φφ. The beacon ids are a ring of their own
(int64: an id past 2⁵³ is not a float's)."""
_COLUMNS = 10


def likelihood_ratio(times: FloatArray, cameras: FloatArray, bearings: FloatArray,
                     covariance: FloatArray, variances: FloatArray, beacon: FloatArray) -> float:
    """Λ of the module docstring for one window of bearings.

    How much better a free position explains the bearings than the beacon's map position.

    Args:
        times: When each bearing was taken, ascending (K,) [s].
        cameras: The track's camera positions (K, 2) [m].
        bearings: The world bearings, heading plus azimuth (K,) [rad].
        covariance: The track's mean (x, y, φ) covariance over them (3, 3).
        variances: Each bearing's own variance (K,) [rad²].
        beacon: The beacon's map position (2,) [m].

    Returns:
        Λ; NaN when Σ is not positive definite.

    Raises:
        InvalidInputError: If the times do not ascend.
    """
    if np.any(np.diff(times) < 0.0):
        raise InvalidInputError("likelihood_ratio: times must be in ascending order")
    cameras = np.asarray(cameras, dtype=np.float64)
    return float(_window_ratio(np.asarray(times, dtype=np.float64),
                               np.ascontiguousarray(cameras[:, 0]),
                               np.ascontiguousarray(cameras[:, 1]),
                               np.asarray(bearings, dtype=np.float64),
                               np.asarray(covariance, dtype=np.float64),
                               np.asarray(variances, dtype=np.float64),
                               float(beacon[0]), float(beacon[1]), SHARED_ERROR_S))


@jit
def _window_ratio(times, xs, ys, bearings, covariance, variances, beacon_x, beacon_y,
                  shared_error_s):
    """The compiled :func:`likelihood_ratio`.

    Σ is built as (A P̄ Aᵀ)_kl ∏ e_m over k < m ≤ l (e_m = exp(−(t_m − t_(m−1))/τ): no
    underflow however long the window), factored by Cholesky, and [J, r] whitened by forward
    substitution; Λ = bᵀ G⁺ b from their 3 × 3 Gram matrix (G = MᵀM, b = Mᵀw): with G of
    rank one (every bearing along one line), |b|²/tr G.
    """
    count = times.size
    shared = np.empty((count, 3))
    columns = np.empty((count, 3))
    step = np.empty(count)
    for k in range(count):
        dx = beacon_x - xs[k]
        dy = beacon_y - ys[k]
        squared = dx * dx + dy * dy
        shared[k, 0] = -dy / squared
        shared[k, 1] = dx / squared
        shared[k, 2] = 1.0
        columns[k, :2] = shared[k, :2]
        columns[k, 2] = wrap_compiled(bearings[k] - math.atan2(dy, dx))
        step[k] = math.exp(-(times[k] - times[k - 1]) / shared_error_s) if k > 0 else 1.0
    projected = shared @ covariance
    sigma = np.empty((count, count))
    for k in range(count):
        decay = 1.0
        for m in range(k, count):
            decay = decay * step[m] if m > k else 1.0
            value = (projected[k, 0] * shared[m, 0] + projected[k, 1] * shared[m, 1]
                     + projected[k, 2] * shared[m, 2]) * decay
            sigma[k, m] = value
            sigma[m, k] = value
        sigma[k, k] += variances[k]
    for j in range(count):  # Cholesky, in the lower triangle
        pivot = sigma[j, j]
        for i in range(j):
            pivot -= sigma[j, i] * sigma[j, i]
        if not pivot > 0.0:
            return np.nan
        sigma[j, j] = math.sqrt(pivot)
        for i in range(j + 1, count):
            value = sigma[i, j]
            for m in range(j):
                value -= sigma[i, m] * sigma[j, m]
            sigma[i, j] = value / sigma[j, j]
    for i in range(count):  # forward substitution: the whitened [J, r]
        for c in range(3):
            value = columns[i, c]
            for m in range(i):
                value -= sigma[i, m] * columns[m, c]
            columns[i, c] = value / sigma[i, i]
    gram = columns.T @ columns
    determinant = gram[0, 0] * gram[1, 1] - gram[0, 1] * gram[0, 1]
    trace = gram[0, 0] + gram[1, 1]
    if determinant > 1e-12 * trace * trace:
        return (gram[1, 1] * gram[0, 2] ** 2 - 2.0 * gram[0, 1] * gram[0, 2] * gram[1, 2]
                + gram[0, 0] * gram[1, 2] ** 2) / determinant
    return (gram[0, 2] ** 2 + gram[1, 2] ** 2) / trace if trace > 0.0 else 0.0


@jit
def _record(kept, kept_ids, start, time, ids, azimuths, inliers, state, cov):
    """Write a frame's accepted detections into the ring; where the next frame's begin.

    From ``start``, or from the ring's beginning when they would pass its end; one a beacon
    (a detection repeated within a frame is one sighting, not many).
    """
    count = min(int(inliers.sum()), kept.shape[0])
    first = start if start + count <= kept.shape[0] else 0
    row = first
    for k in range(ids.size):
        if not inliers[k] or row >= first + count:
            continue
        seen = False
        for r in range(first, row):
            seen = seen or kept_ids[r] == ids[k]
        if seen:
            continue
        kept_ids[row] = ids[k]
        kept[row, 0] = time
        kept[row, 1] = state[0]
        kept[row, 2] = state[1]
        kept[row, 3] = state[2] + azimuths[k]
        kept[row, 4] = cov[0, 0]
        kept[row, 5] = cov[0, 1]
        kept[row, 6] = cov[0, 2]
        kept[row, 7] = cov[1, 1]
        kept[row, 8] = cov[1, 2]
        kept[row, 9] = cov[2, 2]
        row += 1
    return row


@jit
def _test(kept, kept_ids, oldest, time, window_s, tested_at, min_sightings, most, fewest,
          sorted_ids, xy, width, delta_d, coverage, extra_sigma, shared_error_s, tested, ratios):
    """The test of :meth:`FitTest.ratios` over the ring; how many beacons it tested.

    Writes ``tested`` (their rows in the order of ``sorted_ids``) and ``ratios``; none when
    fewer than ``fewest`` beacons are due. ``sorted_ids`` are the map's ids in ascending order,
    ``xy`` and ``width`` its beacons' positions and widths in that order.
    """
    rows, starts = _grouped(kept, kept_ids, oldest, time, window_s, sorted_ids)
    due = np.zeros(sorted_ids.size, dtype=np.bool_)
    for at in range(sorted_ids.size):
        latest = -np.inf
        for k in range(starts[at], starts[at + 1]):
            latest = max(latest, kept[rows[k], 0])
        due[at] = starts[at + 1] - starts[at] >= min_sightings and latest > tested_at
    if due.sum() < fewest:
        return 0
    count = 0
    for at in np.flatnonzero(due):
        window = _picked(kept, rows[starts[at]:starts[at + 1]], most)
        variances = np.empty(window.shape[0])
        for j in range(window.shape[0]):
            distance = math.hypot(xy[at, 0] - window[j, 1], xy[at, 1] - window[j, 2])
            variances[j] = azimuth_variance(distance, width[at], delta_d, coverage, extra_sigma)
        mean = np.zeros(6)
        for j in range(window.shape[0]):
            mean += window[j, 4:]
        mean /= window.shape[0]
        covariance = np.array([[mean[0], mean[1], mean[2]], [mean[1], mean[3], mean[4]],
                               [mean[2], mean[4], mean[5]]])
        tested[count] = at
        ratios[count] = _window_ratio(window[:, 0].copy(), window[:, 1].copy(),
                                      window[:, 2].copy(), window[:, 3].copy(), covariance,
                                      variances, xy[at, 0], xy[at, 1], shared_error_s)
        count += 1
    return count


@jit
def _grouped(kept, kept_ids, oldest, time, window_s, sorted_ids):
    """The ring's rows of the last ``window_s`` seconds, grouped by beacon, as written.

    ``rows`` holds those of ``sorted_ids[at]`` from ``starts[at]`` to ``starts[at + 1]``: a
    counting sort, reading the ring from row ``oldest`` round to it. Older rows are emptied
    (NaN time); rows of ids not on the map are passed over.
    """
    slot = np.full(kept.shape[0], -1, dtype=np.int64)
    counts = np.zeros(sorted_ids.size + 1, dtype=np.int64)
    for r in range(kept.shape[0]):
        if not kept[r, 0] >= time - window_s:
            kept[r, 0] = np.nan
            continue
        at = np.searchsorted(sorted_ids, kept_ids[r])
        if at < sorted_ids.size and sorted_ids[at] == kept_ids[r]:
            slot[r] = at
            counts[at + 1] += 1
    starts = np.cumsum(counts)
    rows = np.empty(starts[-1], dtype=np.int64)
    filled = starts[:-1].copy()
    for k in range(kept.shape[0]):
        r = (oldest + k) % kept.shape[0]
        if slot[r] >= 0:
            rows[filled[slot[r]]] = r
            filled[slot[r]] += 1
    return rows, starts


@jit
def _picked(kept, rows, most):
    """At most ``most`` of a beacon's ``rows``, evenly spaced, in ascending time.

    Rows written a lap of the ring apart may be out of order: they are sorted.
    """
    taken = min(rows.size, most)
    picked = np.empty(taken, dtype=np.int64)
    for j in range(taken):
        picked[j] = rows[int(round(j * (rows.size - 1) / max(taken - 1, 1)))]
    window = kept[picked]
    for j in range(1, taken):  # an insertion sort: nearly sorted already
        k = j
        while k > 0 and window[k - 1, 0] > window[k, 0]:
            swap = window[k - 1].copy()
            window[k - 1] = window[k]
            window[k] = swap
            k -= 1
    return window


class FitTest:
    """The accepted detections of the last seconds and their test (module docstring).

    Args:
        error_model: The azimuth error model (eq. 1-3).
        extra_sigma: Azimuth noise beyond it [rad].
    """

    def __init__(self, error_model: ErrorModel, extra_sigma: float) -> None:
        self.error_model = error_model
        self.extra_sigma = extra_sigma
        self._kept = np.full((MAX_DETECTIONS, _COLUMNS), np.nan)
        self._ids = np.full(MAX_DETECTIONS, -1, dtype=np.int64)
        """Each row's beacon id."""
        """The ring of detections, one a row (the ``_TIME`` ... columns; NaN time: empty)."""
        self._next = 0
        self._tested_at = -math.inf
        self._due = -math.inf
        self._map: BeaconMap | None = None
        self._sorted: tuple[np.ndarray, FloatArray, FloatArray] | None = None

    def record(self, time: float, measurements: Measurements, inliers: np.ndarray,
               state: FloatArray, cov: FloatArray) -> None:
        """Keep a confident frame's accepted detections (``inliers``) with the track's pose.

        Written as one block of the ring, from its start again when it would pass the end
        (the rows left there are overwritten in their turn, or expire).
        """
        self._next = _record(self._kept, self._ids, self._next, float(time), measurements.ids,
                             measurements.azimuth, inliers, state, cov)

    def forget(self, beacon: int) -> None:
        """Drop a beacon's detections (it was set aside, or placed anew)."""
        self._kept[self._ids == beacon, _TIME] = np.nan

    def began(self, beacon: int) -> float:
        """When a beacon's window begins [s]: its earliest detection kept."""
        times = self._kept[self._ids == beacon, _TIME]
        return float(times[~np.isnan(times)].min())

    def moved(self, time: float, beacons: BeaconMap) -> int | None:
        """The beacon taken as moved by this frame's test, if a test is due and one is."""
        if time < self._due:
            return None
        self._due = time + TEST_EVERY_S
        ratios = self.ratios(time, beacons)
        if not ratios:
            return None
        worst = max(ratios, key=ratios.__getitem__)
        agreeing = sum(ratio < AGREE for beacon, ratio in ratios.items() if beacon != worst)
        return worst if ratios[worst] > THRESHOLD and agreeing >= OTHERS_AGREE else None

    def ratios(self, time: float, beacons: BeaconMap) -> dict[int, float]:
        """Test now: Λ of each beacon of ``beacons`` used since the last test.

        Those with at least :data:`MIN_SIGHTINGS` detections in their window, each over at
        most :data:`TESTED` of them, evenly spaced; a Σ not positive definite is no answer.
        None while fewer than :data:`OTHERS_AGREE` + 1 are due: fewer cannot make one moved.
        """
        if beacons is not self._map or self._sorted is None:
            order = np.argsort(beacons.ids, kind="stable")
            self._map = beacons
            self._sorted = (np.ascontiguousarray(beacons.ids[order], dtype=np.int64),
                            np.ascontiguousarray(beacons.xyz[order, :2]),
                            np.ascontiguousarray(beacons.width[order], dtype=np.float64))
        sorted_ids, xy, width = self._sorted
        tested = np.empty(sorted_ids.size, dtype=np.int64)
        ratios = np.empty(sorted_ids.size)
        count = _test(self._kept, self._ids, self._next, float(time), WINDOW_S, self._tested_at,
                      MIN_SIGHTINGS, TESTED, OTHERS_AGREE + 1, sorted_ids, xy, width,
                      float(self.error_model.delta_alpha_d), bool(self.error_model.coverage),
                      float(self.extra_sigma), SHARED_ERROR_S, tested, ratios)
        self._tested_at = time
        return {int(sorted_ids[row]): float(ratio) for row, ratio in
                zip(tested[:count].tolist(), ratios[:count].tolist(), strict=True)
                if not math.isnan(ratio)}
