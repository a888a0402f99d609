"""``robust``: the gated EKF that knows when it is lost, holds over outages and relocalizes.

On top of :class:`~azgym.track.gated_ekf.GatedEkf`:

* **start**: any per-frame fix with three inliers starts the track, but a start from exactly
  three (which any three azimuths fit, a ghost among them or not) stays *tentative*, answering
  ``ok=False``, until a frame in which four beacons pass the gate confirms it; a tentative track
  that a frame contradicts (a measured beacon fails the gate) is dropped, and the frame tried
  for a new start (the idea of Packi & Hanebeck's leave-one-out test: trust a start only once a
  measurement it was not fitted to agrees with it);
* **hold-over**: a frame without usable azimuths only predicts; the answer stays ``ok=True``
  while the predicted position's standard deviation is within ``max_position_std``;
* **relocalization**: a frame is *inconsistent* when at least three beacons were measured and
  fewer than half of them pass the gate. After ``relocalize_after`` seconds of inconsistent
  frames (a kidnapping: the forklift carried while its motion sensors said it stood still), or
  at once when a per-frame fix has at least ``strong_fix`` inliers (more than twice what the
  gate let through), or when hold-over has outgrown its bound (a forklift carried with its
  sensors off: the unobserved time grows the covariance), the track restarts from the
  initializer's fix.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.core import BeaconMap, Estimate, Measurements, Pose
from azgym.localize.base import check_range
from azgym.track.gated_ekf import GatedEkf
from azgym.track.unicycle import IX, IY

CONFIRMING_BEACONS = 4
"""Beacons that confirm a start: one more than a pose's three unknowns, so one is a check."""


class Robust(GatedEkf):
    """The gated EKF with tentative starts, hold-over limits and relocalization (module docstring).

    Args:
        max_position_std: Largest predicted position standard deviation (√(σx² + σy²)) the
            track still answers with [m].
        relocalize_after: Seconds of inconsistent frames after which the track restarts from a
            per-frame fix [s].
        strong_fix: Inliers of a per-frame fix that restart an inconsistent track at once.
        **others: As :class:`~azgym.track.gated_ekf.GatedEkf` (``min_init_inliers`` 3).
    """

    name = "robust"

    def __init__(self, *, gate_probability: float = 0.999,
                 delta_alpha_d: float = math.radians(0.4), extra_sigma: float = math.radians(0.1),
                 position_walk: float = 0.02, initializer: str = "ransac",
                 min_init_inliers: int = 3, max_position_std: float = 0.5,
                 relocalize_after: float = 0.5, strong_fix: int = 6) -> None:
        self.max_position_std = max_position_std
        self.relocalize_after = relocalize_after
        self.strong_fix = strong_fix
        super().__init__(gate_probability=gate_probability, delta_alpha_d=delta_alpha_d,
                         extra_sigma=extra_sigma, position_walk=position_walk,
                         initializer=initializer, min_init_inliers=min_init_inliers)

    def _check_params(self) -> None:
        super()._check_params()
        name = type(self).__name__
        check_range(name, "max_position_std", self.max_position_std, low=0.0, low_open=True)
        check_range(name, "relocalize_after", self.relocalize_after, low=0.0)
        check_range(name, "strong_fix", self.strong_fix, low=4, integer=True)

    def _reset(self, rng: np.random.Generator, initial: Pose | None) -> None:
        super()._reset(rng, initial)
        self._tentative = False
        self._bad_since: float | None = None

    def _now(self) -> float:
        return self._steps.time if self._steps.time is not None else 0.0

    def _restart(self, fix: Estimate) -> Estimate:
        """Start from a per-frame fix: tentative when it has only three inliers."""
        self._start(np.array(fix.pose), fix.covariance)
        self._bad_since = None
        self._tentative = fix.n_inliers < CONFIRMING_BEACONS
        return self._answer(fix.inliers, {"initialized": True})

    def _update(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        if not self._running:
            fix = self._fix(measurements, beacons)
            if fix is None:
                return Estimate.failure(f"not initialized: {self._why}", len(measurements))
            return self._restart(fix)
        inliers, distinct = self._correct(measurements, beacons)
        accepted = int(inliers.sum())
        inconsistent = distinct >= 3 and 2 * accepted < distinct
        if self._tentative:
            if accepted < distinct:
                self._running = False  # a tentative start the frame contradicts
                return self._update(measurements, beacons)
            self._tentative = accepted < CONFIRMING_BEACONS
        self._bad_since = (self._bad_since if self._bad_since is not None else self._now()) \
            if inconsistent else None
        if inconsistent or self._position_std() > self.max_position_std:
            fix = self._fix(measurements, beacons)
            if fix is not None and self._should_restart(fix, accepted):
                return self._restart(fix)
        return self._answer(inliers)

    def _should_restart(self, fix: Estimate, accepted: int) -> bool:
        """Whether a per-frame fix should replace the track (module docstring)."""
        if self._position_std() > self.max_position_std:
            return True
        if fix.n_inliers >= self.strong_fix and fix.n_inliers > 2 * accepted:
            return True
        return self._bad_since is not None and \
            self._now() - self._bad_since >= self.relocalize_after

    def _position_std(self) -> float:
        return math.sqrt(self._cov[IX, IX] + self._cov[IY, IY])

    def _answer(self, inliers: np.ndarray, diagnostics: dict | None = None) -> Estimate:
        """The estimate, or a failure while the start is tentative or the track is too unsure."""
        if self._tentative:
            return Estimate.failure("tentative start from three inliers, not yet confirmed by "
                                    f"{CONFIRMING_BEACONS} beacons in one frame", inliers.size)
        std = self._position_std()
        if std > self.max_position_std:
            return Estimate.failure(
                f"lost: predicted position std {std:.2f} m exceeds max_position_std="
                f"{self.max_position_std} m", inliers.size)
        return self._estimate(inliers, diagnostics)
