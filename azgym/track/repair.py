"""Map repair while tracking: a beacon that moved is noticed, set aside, located again and used.

:class:`~azgym.track.robust.Robust` with ``repair=True`` hands every frame it has corrected to a
:class:`MapRepair`, which keeps a record per beacon (docs/trackers.md, "Map repair"):

* **A sighting** is one frame's detections of one beacon. It *agrees* when one of them passed
  the tracker's gate and leave-one-out test (:mod:`azgym.track.azimuth_update`), and is
  *rejected* when none did. Under the error model a good beacon's sighting is rejected with
  probability 1 − ``gate_probability`` (0.001), so a run of n rejections has probability about
  0.001ⁿ; ghosts and misread ids do not come in runs that last.
* **Suspected**: a beacon is suspected after ``sightings`` rejected sightings in a row (none
  agreeing between, none more than :data:`STREAK_GAP_S` after the one before) spanning at
  least ``after`` seconds, while the other beacons agree: since its run began they agreed in
  at least :data:`OTHERS_AGREE` sightings, of at least :data:`OTHERS_DISTINCT` beacons, and in
  at least twice as many as they were rejected in. A track that is wrong sees every beacon
  rejected, so its error is not taken for a move.
  Only sightings of a confident track count (running, confirmed, not lost, consistent).
* **Suspected, too, when the track fits it** (a move along the line of sight, whose azimuths
  pass the gate: :mod:`azgym.track.repair_fit`). Sightings that pass the gate do not clear such
  a suspect; only locating it where the map has it does.
* **Set aside**: its detections are removed before the correction, and the track is re-run
  without it from before its stretch of sightings (:mod:`azgym.track.repair_lag`); its rays
  are taken afresh (:meth:`MapRepair.retrace`) and it is located (:meth:`MapRepair.relocate`).
* **Located again** (:func:`~azgym.track.repair_rays.locate`): each sighting gives a ray per
  detection from the tracker's camera along its heading plus the azimuth. The point the most
  sightings meet, inside the map's box grown by :data:`OUTSIDE_M` (beyond lies a mirror's
  image), is taken once their rays spread ``span`` and fix it within ``max_std`` without the
  most telling of them, unless it is within :data:`CLEARANCE_M` (or three standard
  deviations) of another beacon (its detections under a misread id) or of its own map
  position (it did not move): the suspicion is then dropped.
* **Used again**: the beacon goes into the tracker's state at its new position, with its
  covariance, and is corrected with the pose by its azimuths (:mod:`azgym.track.repair_state`;
  its placement, :attr:`MapRepair.placed`, is where the state has it). The repair is reported
  (:class:`Repair`), once. Beyond the beacons the state keeps, a repaired beacon is used at
  its placement, its width widened from W to √(W² + 12σ²) (σ its worst-axis standard
  deviation: eq. 2's coverage term then adds (σ/D)² to its azimuth's variance at range D),
  and *refined*: whenever its rays grow by :data:`RETRY_GROWTH`, a more certain position from
  those within the gate of its placement replaces it. A suspect of rejections whose map
  position agrees again in ``sightings`` sightings in a row is cleared; a repaired beacon
  suspected again is located afresh.
"""

from __future__ import annotations

import math
from collections.abc import Collection

import numpy as np

from azgym.core import BeaconMap, FloatArray, Measurements
from azgym.localize.base import ROW_BEACON_INDEX, Problem
from azgym.localize.bearings import spread
from azgym.site.error_model import ErrorModel
from azgym.track.azimuth_update import gated_update
from azgym.track.gated_ekf import subset
from azgym.track.repair_fit import FitTest
from azgym.track.repair_rays import RayStore, locate, pack
from azgym.track.repair_records import Repair, Run
from azgym.track.repair_state import StateBeacons, placed_map
from azgym.track.unicycle import IPHI, IX, IY

__all__ = ["CLEARANCE_M", "OTHERS_AGREE", "OTHERS_DISTINCT", "OUTSIDE_M", "RETRY_GROWTH",
           "STREAK_GAP_S", "MapRepair", "Repair"]

STREAK_GAP_S = 2.0
"""Longest time between two rejected sightings of one run [s]: a beacon out of sight longer
starts a new run (its earlier rays are from a track that has moved on)."""
OTHERS_AGREE = 2
"""Fewest agreeing sightings of other beacons since a run began that let it make a suspect."""
OTHERS_DISTINCT = 2
"""Fewest distinct other beacons that must have agreed since a run began: with one other in
view (a narrow camera), a beacon that moved a little drags the track and the one that did not
is rejected, so one other's agreement cannot tell which of the two moved."""
CLEARANCE_M = 0.25
"""A new position closer than this (or three standard deviations) to another beacon is that
beacon's, seen under a misread id [m]."""
OUTSIDE_M = 1.0
"""A new position further than this outside the box of the map's beacons is a mirror's image
(beacons hang on the walls and racks; what lies behind a wall is seen in it) [m]."""
RETRY_GROWTH = 0.125
"""A suspect is located again only once its rays or their spread (a repaired beacon, refined:
its rays) have grown by this share (one ray at least) since the last try: rays that never meet
(random azimuths, whose spread jitters just below π/2; one standing place) cost a bounded share
of the tracker's time, while a beacon the camera sweeps past is tried as its rays widen."""


class MapRepair:
    """The per-beacon records of a tracker's map repair (module docstring).

    Args:
        sightings: Rejected sightings in a row that make a suspect (and agreeing ones that
            clear it).
        after: Shortest time those rejected sightings span [s].
        span: Smallest spread of a suspect's rays [rad].
        max_std: Largest standard deviation of a new position along its worst axis [m].
        threshold: The tracker's gate (chi-square, one degree of freedom).
        error_model: The azimuth error model (eq. 1-3).
        extra_sigma: Azimuth noise beyond it [rad].
    """

    def __init__(self, *, sightings: int, after: float, span: float, max_std: float,
                 threshold: float, error_model: ErrorModel, extra_sigma: float) -> None:
        self.sightings = sightings
        self.after = after
        self.span = span
        self.max_std = max_std
        self.threshold = threshold
        self.error_model = error_model
        self.extra_sigma = extra_sigma
        self.repairs: list[Repair] = []
        self._runs: dict[int, Run] = {}
        self.placed: dict[int, Repair] = {}
        """Each repaired beacon's placement now: the state's (:meth:`take_state`), or rays'."""
        self._refining: dict[int, Run] = {}
        self._accepted = 0
        self._agreed_by: dict[int, int] = {}
        self._rejected = 0
        self._frame = -1
        self._given: BeaconMap | None = None
        self._current: BeaconMap | None = None
        self._rows_of: BeaconMap | None = None
        self._rows: dict[int, int] = {}
        self._fits = FitTest(error_model, extra_sigma)
        self.kept = StateBeacons()
        """The repaired beacons the tracker's state keeps (:meth:`take_state`)."""

    @property
    def suspects(self) -> tuple[int, ...]:
        """The ids of the beacons set aside now."""
        return tuple(beacon for beacon, run in self._runs.items() if run.suspected)

    def begin_frame(self, beacons: BeaconMap) -> BeaconMap:
        """Count a frame; the map to correct it with (:meth:`map_for`)."""
        self._frame += 1
        return self.map_for(beacons)

    def map_for(self, beacons: BeaconMap) -> BeaconMap:
        """``beacons`` with every repaired beacon at its new position (itself when none is)."""
        if not self.placed:
            return beacons
        if beacons is not self._given or self._current is None:
            self._given, self._current = beacons, placed_map(beacons, self.placed, self.kept)
        return self._current

    def usable(self, measurements: Measurements) -> np.ndarray | None:
        """The rows of the detections not of a suspect, or None when every row is."""
        if not self._runs:
            return None
        suspects = self.suspects
        if not suspects:
            return None
        ids = measurements.ids.tolist()
        rows = [row for row, beacon in enumerate(ids) if beacon not in suspects]
        return None if len(rows) == len(ids) else np.array(rows, dtype=np.intp)

    def observe(self, time: float, measurements: Measurements, inliers: np.ndarray,
                beacons: BeaconMap, state: FloatArray, cov: FloatArray,
                confident: bool) -> tuple[list[int], list[Repair]]:
        """Take a corrected frame: its sightings, rays and verdicts.

        A frame whose detections were all used, with no record open, goes to the fit test only.

        Args:
            time: The frame's time [s].
            measurements: All its detections, the suspects' included.
            inliers: Which of them the tracker used (M,).
            beacons: The map the tracker corrected with (:meth:`begin_frame`).
            state: The tracker's state after the correction.
            cov: Its covariance.
            confident: Whether the track is confident enough for its sightings to count.

        Returns:
            The beacons newly suspected, and the repairs made, in this frame.
        """
        suspected: list[int] = []
        self._forget_lapsed(time)
        if confident:
            self._fits.record(time, measurements, inliers, state, cov)
            if (fitted := self._fits.moved(time, beacons)) is not None:
                self._set_aside(fitted, Run(self._fits.began(fitted), time, self._accepted,
                                            self._rejected, dict(self._agreed_by), fitted=True))
                suspected.append(fitted)
        if not self._runs and not self._refining and all(inliers.tolist()):  # each one used
            return suspected, []  # agreements count only while a run is open (_agree)
        map_rows = self._map_rows(beacons)
        sightings: dict[int, list[int]] = {}
        agreeing = set()  # the beacons one of whose detections the tracker used
        for row, (beacon, used) in enumerate(zip(measurements.ids.tolist(), inliers.tolist(),
                                                 strict=True)):
            if beacon in map_rows:
                sightings.setdefault(beacon, []).append(row)
                if used:
                    agreeing.add(beacon)
        touched: list[int] = []
        for beacon, rows in sorted(sightings.items()):
            refining = self._refining.get(beacon)
            if refining is not None and confident:
                self._add_rays(refining, measurements, np.array(rows), map_rows[beacon],
                               beacons, state, cov)
                self._refine(beacon, refining, time, beacons)
            run = self._runs.get(beacon)
            if run is not None and run.suspected:
                self._suspect_sighting(beacon, run, measurements, np.array(rows), beacons,
                                       state, cov)
                touched.append(beacon)
            elif beacon in agreeing:
                if confident and self._runs:
                    self._agree(beacon)
                self._runs.pop(beacon, None)
            elif confident and self._reject(beacon, time, measurements, np.array(rows),
                                            beacons, state, cov):
                suspected.append(beacon)  # located by :meth:`relocate`, or at its next sighting
        repairs = [found for beacon in touched
                   if (found := self._try_repair(beacon, time, beacons)) is not None]
        return suspected, repairs

    def take_state(self, state: FloatArray, cov: FloatArray) -> tuple[FloatArray, FloatArray]:
        """The state after a frame with the beacons just repaired in it; placements from it."""
        if not self.kept:
            return state, cov
        self._current = None
        return self.kept.sync(state, cov, self.placed)

    def began(self, beacon: int) -> float:
        """When a suspect's run of rejections began [s]."""
        return self._runs[beacon].since

    def forget_rays(self, beacons: Collection[int]) -> None:
        """Drop suspects' rays, to take them again from a re-run track (:meth:`retrace`)."""
        for beacon in beacons:
            run = self._runs[beacon]
            run.rays, run.sightings, run.tried, run.tried_span = RayStore(), 0, 0, 0.0

    def retrace(self, beacons: Collection[int], measurements: Measurements, current: BeaconMap,
                state: FloatArray, cov: FloatArray) -> None:
        """A re-run track's frame: its sightings of suspects ``beacons`` become their rays."""
        map_rows = self._map_rows(current)
        ids = measurements.ids
        for beacon in beacons:
            rows = np.flatnonzero(ids == beacon)
            if rows.size and beacon in map_rows:
                self._add_rays(self._runs[beacon], measurements, rows, map_rows[beacon], current,
                               state, cov)

    def relocate(self, beacons: Collection[int], time: float, current: BeaconMap
                 ) -> list[Repair]:
        """Try to locate suspects from their rays; the repairs made."""
        return [found for beacon in beacons
                if (found := self._try_repair(beacon, time, current)) is not None]

    def _reject(self, beacon: int, time: float, measurements: Measurements, rows: np.ndarray,
                beacons: BeaconMap, state: FloatArray, cov: FloatArray) -> bool:
        """Count a confident track's rejected sighting of a beacon; whether it is now a suspect."""
        run = self._runs.get(beacon)
        if run is None:
            run = self._runs[beacon] = Run(time, time, self._accepted, self._rejected,
                                            dict(self._agreed_by))
        self._rejected += 1
        run.rejected += 1
        run.last = time
        self._add_rays(run, measurements, rows, self._rows[beacon], beacons, state, cov)
        if not self._suspicious(run, time):
            return False
        self._set_aside(beacon, run)
        return True

    def _set_aside(self, beacon: int, run: Run) -> None:
        """Make ``run`` a suspect's: its beacon's refinement and fit-test window are dropped."""
        run.suspected = True
        self._runs[beacon] = run
        self._refining.pop(beacon, None)
        self._fits.forget(beacon)

    def _agree(self, beacon: int) -> None:
        """Count an agreeing sighting of ``beacon`` while a run is open.

        A run reads the counts from its start: what none would read is not counted.
        """
        self._accepted += 1
        self._agreed_by[beacon] = self._agreed_by.get(beacon, 0) + 1

    def _map_rows(self, beacons: BeaconMap) -> dict[int, int]:
        """Each of the map's beacon ids' row (kept while the map is the same object)."""
        if beacons is not self._rows_of:
            self._rows_of = beacons
            self._rows = {beacon: row for row, beacon in enumerate(beacons.ids.tolist())}
        return self._rows

    def _forget_lapsed(self, time: float) -> None:
        """Drop the runs not suspected and lapsed (none rejected for :data:`STREAK_GAP_S`).

        The records held are the suspects' and those of beacons rejected lately, however many.
        """
        if self._runs:  # a frame with none open costs nothing here
            self._runs = {beacon: run for beacon, run in self._runs.items()
                          if run.suspected or time - run.last <= STREAK_GAP_S}

    def _suspicious(self, run: Run, time: float) -> bool:
        """Whether a run makes its beacon a suspect (module docstring)."""
        if run.rejected < self.sightings or time - run.since < self.after:
            return False
        accepted = self._accepted - run.others_accepted
        rejected = self._rejected - run.others_rejected - run.rejected
        if accepted < OTHERS_AGREE or accepted < 2 * rejected:
            return False
        others = sum(count > run.others_by.get(beacon, 0)
                     for beacon, count in self._agreed_by.items())
        return others >= OTHERS_DISTINCT

    def _suspect_sighting(self, beacon: int, run: Run, measurements: Measurements,
                          rows: np.ndarray, beacons: BeaconMap, state: FloatArray,
                          cov: FloatArray) -> None:
        """A suspect's sighting: a ray, or one of the agreeing ones in a row that clear it.

        Agreeing sightings clear a suspect of rejections only: the fit test's agreed before.
        """
        if not run.fitted:
            problem = Problem.from_frame(subset(measurements, rows), beacons)
            passed, _ = gated_update(state.copy(), cov.copy(), problem.floats,
                                     problem.ints[ROW_BEACON_INDEX],
                                     self.error_model.delta_alpha_d, self.error_model.coverage,
                                     self.extra_sigma, self.threshold)
            if passed.any():
                run.agreed += 1
                if run.agreed >= self.sightings:
                    del self._runs[beacon]
                return
            run.agreed = 0
        self._add_rays(run, measurements, rows, self._rows[beacon], beacons, state, cov)

    def _add_rays(self, run: Run, measurements: Measurements, rows: np.ndarray, row: int,
                  beacons: BeaconMap, state: FloatArray, cov: FloatArray) -> None:
        """A sighting's rays: each detection's, from the track's camera (:func:`pack`)."""
        at = beacons.xyz[row, :2]
        distance = math.hypot(*(at - state[[IX, IY]]))
        variance = float(self.error_model.variance(distance, beacons.width[row])) \
            + self.extra_sigma ** 2 + cov[IPHI, IPHI]
        run.rays.add(pack(state[[IX, IY]], state[IPHI] + measurements.azimuth[rows], variance,
                          cov[np.ix_([IX, IY], [IX, IY])], float(cov[IPHI, IPHI]),
                          run.sightings))
        run.sightings += 1

    def _locate(self, run: Run, beacons: BeaconMap, placed: FloatArray | None = None
                ) -> tuple[FloatArray, FloatArray, float, int] | None:
        """Where a record's rays put its beacon (module docstring), or None.

        :func:`~azgym.track.repair_rays.locate`'s answer, inside the box of the map's beacons
        grown by :data:`OUTSIDE_M`. Tried once the rays spread ``span``, and again whenever they
        or their spread have grown by :data:`RETRY_GROWTH` since the last try (a ``placed`` one,
        refined: once they have grown).
        """
        grown = run.rays.added - run.tried >= max(1.0, RETRY_GROWTH * len(run.rays))
        if len(run.rays) < 3 or (placed is not None and not grown):
            return None
        rays = run.rays.latest()
        span = spread(rays[:, 2])
        if span < self.span or (span <= (1.0 + RETRY_GROWTH) * run.tried_span and not grown):
            return None
        run.tried, run.tried_span = run.rays.added, span
        box = (beacons.xyz[:, :2].min(axis=0) - OUTSIDE_M,
               beacons.xyz[:, :2].max(axis=0) + OUTSIDE_M)
        return locate(rays, self.span, self.threshold, self.max_std, box, placed)

    def _try_repair(self, beacon: int, time: float, beacons: BeaconMap) -> Repair | None:
        """Locate a suspect from its rays; its repair, or None (module docstring)."""
        run = self._runs.get(beacon)
        found = None if run is None else self._locate(run, beacons)
        if run is None or found is None:
            return None
        point, covariance, run.std, rays = found
        std = math.sqrt(np.linalg.eigvalsh(covariance)[-1])
        gaps = np.hypot(*(beacons.xyz[:, :2] - point).T)
        own = beacons.ids == beacon
        old = beacons.xyz[own, :2][0]
        del self._runs[beacon]
        if (gaps[~own] < max(CLEARANCE_M, 3.0 * std)).any() or gaps[own][0] < 3.0 * std:
            return None  # another beacon under a misread id, or not moved at all
        if not self.kept.reserve(beacon):
            self._refining[beacon] = run
        repair = self._place(time, beacon, (float(old[0]), float(old[1])), point, covariance,
                             rays)
        self.repairs.append(repair)
        return repair

    def _refine(self, beacon: int, run: Run, time: float, beacons: BeaconMap) -> None:
        """Move a repaired beacon to where its rays put it now, if more certainly (docstring)."""
        found = self._locate(run, beacons, np.array(self.placed[beacon].new))
        if found is not None and found[2] < run.std:
            point, covariance, run.std, rays = found
            self._place(time, beacon, self.placed[beacon].old, point, covariance, rays)

    def _place(self, time: float, beacon: int, old: tuple[float, float], point: FloatArray,
               covariance: FloatArray, rays: int) -> Repair:
        """Put a beacon at ``point`` in the map the tracker corrects with; its record."""
        self._current = None
        self._fits.forget(beacon)
        placed = self.placed[beacon] = Repair(
            time=time, frame=self._frame, beacon=beacon, old=old,
            new=(float(point[0]), float(point[1])), covariance=covariance, rays=rays)
        return placed
