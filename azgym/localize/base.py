"""The localizer interface: one public method that validates, one private method that computes.

A localizer turns one frame's :class:`~azgym.core.Measurements` and the
:class:`~azgym.core.BeaconMap` into an :class:`~azgym.core.Estimate`. Hyperparameters are
keyword-only ``__init__`` arguments stored unchanged (the scikit-learn way), so ``get_params()``
shows them and ``repr`` reproduces them; they are validated when ``localize`` is called, not in
``__init__``.
"""

from __future__ import annotations

import functools
import inspect
import math
from abc import ABC, abstractmethod
from typing import Any, ClassVar

import numba
import numpy as np

from azgym.core import BeaconMap, BoolArray, Estimate, FloatArray, IntArray, Measurements
from azgym.errors import InvalidInputError

MIN_MEASUREMENTS = 3
"""A 2-D position and a heading are three unknowns: three azimuths are the minimum."""


@numba.njit(error_model="numpy", cache=True)
def _gather(ids, azimuth, sorted_ids, sorted_order, xyz, width):
    """Look up each measured id in the map (binary search); gather the usable measurements.

    Returns a (6, K) float array (azimuth, cos, sin, beacon x, beacon y, width), a (2, K) int
    array (position in the frame, beacon row) and the number of distinct beacons: two arrays
    rather than eight, because handing each array back to Python costs about a microsecond.
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
    floats = np.empty((6, usable))
    ints = np.empty((2, usable), dtype=np.int64)
    seen = np.zeros(n, dtype=np.bool_)
    distinct = 0
    u = 0
    for t in range(m):
        b = index[t]
        if b < 0:
            continue
        ints[0, u] = t
        ints[1, u] = b
        floats[0, u] = azimuth[t]
        floats[1, u] = math.cos(azimuth[t])
        floats[2, u] = math.sin(azimuth[t])
        floats[3, u] = xyz[b, 0]
        floats[4, u] = xyz[b, 1]
        floats[5, u] = width[b]
        if not seen[b]:
            seen[b] = True
            distinct += 1
        u += 1
    return floats, ints, distinct


class Problem:
    """One frame reduced to the measurements a localizer can use: those with ids in the map.

    Attributes:
        azimuth: Usable azimuths [rad], shape (K,).
        cos_az: cos of ``azimuth``, shape (K,).
        sin_az: sin of ``azimuth``, shape (K,).
        bx: East coordinate of the beacon each was decoded as [m], shape (K,).
        by: North coordinate [m], shape (K,).
        width: Width W of that beacon [m], shape (K,).
        beacon_index: Row of that beacon in the map, shape (K,); repeated for a ghost.
        source: Position of each usable measurement in the original Measurements, shape (K,).
        n_measurements: M, the number of measurements in the frame, usable or not.
        n_distinct: How many different beacons the usable measurements refer to.
    """

    __slots__ = ("azimuth", "cos_az", "sin_az", "bx", "by", "width", "beacon_index", "source",
                 "n_measurements", "n_distinct")

    def __init__(self, floats: FloatArray, ints: IntArray, n_distinct: int,
                 n_measurements: int) -> None:
        self.azimuth, self.cos_az, self.sin_az, self.bx, self.by, self.width = floats
        self.source, self.beacon_index = ints
        self.n_distinct = n_distinct
        self.n_measurements = n_measurements

    @classmethod
    def from_frame(cls, measurements: Measurements, beacons: BeaconMap) -> Problem:
        """Look up every measurement's beacon; drop (and remember) ids the map does not know."""
        lookup = beacons.lookup_tables()
        return cls(*_gather(measurements.ids, measurements.azimuth, *lookup),
                   n_measurements=len(measurements))

    @property
    def size(self) -> int:
        """K, the number of usable measurements."""
        return int(self.azimuth.size)

    def expand(self, mask: BoolArray) -> BoolArray:
        """Turn a mask over the K usable measurements into one over all M measurements."""
        full = np.zeros(self.n_measurements, dtype=bool)
        full[self.source] = mask
        return full


class Localizer(ABC):
    """Base class of every localizer: ``localize`` validates, ``_localize`` computes.

    Subclasses set ``name``, take keyword-only hyperparameters in ``__init__`` (stored as given),
    may override ``_check_params`` and implement ``_localize``.
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
            InvalidInputError: An argument is not of the expected type, or a hyperparameter is
                out of range.
        """
        if not isinstance(measurements, Measurements):
            raise InvalidInputError(
                f"measurements must be an azgym.Measurements, got {type(measurements).__name__}"
            )
        if not isinstance(beacons, BeaconMap):
            raise InvalidInputError(
                f"beacons must be an azgym.BeaconMap, got {type(beacons).__name__}"
            )
        self._validate_once()
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

    def _check_params(self) -> None:  # noqa: B027 - optional hook, no parameters by default
        """Raise :class:`InvalidInputError` naming any hyperparameter that is out of range."""

    def _validate_once(self) -> None:
        """Run ``_check_params`` unless these exact hyperparameter values passed it before."""
        names = _param_names(type(self))
        values = tuple(getattr(self, name) for name in names)
        if getattr(self, "_validated_params", None) != values:
            self._check_params()
            self._validated_params = values

    def get_params(self) -> dict[str, Any]:
        """The hyperparameters, as given to ``__init__``."""
        return {name: getattr(self, name) for name in _param_names(type(self))}

    def __repr__(self) -> str:
        params = ", ".join(f"{key}={value!r}" for key, value in self.get_params().items())
        return f"{type(self).__name__}({params})"


@functools.cache
def _param_names(cls: type) -> tuple[str, ...]:
    """Names of the keyword-only ``__init__`` arguments of a localizer class."""
    signature = inspect.signature(cls.__init__)
    return tuple(
        name for name, parameter in signature.parameters.items()
        if parameter.kind is parameter.KEYWORD_ONLY
    )


def check_range(
    owner: str,
    name: str,
    value: Any,
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    high_open: bool = False,
    integer: bool = False,
) -> None:
    """Raise :class:`InvalidInputError` unless ``value`` is a finite number in the given range."""
    kind = "an integer" if integer else "a number"
    ok_type = isinstance(value, (int, np.integer)) if integer else isinstance(
        value, (int, float, np.integer, np.floating)
    )
    if isinstance(value, bool) or not ok_type or not math.isfinite(float(value)):
        raise InvalidInputError(f"{owner}.{name} must be {kind}, got {value!r}")
    too_low = low is not None and (value <= low if low_open else value < low)
    too_high = high is not None and (value >= high if high_open else value > high)
    if too_low or too_high:
        left = "(" if low_open else "["
        right = ")" if high_open else "]"
        lo = "-inf" if low is None else low
        hi = "inf" if high is None else high
        raise InvalidInputError(f"{owner}.{name} must be in {left}{lo}, {hi}{right}, got {value!r}")
