"""Repaired beacons kept in the tracker's state, as a SLAM filter keeps its map.

A beacon located again from its rays (:mod:`azgym.track.repair`) is placed a few centimetres
off. Used at that position, its error is the same in every frame: weighing its azimuths by
the position's uncertainty treats that error as new noise each frame, and rays gathered later
to refine it start from the very track it pulls. Plotter's SLAM filter keeps its map in the
filter's state instead, and so does robust with ``repair=True``: a repaired beacon's (x, y)
is appended to the state [x, y, φ, b, k] with the repair's covariance (no tie to the pose);
each of its azimuths then corrects the beacon and the pose jointly (the beacon's Jacobian
columns, :func:`~azgym.track.azimuth_update.gated_update`), the prediction leaves it where it
is (:func:`~azgym.track.unicycle.predict`), and a restart of the pose keeps it
(:meth:`~azgym.track.gated_ekf.GatedEkf._start`). Where it is now, read back from the state
every frame, is its placement (:attr:`~azgym.track.repair.MapRepair.placed`).

At most :data:`MAX_KEPT` beacons are kept (a state of 5 + 2 × 8 entries at most); a repaired
beacon beyond them is used at its placement, weighed by its uncertainty, and refined from its
rays. One located afresh (moved again) has its entries set anew from the new placement.

A re-run of the lag (:mod:`azgym.track.repair_lag`) starts from a snapshot of the state: a
beacon kept since it was taken, or placed afresh since (its :meth:`StateBeacons.stamp` tells),
has its entries set from its placement now (:meth:`StateBeacons.restored`), not brought back
from before.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from azgym.core import BeaconMap, FloatArray, IntArray
from azgym.track.repair_records import Repair
from azgym.track.unicycle import STATE_SIZE

__all__ = ["MAX_KEPT", "StateBeacons", "placed_map"]

MAX_KEPT = 8
"""Most repaired beacons kept in the state: bounds its size and each update's cost."""


class StateBeacons:
    """Which repaired beacons the state keeps, and where (module docstring)."""

    def __init__(self) -> None:
        self.columns: dict[int, int] = {}
        """Each kept beacon's column of x in the state (y the next)."""
        self._pending: list[int] = []
        self._placings: dict[int, int] = {}
        """How often each kept beacon's entries have been set from a placement."""

    def __len__(self) -> int:
        """The beacons kept or about to be (one placed afresh counted once)."""
        return len(self.columns.keys() | set(self._pending))

    def __contains__(self, beacon: object) -> bool:
        return beacon in self.columns or beacon in self._pending

    def reserve(self, beacon: int) -> bool:
        """Whether a beacon just placed goes into the state (its entries set at :meth:`sync`).

        False when :data:`MAX_KEPT` others are kept or about to be.
        """
        if beacon not in self and len(self) >= MAX_KEPT:
            return False
        if beacon not in self._pending:
            self._pending.append(beacon)
        return True

    def stamp(self) -> dict[int, int]:
        """What a snapshot of the state keeps to be :meth:`restored`: which placements it has."""
        return dict(self._placings)

    def columns_of(self, ids: IntArray) -> IntArray:
        """Per measured beacon id, its state column (−1: at its map position)."""
        return np.array([self.columns.get(beacon, -1) for beacon in ids.tolist()],
                        dtype=np.int64)

    def sync(self, state: FloatArray, cov: FloatArray, placed: dict[int, Repair]
             ) -> tuple[FloatArray, FloatArray]:
        """Take the beacons reserved into the state; each kept one's placement from it.

        Args:
            state: The tracker's state (``STATE_SIZE`` + 2 per kept beacon); grown, not changed
                in place, when a beacon is added.
            cov: Its covariance.
            placed: The repair's placements (:attr:`~azgym.track.repair.MapRepair.placed`),
                rewritten for the kept beacons.

        Returns:
            The state and covariance, grown by the beacons taken in.
        """
        for beacon in self._pending:
            column = self.columns.setdefault(beacon, STATE_SIZE + 2 * len(self.columns))
            state, cov = _set(state, cov, column, placed[beacon])
            self._placings[beacon] = self._placings.get(beacon, 0) + 1
        self._pending.clear()
        for beacon, column in self.columns.items():
            placed[beacon] = dataclasses.replace(
                placed[beacon], new=(float(state[column]), float(state[column + 1])),
                covariance=cov[column:column + 2, column:column + 2])  # copied by Repair
        return state, cov

    def restored(self, state: FloatArray, cov: FloatArray, placed: dict[int, Repair],
                 stamp: dict[int, int]) -> tuple[FloatArray, FloatArray]:
        """A snapshot's state, with the kept beacons it holds from an older placement set anew.

        The state of a snapshot the track re-runs from (:mod:`azgym.track.repair_lag`): a beacon
        kept since is appended, and one placed afresh since (``stamp``: the snapshot's
        :meth:`stamp`) or about to be (reserved again) has its entries set anew, its ties to the
        rest cut, as :meth:`sync` sets them.
        """
        for beacon, column in self.columns.items():
            if beacon in self._pending or stamp.get(beacon) != self._placings[beacon]:
                state, cov = _set(state, cov, column, placed[beacon])
        return state, cov


def placed_map(beacons: BeaconMap, placed: dict[int, Repair], kept: StateBeacons) -> BeaconMap:
    """``beacons`` with every repaired beacon at its placement (its height kept).

    A beacon the state does not keep has its width widened from W to √(W² + 12σ²), σ its
    placement's worst-axis standard deviation: eq. 2's coverage term, (W/2D)²/3 at range D,
    then adds (σ/D)² to its azimuth's variance. A kept one's uncertainty is in the state.
    """
    xyz, width = beacons.xyz.copy(), beacons.width.copy()
    for row, beacon in enumerate(beacons.ids.tolist()):
        if beacon in placed:
            xyz[row, :2] = placed[beacon].new
            if beacon not in kept:
                width[row] = math.sqrt(width[row] ** 2 + 12.0 * placed[beacon].std ** 2)
    return BeaconMap(beacons.ids, xyz, width)


def _set(state: FloatArray, cov: FloatArray, column: int, placement: Repair
         ) -> tuple[FloatArray, FloatArray]:
    """A beacon's entries at ``column`` set from its placement, untied (grown to hold them)."""
    state, cov = _grown(state, cov, column + 2)
    state[column:column + 2] = placement.new
    cov[column:column + 2, :] = 0.0
    cov[:, column:column + 2] = 0.0
    cov[column:column + 2, column:column + 2] = placement.covariance
    return state, cov


def _grown(state: FloatArray, cov: FloatArray, size: int) -> tuple[FloatArray, FloatArray]:
    """``state`` and ``cov`` with zero entries up to ``size`` (themselves when as large)."""
    if state.size >= size:
        return state, cov
    grown, wider = np.zeros(size), np.zeros((size, size))
    grown[:state.size] = state
    wider[:state.size, :state.size] = cov
    return grown, wider
