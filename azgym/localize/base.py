"""The localizer interface: one public method that validates, one private method that computes.

A localizer turns one frame's :class:`~azgym.core.Measurements` and the
:class:`~azgym.core.BeaconMap` into an :class:`~azgym.core.Estimate`. Hyperparameters are
keyword-only ``__init__`` arguments stored unchanged (the scikit-learn way), so ``get_params()``
shows them and ``repr`` reproduces them. They are validated in ``__init__`` (a bad value fails
where it is written, naming the field) and again by ``localize`` if they were changed since.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from typing import ClassVar

import numpy as np

from azgym.core import BeaconMap, BoolArray, Estimate, FloatArray, IntArray, Measurements
from azgym.errors import InvalidInputError
from azgym.hyperparameters import Hyperparameters
from azgym.jit import jit

__all__ = ["FLOAT_ROWS", "INT_ROWS", "Localizer", "MAX_MEASUREMENTS", "MIN_MEASUREMENTS", "Problem",
           "ROW_AZIMUTH", "ROW_BEACON_INDEX", "ROW_BX", "ROW_BY", "ROW_COS_AZ", "ROW_SIN_AZ",
           "ROW_SOURCE", "ROW_WIDTH", "gather"]

MIN_MEASUREMENTS = 3
"""A 2-D position and a heading are three unknowns: three azimuths are the minimum."""
MAX_MEASUREMENTS = 1024
"""Most detections a localizer accepts in one frame; more raise :class:`InvalidInputError`.

A camera sees tens of beacons at a time, so a frame with more than a thousand detections comes
from a broken detector, not from a scene. The cap bounds every built-in's memory before any work:
ransac and triplet keep the circle equation of every pair of measurements (an M × M × 4 table,
32 MB at the cap), and triplet's and loo's run times grow as M³.
"""

# The rows of Problem.floats. Kernels index the packed array by these names, never by number, so
# the layout is stated here once and a reordering cannot silently swap, say, x and width.
ROW_AZIMUTH = 0
"""Row of ``Problem.floats``: the measured azimuth α [rad]."""
ROW_COS_AZ = 1
"""Row of ``Problem.floats``: cos α, computed once per frame for every kernel."""
ROW_SIN_AZ = 2
"""Row of ``Problem.floats``: sin α."""
ROW_BX = 3
"""Row of ``Problem.floats``: east coordinate x_i of the measured beacon [m]."""
ROW_BY = 4
"""Row of ``Problem.floats``: north coordinate y_i of the measured beacon [m]."""
ROW_WIDTH = 5
"""Row of ``Problem.floats``: width W_i of the measured beacon [m] (the coverage error, eq. 2)."""
FLOAT_ROWS = 6
"""Number of rows of ``Problem.floats``."""

ROW_SOURCE = 0
"""Row of ``Problem.ints``: position of the measurement in the frame's Measurements."""
ROW_BEACON_INDEX = 1
"""Row of ``Problem.ints``: row of the measured beacon in the map (repeated for a ghost)."""
INT_ROWS = 2
"""Number of rows of ``Problem.ints``."""


@jit
def gather(ids, azimuth, sorted_ids, sorted_order, xyz, width):
    """Look up each measured id in the map (binary search); gather the usable measurements.

    Returns the (FLOAT_ROWS, K) float array and the (INT_ROWS, K) int array of a
    :class:`Problem` (rows named by the ``ROW_*`` constants) and the number of distinct beacons:
    two arrays rather than eight, because handing each array back to Python costs about a
    microsecond.
    """
    m = ids.size
    n = sorted_ids.size
    index = np.empty(m, dtype=np.int64)
    usable = 0
    for t in range(m):
        pos = np.searchsorted(sorted_ids, ids[t])
        if pos < n and sorted_ids[pos] == ids[t]:
            index[t] = sorted_order[pos]
            usable += 1
        else:
            index[t] = -1
    floats = np.empty((FLOAT_ROWS, usable))
    ints = np.empty((INT_ROWS, usable), dtype=np.int64)
    seen = np.zeros(n, dtype=np.bool_)
    distinct = 0
    u = 0
    for t in range(m):
        b = index[t]
        if b < 0:
            continue
        ints[ROW_SOURCE, u] = t
        ints[ROW_BEACON_INDEX, u] = b
        floats[ROW_AZIMUTH, u] = azimuth[t]
        floats[ROW_COS_AZ, u] = math.cos(azimuth[t])
        floats[ROW_SIN_AZ, u] = math.sin(azimuth[t])
        floats[ROW_BX, u] = xyz[b, 0]
        floats[ROW_BY, u] = xyz[b, 1]
        floats[ROW_WIDTH, u] = width[b]
        if not seen[b]:
            seen[b] = True
            distinct += 1
        u += 1
    return floats, ints, distinct


class Problem:
    """One frame reduced to the measurements a localizer can use: those with ids in the map.

    The data lives in two packed arrays, ``floats`` (FLOAT_ROWS, K) and ``ints`` (INT_ROWS, K),
    which compiled kernels take whole and index by the ``ROW_*`` constants; the named rows below
    are views of them.

    Attributes:
        floats: Each usable measurement's azimuth [rad], its cos and sin, its beacon's x and y
            [m] and width W [m], one row each (rows ``ROW_AZIMUTH`` to ``ROW_WIDTH``).
        ints: Each usable measurement's source (position in the original Measurements) and
            beacon_index (row of its beacon in the map; repeated for a ghost), one row each
            (rows ``ROW_SOURCE`` and ``ROW_BEACON_INDEX``).
        n_measurements: M, the number of measurements in the frame, usable or not.
        n_distinct: How many different beacons the usable measurements refer to.
    """

    __slots__ = ("floats", "ints", "n_measurements", "n_distinct")

    def __init__(self, floats: FloatArray, ints: IntArray, n_distinct: int,
                 n_measurements: int) -> None:
        self.floats = floats
        self.ints = ints
        self.n_distinct = n_distinct
        self.n_measurements = n_measurements

    @classmethod
    def from_frame(cls, measurements: Measurements, beacons: BeaconMap) -> Problem:
        """Look up every measurement's beacon; drop (and remember) ids the map does not know."""
        floats, ints, distinct = gather(measurements.ids, measurements.azimuth,
                                        *beacons.lookup_tables())
        return cls(floats, ints, distinct, len(measurements))

    @property
    def size(self) -> int:
        """K, the number of usable measurements."""
        return int(self.floats.shape[1])

    azimuth = property(lambda self: self.floats[ROW_AZIMUTH], doc="Usable azimuths [rad], (K,).")
    cos_az = property(lambda self: self.floats[ROW_COS_AZ], doc="cos of ``azimuth``.")
    sin_az = property(lambda self: self.floats[ROW_SIN_AZ], doc="sin of ``azimuth``.")
    bx = property(lambda self: self.floats[ROW_BX], doc="East coordinate of each beacon [m].")
    by = property(lambda self: self.floats[ROW_BY], doc="North coordinate of each beacon [m].")
    width = property(lambda self: self.floats[ROW_WIDTH], doc="Width W of each beacon [m].")
    source = property(lambda self: self.ints[ROW_SOURCE],
                      doc="Position in the original Measurements.")
    beacon_index = property(lambda self: self.ints[ROW_BEACON_INDEX],
                            doc="Row of each beacon in the map.")

    def expand(self, mask: BoolArray) -> BoolArray:
        """Turn a mask over the K usable measurements into one over all M measurements."""
        full = np.zeros(self.n_measurements, dtype=bool)
        full[self.source] = mask
        return full


class Localizer(Hyperparameters, ABC):
    """Base class of every localizer: ``localize`` validates, ``_localize`` computes.

    Subclasses set ``name``, take keyword-only hyperparameters in ``__init__`` (stored as given,
    then checked by calling ``_validate_once``), may override ``_check_params`` and implement
    ``_localize``.
    """

    name: ClassVar[str] = ""

    def localize(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        """Estimate the camera pose from one frame.

        Measurements whose id is not in the map are ignored (never inliers). With fewer than three
        usable measurements, or when the geometry does not determine the pose, the result has
        ``ok=False`` and a ``reason``.

        Args:
            measurements: The frame's detections.
            beacons: The beacon map.

        Raises:
            InvalidInputError: An argument is not of the expected type, the frame has more than
                MAX_MEASUREMENTS detections, or a hyperparameter is out of range.
        """
        if not isinstance(measurements, Measurements):
            raise InvalidInputError(
                f"measurements must be an azgym.Measurements, got {type(measurements).__name__}"
            )
        if not isinstance(beacons, BeaconMap):
            raise InvalidInputError(
                f"beacons must be an azgym.BeaconMap, got {type(beacons).__name__}"
            )
        if measurements.ids.size > MAX_MEASUREMENTS:
            raise InvalidInputError(
                f"measurements has {len(measurements)} detections, more than the "
                f"{MAX_MEASUREMENTS} a localizer accepts in one frame"
            )
        self._validate_once()
        return self._localize_frame(measurements, beacons)

    def _localize_frame(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        """Reduce the frame to its usable measurements, refuse fewer than three beacons, solve.

        A localizer whose compiled kernel can do the id lookup itself may override this to save
        the round trip through :class:`Problem` (ransac does); it must answer exactly as this
        method would, and may call it for the cases it does not handle.
        """
        problem = Problem.from_frame(measurements, beacons)
        if problem.n_distinct < MIN_MEASUREMENTS:
            unknown = problem.n_measurements - problem.size
            detail = f"; {unknown} had ids not in the map" if unknown else ""
            return Estimate.failure(
                f"fewer than {MIN_MEASUREMENTS} distinct beacons measured "
                f"({problem.size} usable of {problem.n_measurements} measurements{detail})",
                problem.n_measurements,
            )
        return self._localize(problem)

    @abstractmethod
    def _localize(self, problem: Problem) -> Estimate:
        """Compute the estimate from validated, usable measurements (K >= 3)."""
