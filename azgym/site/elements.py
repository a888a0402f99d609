"""The physical layout of a site: shelf racks, walls, the camera on the forklift, sensor faults.

Racks and walls are vertical obstacles standing on the floor. For the camera they are occluders
(and, if reflective, mirrors): :func:`occluder_table` turns them into one array of segments with
a height and a reflectivity, the form the compiled sensor kernels take.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from azgym.core import FloatArray, wrap_angle
from azgym.profile import FORKLIFT

__all__ = ["ALL_ROUND", "CAMERA_RATES_HZ", "CAMERA_RATE_HZ", "ROUTE_CLEARANCE", "SEG_HEIGHT",
           "SEG_REFLECTIVITY", "SEG_X1", "SEG_X2", "SEG_Y1", "SEG_Y2", "Bump", "Camera", "Faults",
           "Light", "Rack", "Route", "Vehicle", "Wall", "leg_hits_rack", "leg_wall_distance",
           "occluder_table"]


@dataclass(frozen=True)
class Rack:
    """A shelf rack: a rectangular footprint of some height.

    Attributes:
        center: Centre of the footprint (x, y) [m].
        size: (length, depth) [m], length along the rack's axis.
        angle: Direction of the rack's axis, counter-clockwise from east [rad].
        height: Height of its top [m].
        reflectivity: Share of light its faces mirror (metal faces), 0 for none.
    """

    center: tuple[float, float]
    size: tuple[float, float]
    angle: float
    height: float
    reflectivity: float = 0.0

    def corners(self) -> FloatArray:
        """The footprint's four corners, counter-clockwise, shape (4, 2) [m]."""
        c, s = math.cos(self.angle), math.sin(self.angle)
        half_l, half_d = 0.5 * self.size[0], 0.5 * self.size[1]
        local = np.array([[-half_l, -half_d], [half_l, -half_d], [half_l, half_d],
                          [-half_l, half_d]])
        return local @ np.array([[c, s], [-s, c]]) + np.asarray(self.center)

    def contains(self, x: Any, y: Any, margin: float = 1e-6) -> Any:
        """Whether (x, y) lies inside the footprint, more than ``margin`` [m] from its faces.

        A bool for one point; for arrays of points, an array of them (element by element).
        """
        c, s = math.cos(self.angle), math.sin(self.angle)
        dx, dy = x - self.center[0], y - self.center[1]
        along, across = c * dx + s * dy, -s * dx + c * dy
        return ((abs(along) < 0.5 * self.size[0] - margin)
                & (abs(across) < 0.5 * self.size[1] - margin))


@dataclass(frozen=True)
class Wall:
    """A straight wall (or glass pane) from ``start`` to ``end``.

    Attributes:
        start: One end (x, y) [m].
        end: The other end (x, y) [m].
        height: Height of its top [m].
        reflectivity: Share of light it mirrors (glass, polished metal), 0 for none.
    """

    start: tuple[float, float]
    end: tuple[float, float]
    height: float
    reflectivity: float = 0.0


CAMERA_RATES_HZ = (0.1, 1000.0)
"""The camera frame rates azgym accepts [Hz]: slower would leave a route without frames (and
take forever to reach the next one), faster is no camera."""
CAMERA_RATE_HZ = 10.0
"""A camera's frame rate unless its scenario or sensor says otherwise [Hz]."""
ALL_ROUND = 2.0 * math.pi
"""The field of view of a camera that sees all round (the upward fisheye) [rad]."""


@dataclass(frozen=True)
class Camera:
    """The camera as the sensor geometry needs it: an upward fisheye, or a forward camera.

    Attributes:
        height: Height of the lens above the floor [m].
        min_elevation: Lowest elevation the lens sees, from the horizon [rad].
        max_range: Distance at which a beacon's flux falls to the detection threshold [m, 3-D];
            a ghost's reflected flux must reach the same threshold.
        field_of_view: The full horizontal view, centred on the heading [rad]; a detection is
            kept only if its measured azimuth is within half of it (the image's edge).
            ``ALL_ROUND`` (2π): the upward fisheye, which sees all round.
        rate_hz: Frames per second of the geometry sensor [Hz].
    """

    height: float = 2.0
    min_elevation: float = 0.0
    max_range: float = 60.0
    field_of_view: float = ALL_ROUND
    rate_hz: float = CAMERA_RATE_HZ

    @property
    def all_round(self) -> bool:
        """Whether the camera sees all round (no field-of-view limit)."""
        return self.field_of_view >= ALL_ROUND


@dataclass(frozen=True)
class Vehicle:
    """What drives the scenario's routes, and where its camera sits.

    Attributes:
        kind: One of :data:`azgym.profile.VEHICLE_KINDS`: ``"forklift"`` (the default, driven by
            :mod:`azgym.world.forklift`) or ``"differential-drive"`` (:mod:`azgym.world.robot`).
        camera_ahead: A differential drive's camera offset ahead of its turning axis, along the
            heading [m] (negative: behind it); None for a forklift, whose camera sits where
            :class:`~azgym.world.forklift.ForkliftSpec` puts it.
    """

    kind: str = FORKLIFT
    camera_ahead: float | None = None

    @property
    def robot_camera_ahead(self) -> float:
        """A differential drive's camera offset [m]: ``camera_ahead``, or 0 (on the axis)."""
        return 0.0 if self.camera_ahead is None else self.camera_ahead


@dataclass(frozen=True)
class Faults:
    """Decoding faults that geometry does not produce.

    Attributes:
        misdecode_rate: Probability that a detection's id is decoded as another map beacon's.
    """

    misdecode_rate: float = 0.0


@dataclass(frozen=True, eq=False)
class Route:
    """A named polyline for the forklift to follow.

    Attributes:
        name: Identifier within the scenario.
        waypoints: Points to pass, in order, shape (K, 2) [m].
        reverse: For each of the K − 1 legs, whether it is driven backwards.
        speed: Cruise speed [m/s].
    """

    name: str
    waypoints: FloatArray
    reverse: tuple[bool, ...]
    speed: float

    def start_pose(self) -> tuple[float, float, float]:
        """Where the forklift starts: on the first waypoint, facing along the first leg."""
        (x0, y0), (x1, y1) = self.waypoints[0], self.waypoints[1]
        heading = math.atan2(y1 - y0, x1 - x0)
        if self.reverse[0]:
            heading = float(wrap_angle(heading + math.pi))
        return float(x0), float(y0), heading


@dataclass(frozen=True)
class Bump:
    """A bumpy stretch of floor: a rectangle where the camera sways.

    Attributes:
        center: Centre (x, y) [m].
        size: (x extent, y extent) [m].
        tilt: Standard deviation of the camera's pitch and roll there [rad].
    """

    center: tuple[float, float]
    size: tuple[float, float]
    tilt: float

    def contains(self, x: float, y: float) -> bool:
        """Whether (x, y) is on the stretch."""
        return (abs(x - self.center[0]) <= 0.5 * self.size[0]
                and abs(y - self.center[1]) <= 0.5 * self.size[1])


@dataclass(frozen=True)
class Light:
    """A light that is not a beacon: a ceiling lamp, a sunny window. The image path draws it.

    It never blinks a code, so it is a blob no beacon explains (a distractor); racks hide it and
    mirrors reflect it like any light.

    Attributes:
        name: What it is, for listings.
        xyz: Its centre (x, y, z) [m].
        width: Horizontal extent [m].
        tall: Vertical extent [m] (a window is tall, a lamp is not).
        power: Its flux as a multiple of a beacon's at the same distance.
    """

    name: str
    xyz: tuple[float, float, float]
    width: float
    tall: float
    power: float


ROUTE_CLEARANCE = 0.7
"""A route must keep this far from every rack and wall [m]: half a forklift's width and a
margin."""


def leg_hits_rack(start: Sequence[float], end: Sequence[float], rack: Rack,
                  clearance: float) -> bool:
    """Whether the straight leg start→end comes within ``clearance`` of the rack's footprint.

    Liang-Barsky clipping of the leg, in the rack's own frame, against its footprint grown by the
    clearance on every side (a slightly conservative test at the corners).
    """
    c, s = math.cos(rack.angle), math.sin(rack.angle)
    local = [((p[0] - rack.center[0]) * c + (p[1] - rack.center[1]) * s,
              -(p[0] - rack.center[0]) * s + (p[1] - rack.center[1]) * c) for p in (start, end)]
    (x0, y0), (x1, y1) = local
    dx, dy = x1 - x0, y1 - y0
    half_x = 0.5 * rack.size[0] + clearance
    half_y = 0.5 * rack.size[1] + clearance
    lo, hi = 0.0, 1.0
    for p, q in ((-dx, x0 + half_x), (dx, half_x - x0), (-dy, y0 + half_y), (dy, half_y - y0)):
        if p == 0:
            if q < 0:
                return False
            continue
        t = q / p
        if p < 0:
            lo = max(lo, t)
        else:
            hi = min(hi, t)
        if lo > hi:
            return False
    return True


def leg_wall_distance(start: Sequence[float], end: Sequence[float], wall: Wall) -> float:
    """The shortest distance between the straight leg start→end and the wall's line [m].

    Zero when the leg crosses the wall; otherwise the nearest of the four end points to the
    other segment (two segments that do not cross are nearest at an end of one of them).
    """
    a, b = (float(start[0]), float(start[1])), (float(end[0]), float(end[1]))
    c, d = wall.start, wall.end
    if _crosses(a, b, c, d):
        return 0.0
    return min(_point_segment_distance(a, c, d), _point_segment_distance(b, c, d),
               _point_segment_distance(c, a, b), _point_segment_distance(d, a, b))


def _crosses(a: tuple[float, float], b: tuple[float, float], c: tuple[float, float],
             d: tuple[float, float]) -> bool:
    """Whether segments ab and cd cross or touch (their ends on opposite sides of each other)."""
    def side(p: tuple[float, float], q: tuple[float, float], r: tuple[float, float]) -> float:
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    return (side(a, b, c) * side(a, b, d) <= 0 and side(c, d, a) * side(c, d, b) <= 0
            and min(a[0], b[0]) <= max(c[0], d[0]) and min(c[0], d[0]) <= max(a[0], b[0])
            and min(a[1], b[1]) <= max(c[1], d[1]) and min(c[1], d[1]) <= max(a[1], b[1]))


def _point_segment_distance(p: tuple[float, float], a: tuple[float, float],
                            b: tuple[float, float]) -> float:
    """The distance from point p to the segment ab [m]."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    squared = dx * dx + dy * dy
    t = 0.0 if squared == 0 else max(0.0, min(1.0, ((p[0] - a[0]) * dx + (p[1] - a[1]) * dy)
                                              / squared))
    return math.hypot(p[0] - a[0] - t * dx, p[1] - a[1] - t * dy)


SEG_X1, SEG_Y1, SEG_X2, SEG_Y2, SEG_HEIGHT, SEG_REFLECTIVITY = range(6)
"""Columns of an occluder table: one end (x, y) [m], the other end, top height [m], reflectivity."""
SEG_COLUMNS = 6
"""Columns of an occluder table."""


def occluder_table(racks: tuple[Rack, ...], walls: tuple[Wall, ...]) -> FloatArray:
    """Every rack face and wall as a row of ``SEG_*`` columns, shape (S, SEG_COLUMNS)."""
    rows = []
    for rack in racks:
        corners = rack.corners()
        for k in range(4):
            a, b = corners[k], corners[(k + 1) % 4]
            rows.append((a[0], a[1], b[0], b[1], rack.height, rack.reflectivity))
    for wall in walls:
        rows.append((*wall.start, *wall.end, wall.height, wall.reflectivity))
    return np.array(rows, dtype=np.float64).reshape(-1, SEG_COLUMNS)
