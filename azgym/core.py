"""The types every part of azgym speaks: beacon map, a frame's measurements, pose estimate.

Conventions (docs/architecture.md): SI units and radians; world frame x east, y north, z up; the
heading φ is the direction of the camera's x-axis in the world, counter-clockwise; the azimuth of
beacon i in the camera frame is α_i = atan2(y_i − y, x_i − x) − φ (Rátosi & Simon, eq. 19-22).
Every angle difference goes through :func:`wrap_angle` (or its scalar and compiled twins).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from azgym.errors import InvalidInputError

__all__ = ["BeaconMap", "BoolArray", "Estimate", "FloatArray", "IntArray", "Measurements", "Pose",
           "estimated_pose", "interpolate_pose", "pose_error", "wrap_angle", "wrap_scalar"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]
BoolArray = NDArray[np.bool_]
Pose = tuple[float, float, float]
"""A camera pose (x, y, heading) [m, m, rad]."""


TWO_PI = 2.0 * math.pi


AZIMUTH_SLACK = 1e-6
"""How far past ±π a measured azimuth may lie [rad]: a float32 round trip of ±π (an agent's
observation) lands about 1e-7 outside."""
LARGE_ANGLE = 1e12
"""Beyond this magnitude [rad] an angle is first reduced modulo 2π (exact), so that the count
of whole turns stays a small integer in compiled code too."""


def wrap_scalar(angle: float) -> float:
    """Wrap one angle to (−π, π] [rad]: the formula every wrap in azgym uses.

    An angle already in range comes back bit for bit; any other becomes a − 2π ⌈(a − π) / 2π⌉,
    which is exact for |a| < 3π (beyond, a rounded result is moved back into range). Keeping
    in-range angles untouched matters: the localizers turn a last-bit change of an azimuth into
    a different inlier set now and then. NaN and ±inf come back as they are: they have no
    direction, and the caller decides what that means. Compiled kernels call its twin
    :data:`azgym.jit.wrap_compiled` (this function, compiled); arrays go through
    :func:`wrap_angle`, which computes the same element by element.
    """
    if -math.pi < angle <= math.pi or not math.isfinite(angle):
        return angle
    if abs(angle) > LARGE_ANGLE:
        angle = angle % TWO_PI
    wrapped = angle - TWO_PI * math.ceil((angle - math.pi) / TWO_PI)
    if wrapped <= -math.pi:
        return wrapped + TWO_PI
    return wrapped - TWO_PI if wrapped > math.pi else wrapped


def interpolate_pose(a: tuple[float, float, float], b: tuple[float, float, float],
                     fraction: float) -> tuple[float, float, float]:
    """The pose ``fraction`` of the way from a to b, the heading along the shorter arc.

    ``fraction`` 1 gives b itself, bit for bit.
    """
    if fraction >= 1.0:
        return b
    turn = wrap_scalar(b[2] - a[2])
    return (a[0] + fraction * (b[0] - a[0]), a[1] + fraction * (b[1] - a[1]),
            wrap_scalar(a[2] + fraction * turn))


def wrap_angle(angle: ArrayLike) -> Any:
    """Wrap angles to the interval (−π, π] (the formula of :func:`wrap_scalar`).

    Args:
        angle: Angle or array of angles in radians.

    Returns:
        The wrapped angle(s), a float for a scalar input; NaN and ±inf as they are.
    """
    if isinstance(angle, (float, int)):  # without numpy's overhead
        return wrap_scalar(angle)
    angle = np.asarray(angle, dtype=np.float64)
    with np.errstate(invalid="ignore"):
        reduced = np.where(np.abs(angle) > LARGE_ANGLE, np.mod(angle, TWO_PI), angle)
        wrapped = reduced - TWO_PI * np.ceil((reduced - np.pi) / TWO_PI)
    wrapped = np.where(wrapped <= -np.pi, wrapped + TWO_PI,
                       np.where(wrapped > np.pi, wrapped - TWO_PI, wrapped))
    keep = ((angle > -np.pi) & (angle <= np.pi)) | ~np.isfinite(angle)
    wrapped = np.where(keep, angle, wrapped)
    return float(wrapped) if wrapped.ndim == 0 else wrapped


def pose_error(estimate: Pose, truth: Pose) -> tuple[float, float]:
    """How far an estimated pose is from the true one: the only definition azgym uses.

    Args:
        estimate: The estimated (x, y, heading) [m, m, rad].
        truth: The true (x, y, heading).

    Returns:
        The 2-D position error [m] and the absolute heading error, wrapped to [0, π] [rad].
    """
    return (math.hypot(estimate[0] - truth[0], estimate[1] - truth[1]),
            abs(wrap_scalar(float(estimate[2]) - float(truth[2]))))


def estimated_pose(estimate: Any) -> Pose | None:
    """The pose an estimate gives, or None when it gives none: the one rule for "has a pose".

    A pose needs ``ok`` to be True and x, y and heading to be finite: an ``ok=True`` with a NaN
    part is no pose (a plug-in's bug must not read as an answer).

    Raises:
        InvalidInputError: ``ok`` is not a bool (e.g. the string "False", which is truthy).
    """
    ok = estimate.ok
    if not isinstance(ok, (bool, np.bool_)):
        raise InvalidInputError(f"Estimate.ok must be True or False, got {ok!r}")
    if not ok:
        return None
    pose = (float(estimate.x), float(estimate.y), float(estimate.heading))
    return pose if all(math.isfinite(value) for value in pose) else None


def _frozen(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)
    return array


def _as_ids(owner: str, name: str, values: ArrayLike) -> IntArray:
    array = np.asarray(values)
    if array.ndim != 1:
        raise InvalidInputError(f"{owner}.{name} must be 1-D, got shape {array.shape}")
    if array.size and not np.issubdtype(array.dtype, np.integer):
        if not np.issubdtype(array.dtype, np.floating):
            raise InvalidInputError(f"{owner}.{name} must hold integers, got dtype {array.dtype}")
        whole = np.isfinite(array) & (array == np.round(array)) & (np.abs(array) < 2.0**62)
        if not whole.all():
            bad = array[~whole][0]
            raise InvalidInputError(f"{owner}.{name} must hold integers, got {bad}")
    return _frozen(array.astype(np.int64, copy=True))


def _as_finite(owner: str, name: str, values: ArrayLike, shape: tuple[int, ...]) -> FloatArray:
    try:
        array = np.array(values, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise InvalidInputError(f"{owner}.{name} must be numeric: {exc}") from None
    if array.shape != shape:
        raise InvalidInputError(f"{owner}.{name} must have shape {shape}, got {array.shape}")
    bad = ~np.isfinite(array)
    if bad.any():
        where = tuple(int(i) for i in np.argwhere(bad)[0])
        index = where[0] if len(where) == 1 else where
        raise InvalidInputError(
            f"{owner}.{name} must be finite, got {array[where]} at index {index}"
        )
    return _frozen(array)


@dataclass(frozen=True, eq=False)
class BeaconMap:
    """The known beacons: ids, 3-D positions and horizontal sizes. Immutable.

    Attributes:
        ids: Unique integer beacon ids >= 0, shape (N,). Negative ids are refused: −1 marks the
            empty slots of an environment's observation, and a map id must never look like one.
        xyz: Beacon positions in the world frame [m], shape (N, 3).
        width: Horizontal size W of each beacon [m], shape (N,), used by the coverage error
            of eq. 2. A scalar is broadcast to every beacon.
    """

    ids: IntArray
    xyz: FloatArray
    width: FloatArray
    _sorted_ids: IntArray = field(init=False, repr=False)
    _sorted_order: IntArray = field(init=False, repr=False)

    def __init__(self, ids: ArrayLike, xyz: ArrayLike, width: ArrayLike = 0.03) -> None:
        id_array = _as_ids("BeaconMap", "ids", ids)
        negative = np.flatnonzero(id_array < 0)
        if negative.size:  # also an unsigned id past int64's range, wrapped negative
            k = int(negative[0])
            raise InvalidInputError(
                f"BeaconMap.ids must be >= 0 (-1 marks an empty slot in observations), got "
                f"{np.asarray(ids).reshape(-1)[k]} at index {k}"
            )
        n = id_array.size
        unique, counts = np.unique(id_array, return_counts=True)
        if (counts > 1).any():
            raise InvalidInputError(
                f"BeaconMap.ids must be unique; duplicated: {unique[counts > 1].tolist()}"
            )
        xyz_array = _as_finite("BeaconMap", "xyz", xyz, (n, 3))
        try:
            width_values = np.asarray(width, dtype=np.float64)
        except (TypeError, ValueError) as exc:
            raise InvalidInputError(f"BeaconMap.width must be numeric: {exc}") from None
        if width_values.ndim == 0:
            width_values = np.full(n, float(width_values))
        width_array = _as_finite("BeaconMap", "width", width_values, (n,))
        if (width_array < 0).any():
            raise InvalidInputError(
                f"BeaconMap.width must be >= 0 m, got {width_array[width_array < 0][0]}"
            )
        order = np.argsort(id_array, kind="stable")
        object.__setattr__(self, "ids", id_array)
        object.__setattr__(self, "xyz", xyz_array)
        object.__setattr__(self, "width", width_array)
        object.__setattr__(self, "_sorted_ids", _frozen(id_array[order]))
        object.__setattr__(self, "_sorted_order", _frozen(order.astype(np.int64)))

    def __len__(self) -> int:
        return int(self.ids.size)

    def lookup_tables(self) -> tuple[IntArray, IntArray, FloatArray, FloatArray]:
        """(sorted ids, their rows, xyz, width): what the compiled id lookup needs."""
        return self._sorted_ids, self._sorted_order, self.xyz, self.width

    @property
    def xy(self) -> FloatArray:
        """Horizontal positions [m], shape (N, 2)."""
        return self.xyz[:, :2]

    def index_of(self, ids: ArrayLike) -> IntArray:
        """Map beacon ids to row indices of this map; ids not in the map give −1.

        Args:
            ids: Beacon ids, any shape.
        """
        query = np.asarray(ids, dtype=np.int64)
        pos = np.searchsorted(self._sorted_ids, query)
        pos_clipped = np.minimum(pos, max(len(self) - 1, 0))
        if len(self) == 0:
            return np.full(query.shape, -1, dtype=np.int64)
        found = self._sorted_ids[pos_clipped] == query
        return np.where(found, self._sorted_order[pos_clipped], -1)

    def bounds(self) -> tuple[float, float, float, float]:
        """Bounding box of the beacons' horizontal positions: (x_min, y_min, x_max, y_max) [m]."""
        lo = self.xy.min(axis=0)
        hi = self.xy.max(axis=0)
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])


@dataclass(frozen=True, eq=False)
class Measurements:
    """One camera frame's beacon detections. Ground truth never travels inside it.

    M may differ from the number of beacons: beacons may be missing, the same id may appear twice
    (a mirror ghost beside the real beacon) and an id may be absent from the map (misdecoded).
    A negative id is accepted and is in no map (map ids are >= 0), so it reads like any unknown
    id: a detector may give −1 to a detection it could not decode, and an environment's padded
    slots (id −1) are never taken for a beacon.

    Attributes:
        ids: Decoded beacon id of each detection, shape (M,); negative for none.
        azimuth: Azimuth of each detection in the camera frame [rad], shape (M,), finite.
        quality: Optional per-detection quality (e.g. blob size), shape (M,) or (M, Q).
    """

    ids: IntArray
    azimuth: FloatArray
    quality: FloatArray | None = None

    def __init__(
        self, ids: ArrayLike, azimuth: ArrayLike, quality: ArrayLike | None = None
    ) -> None:
        id_array = _as_ids("Measurements", "ids", ids)
        azimuth_array = _as_finite("Measurements", "azimuth", azimuth, id_array.shape)
        outside = np.abs(azimuth_array) > math.pi + AZIMUTH_SLACK
        if outside.any():
            k = int(np.flatnonzero(outside)[0])
            raise InvalidInputError(
                f"Measurements.azimuth must be radians in [-π, π], got {azimuth_array[k]} at "
                f"index {k} (degrees? convert with np.radians; unwrapped? use azgym.wrap_angle)")
        quality_array = None
        if quality is not None:
            shape = np.shape(quality)
            if len(shape) not in (1, 2) or shape[0] != id_array.size:
                raise InvalidInputError(
                    f"Measurements.quality must have shape ({id_array.size},) or "
                    f"({id_array.size}, Q), got {shape}"
                )
            quality_array = _as_finite("Measurements", "quality", quality, shape)
        object.__setattr__(self, "ids", id_array)
        object.__setattr__(self, "azimuth", azimuth_array)
        object.__setattr__(self, "quality", quality_array)

    def __len__(self) -> int:
        return int(self.ids.size)

    @classmethod
    def _from_frozen(
        cls, ids: IntArray, azimuth: FloatArray, quality: FloatArray | None = None
    ) -> Measurements:
        """Wrap read-only arrays azgym's own sensors produced, skipping the checks (a hot path).

        Only for read-only int64 ids and finite float64 azimuths of equal length, which the
        compiled sensor guarantees; they are kept, not copied.
        """
        measurements = object.__new__(cls)
        object.__setattr__(measurements, "ids", ids)
        object.__setattr__(measurements, "azimuth", azimuth)
        object.__setattr__(measurements, "quality", quality)
        return measurements


@dataclass(frozen=True, eq=False, slots=True)
class Estimate:
    """A localizer's answer for one frame.

    A failed estimate has ``ok=False``, a ``reason`` and NaN pose: a missing estimate must never be
    scored as a zero error.

    Attributes:
        x: Camera position, east [m].
        y: Camera position, north [m].
        heading: Camera heading φ [rad], wrapped to (−π, π].
        inliers: Which measurements the estimate used, shape (M,) bool.
        ok: Whether a pose was found.
        reason: Why not, when ``ok`` is False; empty otherwise.
        covariance: Optional 3×3 covariance of (x, y, heading).
        diagnostics: Localizer-specific extras (iterations, residuals, ...).
    """

    x: float
    y: float
    heading: float
    inliers: BoolArray
    ok: bool = True
    reason: str = ""
    covariance: FloatArray | None = None
    diagnostics: Mapping[str, Any] = field(default_factory=dict)

    @classmethod
    def failure(
        cls, reason: str, n_measurements: int, diagnostics: Mapping[str, Any] | None = None
    ) -> Estimate:
        """An estimate that says no pose could be found, and why."""
        return cls._filled(math.nan, math.nan, math.nan, np.zeros(n_measurements, dtype=bool),
                           False, reason, None, dict(diagnostics or {}))

    @classmethod
    def _filled(cls, x: float, y: float, heading: float, inliers: BoolArray, ok: bool,
                reason: str, covariance: FloatArray | None, diagnostics: Mapping[str, Any]
                ) -> Estimate:
        """``Estimate(...)`` with every field given, built faster (every frame's answer).

        The slots are set through their descriptors, which costs about a microsecond less than
        the frozen dataclass's keyword ``__init__``, which has nothing else to do.
        """
        estimate = object.__new__(cls)
        _SET_X(estimate, x)
        _SET_Y(estimate, y)
        _SET_HEADING(estimate, heading)
        _SET_INLIERS(estimate, inliers)
        _SET_OK(estimate, ok)
        _SET_REASON(estimate, reason)
        _SET_COVARIANCE(estimate, covariance)
        _SET_DIAGNOSTICS(estimate, diagnostics)
        return estimate

    @property
    def pose(self) -> Pose:
        """(x, y, heading) [m, m, rad]; NaN for a failed estimate."""
        return self.x, self.y, self.heading

    @property
    def position(self) -> FloatArray:
        """The position as an array [x, y] [m]."""
        return np.array([self.x, self.y])

    @property
    def n_inliers(self) -> int:
        """Number of measurements the estimate used."""
        return int(np.count_nonzero(self.inliers))


# The slot descriptors' setters, for ``Estimate._filled`` (one per field, in the fields' order).
(_SET_X, _SET_Y, _SET_HEADING, _SET_INLIERS, _SET_OK, _SET_REASON, _SET_COVARIANCE,
 _SET_DIAGNOSTICS) = (vars(Estimate)[name].__set__ for name in Estimate.__slots__)
