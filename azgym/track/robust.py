"""``robust``: the gated EKF that knows when it is lost, holds over outages and relocalizes.

On top of :class:`~azgym.track.gated_ekf.GatedEkf`:

* **start**: any per-frame fix with three inliers starts the track, but a start from exactly
  three (which any three azimuths fit, a ghost among them or not) stays *tentative*, answering
  ``ok=False``, until a frame in which four beacons pass the gate confirms it, or three azimuths
  (in one frame or over several) pass it once the camera has moved ``confirm_travel`` from the
  start (where only a few beacons are in sight, odometry carries the start to poses it was not
  fitted to); a tentative
  track that a frame contradicts (a measured beacon fails the gate) is dropped, and the frame
  tried for a new start (the idea of Packi & Hanebeck's leave-one-out test: trust a start only
  once a measurement it was not fitted to agrees with it);
* **hold-over**: a frame without usable azimuths only predicts; the answer stays ``ok=True``
  while the predicted position's standard deviation is within ``max_position_std``. Beyond it
  the track is *lost*: it answers ``ok=False`` until a per-frame fix, to whose pose it moves
  before correcting (one linearized update from metres away passes every azimuth and lands,
  tightly, wherever the linearization led);
* **relocalization**: a frame is *inconsistent* when at least three beacons were measured and
  fewer than half of them pass the gate. After ``relocalize_after`` seconds of inconsistent
  frames (a kidnapping: the forklift carried while its motion sensors said it stood still), or
  at once when a per-frame fix has at least ``strong_fix`` inliers (more than twice what the
  gate let through), the track restarts from the initializer's fix. A forklift carried with its
  sensors off is lost by the rule above: the unobserved time grows the covariance.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from azgym.core import BeaconMap, Estimate, FloatArray, IntArray, Measurements, Pose
from azgym.hyperparameters import check_flag, check_range
from azgym.localize.base import ROW_BEACON_INDEX, Problem
from azgym.localize.bearings import MIN_SPREAD
from azgym.profile import FORKLIFT
from azgym.sensing.motion import Motion
from azgym.site.error_model import ErrorModel
from azgym.track.gated_ekf import DEFAULT_NOISE, GatedEkf, subset
from azgym.track.kinematics import WHEELBASE
from azgym.track.repair import STREAK_GAP_S, MapRepair, Repair
from azgym.track.repair_lag import Lag, Lagged
from azgym.track.unicycle import IPHI, IX, IY, Step, predict

__all__ = ["Robust"]

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
        confirm_travel: Distance from a tentative start after which a frame whose three (or
            more) beacons all pass the gate confirms it [m].
        repair: Whether to repair the map while tracking (:mod:`azgym.track.repair`).
        repair_sightings: Rejected sightings of a beacon in a row that make it a suspect.
        repair_after: Shortest time those sightings span [s].
        repair_span: Smallest spread a suspect's rays must have to locate it [rad], at most π/2
            (:func:`~azgym.localize.bearings.spread`; by default the observability rule's
            :data:`~azgym.localize.bearings.MIN_SPREAD`, 10°).
        repair_std: Largest standard deviation of a new position along its worst axis, without
            its most telling ray [m].
        **others: As :class:`~azgym.track.gated_ekf.GatedEkf` (``min_init_inliers`` 3).
    """

    name = "robust"

    def __init__(self, *, gate_probability: float = 0.999,
                 delta_alpha_d: float = math.radians(0.4), coverage: bool = True,
                 extra_sigma: float = math.radians(0.1), vehicle: str = FORKLIFT,
                 yaw_source: str | None = None, camera_ahead: float | None = None,
                 wheelbase: float = WHEELBASE, speed_factor: float = 1.0,
                 speed_noise: float = DEFAULT_NOISE.speed_noise,
                 speed_scale: float = DEFAULT_NOISE.speed_scale,
                 scale_walk: float = DEFAULT_NOISE.scale_walk,
                 turn_rate_noise: float = DEFAULT_NOISE.turn_rate_noise,
                 bias_walk: float = DEFAULT_NOISE.bias_walk,
                 heading_walk: float = DEFAULT_NOISE.heading_walk,
                 position_walk: float = DEFAULT_NOISE.position_walk, initializer: str = "ransac",
                 min_init_inliers: int = 3, max_position_std: float = 0.5,
                 relocalize_after: float = 0.5, strong_fix: int = 6,
                 confirm_travel: float = 1.0, repair: bool = False,
                 repair_sightings: int = 5, repair_after: float = 1.0,
                 repair_span: float = MIN_SPREAD, repair_std: float = 0.1) -> None:
        self.max_position_std = max_position_std
        self.repair = repair
        self.repair_sightings = repair_sightings
        self.repair_after = repair_after
        self.repair_span = repair_span
        self.repair_std = repair_std
        self.confirm_travel = confirm_travel
        self.relocalize_after = relocalize_after
        self.strong_fix = strong_fix
        super().__init__(
            gate_probability=gate_probability, delta_alpha_d=delta_alpha_d, coverage=coverage,
            extra_sigma=extra_sigma, vehicle=vehicle, yaw_source=yaw_source,
            camera_ahead=camera_ahead, wheelbase=wheelbase, speed_factor=speed_factor,
            speed_noise=speed_noise, speed_scale=speed_scale, scale_walk=scale_walk,
            turn_rate_noise=turn_rate_noise, bias_walk=bias_walk, heading_walk=heading_walk,
            position_walk=position_walk, initializer=initializer,
            min_init_inliers=min_init_inliers)

    def _check_params(self) -> None:
        super()._check_params()
        name = type(self).__name__
        check_range(name, "max_position_std", self.max_position_std, low=0.0, low_open=True)
        check_range(name, "relocalize_after", self.relocalize_after, low=0.0)
        check_range(name, "strong_fix", self.strong_fix, low=4, integer=True)
        check_range(name, "confirm_travel", self.confirm_travel, low=0.0)
        check_flag(name, "repair", self.repair)
        check_range(name, "repair_sightings", self.repair_sightings, low=2, high=1000,
                    integer=True)
        check_range(name, "repair_after", self.repair_after, low=0.0, high=3600.0)
        check_range(name, "repair_span", self.repair_span, low=0.0, high=math.pi / 2,
                    low_open=True)
        check_range(name, "repair_std", self.repair_std, low=0.0, low_open=True)

    def _reset(self, rng: np.random.Generator, initial: Pose | None) -> None:
        super()._reset(rng, initial)
        self._tentative = False
        self._bad_since: float | None = None
        self._started_at = np.zeros(2)
        self._checked = 0
        self._repair = MapRepair(
            sightings=int(self.repair_sightings), after=float(self.repair_after),
            span=float(self.repair_span), max_std=float(self.repair_std),
            threshold=self._threshold,
            error_model=ErrorModel(float(self.delta_alpha_d), bool(self.coverage)),
            extra_sigma=float(self.extra_sigma)) if self.repair else None
        self._replay_time: float | None = None
        self._pending: list[Step] = []
        self._lag = Lag(self._snapshot()) if self.repair else None

    @property
    def repairs(self) -> tuple[Repair, ...]:
        """The repairs made since ``reset`` (none unless ``repair``)."""
        repair = self.__dict__.get("_repair")
        return () if repair is None else tuple(repair.repairs)

    @property
    def placed(self) -> dict[int, Repair]:
        """Where the tracker has each beacon repaired since ``reset`` now, as a :class:`Repair`.

        A beacon kept in the state: its ``new`` position and ``covariance`` the state's now, the
        rest its repair's. One refined from its rays: the latest refinement's. ``old`` is the
        map's position.
        """
        repair = self.__dict__.get("_repair")
        return {} if repair is None else dict(repair.placed)

    def _now(self) -> float:
        if self._replay_time is not None:
            return self._replay_time
        return self._steps.time if self._steps.time is not None else 0.0

    def _restart(self, fix: Estimate, covariance: FloatArray) -> Estimate:
        """Start from a per-frame fix: tentative when it has only three inliers."""
        self._start(np.array(fix.pose), covariance)
        self._bad_since = None
        self._tentative = fix.n_inliers < CONFIRMING_BEACONS
        self._started_at = np.array(fix.pose[:2])
        self._checked = 0
        return self._answer(fix.inliers, {"initialized": True})

    def _predict(self, motion: Motion) -> None:
        if self._lag is None:
            super()._predict(motion)
            return
        steps = self._steps.steps(motion)
        self._pending += steps
        self._move(steps)

    def _move(self, steps: list[Step]) -> None:
        """Predict through motion steps (a running track), as gated-ekf does."""
        for step in steps:
            if self._running:
                predict(self._state, self._cov, step, self._lever, self._noise)

    def _update(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        if self._repair is None or self._lag is None:
            return self._track(measurements, beacons)
        return self._track_and_repair(self._repair, self._lag, measurements, beacons)

    def _track_and_repair(self, repair: MapRepair, lag: Lag, measurements: Measurements,
                          given: BeaconMap) -> Estimate:
        """Track on the repaired map without the suspects' detections, then take the sightings.

        The sightings go to :mod:`azgym.track.repair`, the frame to the lag. A frame that makes
        a suspect re-runs the track from before the suspect's stretch of sightings
        (:mod:`azgym.track.repair_lag`), and the suspect is located from the re-run track.
        """
        beacons = repair.begin_frame(given)
        estimate, inliers, rows = self._track_usable(repair, measurements, beacons)
        confident = estimate.ok and self._running and self._bad_since is None
        now = self._now()
        suspected, repaired = repair.observe(now, measurements, inliers, beacons, self._state,
                                             self._cov, confident)
        lag.close(now, self._pending, measurements, self._snapshot)
        self._pending = []
        replayed = 0
        if suspected:
            frames = lag.replayable({beacon: repair.began(beacon) for beacon in suspected},
                                    STREAK_GAP_S)
            if frames:
                estimate, inliers = self._replay(repair, lag, frames, suspected,
                                                 repair.map_for(given))
                replayed = len(frames)
            repaired += repair.relocate(suspected, now, repair.map_for(given))
        self._state, self._cov = repair.take_state(self._state, self._cov)
        if rows is None and not suspected and not repaired:
            return estimate
        diagnostics = dict(estimate.diagnostics)
        if suspected:
            diagnostics["suspected"] = tuple(suspected)
            diagnostics["replayed"] = replayed
        if repaired:
            diagnostics["repaired"] = tuple(repaired)
        return dataclasses.replace(estimate, inliers=inliers, diagnostics=diagnostics)

    def _track_usable(self, repair: MapRepair, measurements: Measurements, beacons: BeaconMap
                      ) -> tuple[Estimate, np.ndarray, np.ndarray | None]:
        """One frame tracked without the suspects' detections.

        Returns:
            The estimate, its inliers among all the detections, and the rows tracked (None:
            every one).
        """
        rows = repair.usable(measurements)
        if rows is None:
            estimate = self._track(measurements, beacons)
            return estimate, estimate.inliers, None
        estimate = self._track(subset(measurements, rows), beacons)
        inliers = np.zeros(len(measurements), dtype=bool)
        inliers[rows[estimate.inliers]] = True
        return estimate, inliers, rows

    def _replay(self, repair: MapRepair, lag: Lag, frames: list[Lagged], suspected: list[int],
                beacons: BeaconMap) -> tuple[Estimate, np.ndarray]:
        """Re-run the lag's ``frames`` without the suspects; the last one's estimate, inliers.

        From the snapshot before the first; the snapshots re-run replace those taken, and a
        confident re-run track's sightings of the new suspects are their rays.
        """
        repair.forget_rays(suspected)
        snapshots = lag.snapshots
        self._restore(snapshots[frames[0][0]])
        for number, steps, time, measurements in frames:
            if number in snapshots:
                snapshots[number] = self._snapshot()
            self._move(steps)
            self._replay_time = time
            estimate, inliers, _ = self._track_usable(repair, measurements, beacons)
            if estimate.ok and self._running and self._bad_since is None:
                repair.retrace(suspected, measurements, beacons, self._state, self._cov)
        self._replay_time = None
        if frames[-1][0] + 1 in snapshots:
            snapshots[frames[-1][0] + 1] = self._snapshot()
        return estimate, inliers

    def _snapshot(self) -> tuple:
        """The filter's state, for :meth:`_restore`."""
        return (self._state.copy(), self._cov.copy(), self._running, self._tentative,
                self._bad_since, self._started_at, self._checked,
                None if self._repair is None else self._repair.kept.stamp())

    def _restore(self, snapshot: tuple) -> None:
        """Go back to a :meth:`_snapshot`."""
        state, cov, self._running, self._tentative, self._bad_since, self._started_at, \
            self._checked, stamp = snapshot
        self._state, self._cov = state.copy(), cov.copy()
        if self._repair is not None:  # beacons kept or placed afresh since are set as now
            self._state, self._cov = self._repair.kept.restored(self._state, self._cov,
                                                                self._repair.placed, stamp)

    def _state_columns(self, problem: Problem, beacons: BeaconMap) -> IntArray | None:
        """The repaired beacons the state keeps (:mod:`azgym.track.repair_state`)."""
        if self._repair is None or not self._repair.kept.columns:
            return None  # the frame's hot path: nothing kept
        return self._repair.kept.columns_of(beacons.ids[problem.ints[ROW_BEACON_INDEX]])

    def _track(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        """One frame of the tracker without map repair (module docstring)."""
        if not self._running:
            found = self._fix(measurements, beacons)
            if found is None:
                return Estimate.failure(f"not initialized: {self._why}", len(measurements))
            return self._restart(*found)
        if self._position_std() > self.max_position_std:
            return self._relocalize(measurements, beacons)
        inliers, distinct = self._correct(measurements, beacons)
        accepted = int(np.count_nonzero(inliers))
        inconsistent = distinct >= 3 and 2 * accepted < distinct
        if self._tentative:
            if accepted < distinct:
                self._running = False  # a tentative start the frame contradicts
                return self._track(measurements, beacons)
            self._tentative = not self._confirms(accepted)
        self._bad_since = (self._bad_since if self._bad_since is not None else self._now()) \
            if inconsistent else None
        if inconsistent:
            found = self._fix(measurements, beacons)
            if found is not None and self._should_restart(found[0], accepted):
                return self._restart(*found)
        return self._answer(inliers)

    def _confirms(self, accepted: int) -> bool:
        """Whether a frame all of whose beacons passed the gate confirms a tentative start.

        Four beacons in one frame do; so do three azimuths, in one frame or over several, that
        passed once the camera had moved ``confirm_travel`` from the start: the azimuths of poses
        the start was not fitted to, reached by odometry, check it (a standing camera's frames
        repeat the start's geometry and check nothing; a forward camera sees one or two beacons
        a frame).
        """
        if accepted >= CONFIRMING_BEACONS:
            return True
        travel = math.hypot(*(self._state[[IX, IY]] - self._started_at))
        if travel >= self.confirm_travel:
            self._checked += accepted
        return self._checked >= 3

    def _relocalize(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        """A lost track (its prediction beyond ``max_position_std``) moves to a per-frame fix.

        A prediction that wide is not corrected where it stands: one linearized update from
        metres away lets every azimuth through the gate and lands, with a tight covariance,
        wherever the linearization led it (8 m off after a kidnapping). The track moves to the
        fix's pose, keeps its wide covariance (and its gyro bias and odometry scale), and is
        corrected there by the fix's inliers alone: the frame's azimuths, linearized where they
        were fitted. Without a fix it only answers that it is lost.
        """
        inliers = np.zeros(len(measurements), dtype=bool)
        found = self._fix(measurements, beacons)
        if found is None:
            return self._answer(inliers)
        fix, _ = found
        self._state[[IX, IY, IPHI]] = fix.pose
        self._started_at = np.array(fix.pose[:2])
        self._tentative = fix.n_inliers < CONFIRMING_BEACONS
        self._checked = 0
        self._bad_since = None
        chosen = np.flatnonzero(fix.inliers)
        accepted, _ = self._correct(subset(measurements, chosen), beacons)
        inliers[chosen[accepted]] = True
        return self._answer(inliers, {"relocalized": True})

    def _should_restart(self, fix: Estimate, accepted: int) -> bool:
        """Whether a per-frame fix should replace an inconsistent track (module docstring)."""
        if fix.n_inliers >= self.strong_fix and fix.n_inliers > 2 * accepted:
            return True
        return self._bad_since is not None and \
            self._now() - self._bad_since >= self.relocalize_after

    def _position_std(self) -> float:
        return math.sqrt(self._cov[IX, IX] + self._cov[IY, IY])

    def _answer(self, inliers: np.ndarray, diagnostics: dict | None = None) -> Estimate:
        """The estimate, or a failure while the start is tentative or the track is too unsure."""
        if self._tentative:
            return Estimate.failure(
                "tentative start from three inliers, not yet confirmed by "
                f"{CONFIRMING_BEACONS} beacons in one frame or three azimuths after confirm_travel="
                f"{self.confirm_travel} m", inliers.size)
        std = self._position_std()
        if std > self.max_position_std:
            return Estimate.failure(
                f"lost: predicted position std {std:.2f} m exceeds max_position_std="
                f"{self.max_position_std} m", inliers.size)
        return self._estimate(inliers, diagnostics)
