"""``gated-ekf``: an extended Kalman filter on raw azimuths, each gated by its Mahalanobis distance.

The filter follows the camera pose and the gyro's bias (:mod:`azgym.track.unicycle`): each frame
it predicts with the odometry's speed and the gyro's yaw rate, then corrects with the frame's
azimuths that pass the chi-square gate (:mod:`azgym.track.azimuth_update`) and then agree with
each other (:func:`leave_one_out`: a moved beacon passes the gate of a wide prediction, not the
test against the beacons beside it). It starts from the pose given to ``reset`` or, without
one, from the first frame a per-frame localizer (ransac or loo) solves, with that fix's
covariance; until then it answers ``ok=False``. This is the textbook filter: once started it
never doubts itself. :class:`~azgym.track.robust.Robust` adds
hold-over limits and relocalization on top.
"""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np

from azgym.core import (
    BeaconMap,
    BoolArray,
    Estimate,
    FloatArray,
    IntArray,
    Measurements,
    Pose,
    wrap_scalar,
)
from azgym.errors import InvalidInputError
from azgym.hyperparameters import check_range
from azgym.localize.base import ROW_BEACON_INDEX, ROW_SOURCE, Problem
from azgym.localize.registry import build
from azgym.sensing.motion import ImuModel, Motion, OdometryModel
from azgym.track.azimuth_update import gated_update
from azgym.track.base import Tracker
from azgym.track.unicycle import (
    IBIAS,
    IPHI,
    ISCALE,
    IX,
    IY,
    STATE_SIZE,
    MotionNoise,
    MotionSteps,
    camera_lever,
    predict,
)
from azgym.world.forklift import ForkliftSpec

INITIALIZERS = ("ransac", "loo")
"""The per-frame localizers a tracker may start from."""
INITIAL_STD = (0.05, 0.05, math.radians(1.0))
"""Floor on the standard deviations of a start pose (x, y [m], heading [rad]): a per-frame
fix's covariance assumes its inliers are clean, and a pose given to ``reset`` is never exact."""
DEFAULT_PERIOD = 1.0 / OdometryModel().rate_hz
"""Sample period assumed for a motion stream until a frame with two samples shows its own [s]."""


class GatedEkf(Tracker):
    """An EKF on raw azimuths, gated one by one and then leave-one-out (module docstring).

    Args:
        gate_probability: Share of good azimuths the gate lets through: the threshold is the
            chi-square quantile (one degree of freedom) of this probability, for the gate and
            for the leave-one-out test alike.
        delta_alpha_d: Δα_d, half-width of the centre-detection error [rad] (eq. 1).
        extra_sigma: Azimuth noise beyond the error model (camera sway, rendering) [rad].
        position_walk: Model error of the motion prediction [m/√s].
        initializer: The per-frame localizer that gives the first fix: "ransac" or "loo".
        min_init_inliers: Fewest inliers a first fix needs.
    """

    name = "gated-ekf"

    def __init__(self, *, gate_probability: float = 0.999,
                 delta_alpha_d: float = math.radians(0.4), extra_sigma: float = math.radians(0.1),
                 position_walk: float = 0.02, initializer: str = "ransac",
                 min_init_inliers: int = 4) -> None:
        self.gate_probability = gate_probability
        self.delta_alpha_d = delta_alpha_d
        self.extra_sigma = extra_sigma
        self.position_walk = position_walk
        self.initializer = initializer
        self.min_init_inliers = min_init_inliers
        self._validate_once()

    def _check_params(self) -> None:
        name = type(self).__name__
        check_range(name, "gate_probability", self.gate_probability, low=0.0, high=1.0,
                    low_open=True, high_open=True)
        check_range(name, "delta_alpha_d", self.delta_alpha_d, low=0.0, high=math.pi / 2,
                    high_open=True)
        check_range(name, "extra_sigma", self.extra_sigma, low=0.0, high=math.pi / 2)
        check_range(name, "position_walk", self.position_walk, low=0.0)
        check_range(name, "min_init_inliers", self.min_init_inliers, low=3, integer=True)
        if self.initializer not in INITIALIZERS:
            raise InvalidInputError(f"{name}.initializer must be one of {INITIALIZERS}, got "
                                    f"{self.initializer!r}")
        if self.delta_alpha_d == 0.0 and self.extra_sigma == 0.0:
            raise InvalidInputError(f"{name}: delta_alpha_d and extra_sigma are both 0, which "
                                    "gives the azimuths no noise to weigh them by")
        self._threshold = NormalDist().inv_cdf(0.5 + 0.5 * self.gate_probability) ** 2
        self._localizer = build(self.initializer, delta_alpha_d=self.delta_alpha_d)
        self._noise = MotionNoise(position_walk=self.position_walk)
        self._lever = camera_lever(ForkliftSpec())

    # -- the sequence ------------------------------------------------------------------------

    def _reset(self, rng: np.random.Generator, initial: Pose | None) -> None:
        self._steps = MotionSteps(DEFAULT_PERIOD)
        self._state = np.zeros(STATE_SIZE)
        self._cov = np.zeros((STATE_SIZE, STATE_SIZE))
        self._running = initial is not None
        if initial is not None:
            self._start(np.array(initial), np.diag(np.square(INITIAL_STD)))

    def _start(self, pose: np.ndarray, cov: np.ndarray) -> None:
        """Start (or restart) the filter at ``pose`` with covariance ``cov`` (3 × 3)."""
        self._state[:] = (pose[0], pose[1], pose[2], 0.0, 0.0)
        self._cov[:] = 0.0
        self._cov[:3, :3] = cov + np.diag(np.square(INITIAL_STD))
        self._cov[IBIAS, IBIAS] = ImuModel().gyro_bias ** 2
        self._cov[ISCALE, ISCALE] = self._noise.speed_scale ** 2
        self._running = True

    def _predict(self, motion: Motion) -> None:
        for step in self._steps.steps(motion):
            if self._running:
                predict(self._state, self._cov, step, self._lever, self._noise)

    def _update(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        if not self._running:
            fix = self._fix(measurements, beacons)
            if fix is None:
                return Estimate.failure(f"not initialized: {self._why}", len(measurements))
            self._start(np.array(fix.pose), fix.covariance)
            return self._estimate(fix.inliers, {"initialized": True})
        inliers, _ = self._apply(measurements, beacons)
        return self._estimate(inliers)

    # -- the steps ---------------------------------------------------------------------------

    def _fix(self, measurements: Measurements, beacons: BeaconMap) -> Estimate | None:
        """The initializer's fix of this frame, or None (with ``_why`` set) if it is unfit."""
        fix = self._localizer.localize(measurements, beacons)
        if not fix.ok:
            self._why = f"{self.initializer}: {fix.reason}"
            return None
        if fix.n_inliers < self.min_init_inliers or fix.covariance is None \
                or not np.isfinite(fix.covariance).all():
            self._why = (f"{self.initializer}'s fix has {fix.n_inliers} inliers, fewer than "
                         f"min_init_inliers={self.min_init_inliers}, or no covariance")
            return None
        return fix

    def _apply(self, measurements: Measurements, beacons: BeaconMap) -> tuple[np.ndarray, int]:
        """Correct with the azimuths that pass the gate and then the leave-one-out test.

        The inlier mask (M,) and the frame's count of distinct usable beacons. The azimuths
        :func:`leave_one_out` withholds are left out of the frame given to :meth:`_correct`,
        which gates the rest exactly as they were gated here.
        """
        problem = Problem.from_frame(measurements, beacons)
        if problem.size < 2:
            return self._correct(measurements, beacons)
        nu, h, r, d2 = innovations(self._state, self._cov, problem.floats, self.delta_alpha_d,
                                   self.extra_sigma)
        excluded = leave_one_out(nu, h, r, d2, problem.ints[ROW_BEACON_INDEX], self._cov,
                                 self._threshold)
        if not excluded.any():
            return self._correct(measurements, beacons)
        kept = np.ones(len(measurements), dtype=bool)
        kept[problem.ints[ROW_SOURCE][excluded]] = False
        chosen = np.flatnonzero(kept)
        accepted, _ = self._correct(subset(measurements, chosen), beacons)
        inliers = np.zeros(len(measurements), dtype=bool)
        inliers[chosen[accepted]] = True
        return inliers, problem.n_distinct

    def _correct(self, measurements: Measurements,
                 beacons: BeaconMap) -> tuple[np.ndarray, int]:
        """Gate and apply the frame's azimuths; the inlier mask (M,) and the usable count."""
        problem = Problem.from_frame(measurements, beacons)
        inliers = np.zeros(len(measurements), dtype=bool)
        if problem.size == 0:
            return inliers, 0
        passed, _ = gated_update(self._state, self._cov, problem.floats,
                                 problem.ints[ROW_BEACON_INDEX], self.delta_alpha_d,
                                 self.extra_sigma, self._threshold)
        inliers[problem.ints[ROW_SOURCE][passed]] = True
        return inliers, problem.n_distinct

    def _estimate(self, inliers: np.ndarray, diagnostics: dict | None = None) -> Estimate:
        state = self._state
        return Estimate(x=float(state[IX]), y=float(state[IY]),
                        heading=wrap_scalar(float(state[IPHI])), inliers=inliers,
                        covariance=self._cov[:3, :3].copy(),
                        diagnostics=diagnostics or {})


def subset(measurements: Measurements, rows: np.ndarray) -> Measurements:
    """The measurements at ``rows`` (indices), their quality columns with them."""
    quality = None if measurements.quality is None else measurements.quality[rows]
    return Measurements(measurements.ids[rows], measurements.azimuth[rows], quality)


def leave_one_out(nu: FloatArray, h: FloatArray, r: FloatArray, d2: FloatArray,
                  beacon_index: IntArray, cov: FloatArray, threshold: float) -> BoolArray:
    """Which rows to withhold so that every azimuth the gate accepts also agrees with the others.

    Passing the gate against the prediction is not enough when the prediction is wide (after a
    start, an outage, a relocalization): a beacon moved since the map was made then passes too,
    and outweighs the few lit beacons beside it, pulling the track tens of centimetres to where
    its azimuth fits; once there, the track is tight and the good beacons fail the gate. What
    gives it away is that the others agree with each other and not with it. Packi & Hanebeck's
    leave-one-out test asks exactly that: each accepted azimuth against the prediction corrected
    by all the other accepted ones. For the accepted innovations ν with joint covariance
    S = H P Hᵀ + R (the shared pose's cross terms included) and w = S⁻¹ ν, azimuth i's residual
    given the others, over its variance, is (w_i)² / (S⁻¹)_ii: chi-square with one degree of
    freedom, held to the gate's own threshold. The worst offender is withheld and the gate run
    again without it (a detection of its beacon that lost to it may take its place), until
    every remaining one passes. One azimuth alone has no others: the gate has judged it.

    Each statistic is at most νᵀ S⁻¹ ν ≤ Σ ν_i² / R_i (S ⪰ R): a set whose innovations are
    within their noise (a tight track's usual frame) passes without forming S.

    Returns:
        The withheld rows, a mask over the rows of ``nu``.
    """
    excluded = np.zeros(nu.size, dtype=bool)
    while True:
        rows = np.flatnonzero(gate(np.where(excluded, np.inf, d2), beacon_index, threshold))
        if rows.size < 2:
            return excluded
        v = nu[rows]
        if float(v @ (v / r[rows])) < threshold:
            return excluded
        hr = h[rows]
        info = np.linalg.inv(hr @ cov @ hr.T + np.diag(r[rows]))
        w = info @ v
        statistic = w * w / np.diag(info)
        worst = int(np.argmax(statistic))
        if statistic[worst] < threshold:
            return excluded
        excluded[rows[worst]] = True
