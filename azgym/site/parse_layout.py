"""The floor's layout tables: beacons, racks, walls, routes, bumps and lights.

``[[beacons]]``, ``[[racks]]``, ``[[walls]]``, ``[[routes]]``, ``[[bumps]]`` and ``[[lights]]``
place things in the room, so besides their own fields they are checked against
each other: a beacon must stand in the room (on its walls at most) and, like a lamp, not inside
a rack; a route's legs must keep ``ROUTE_CLEARANCE`` off the racks and walls (the forklift drives
them among pymunk's solid racks and walls); route names must be unique. Those geometric rules are
kept here, next to the tables they relate; the sensor's tables (camera, fisheye, error model,
faults) are in :mod:`azgym.site.parse_sensor`, and field-level checks and their messages in
:mod:`azgym.site.reader`.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from azgym.core import BeaconMap, FloatArray, IntArray
from azgym.site.elements import (
    ROUTE_CLEARANCE,
    Bump,
    Light,
    Rack,
    Route,
    Wall,
    leg_hits_rack,
    leg_wall_distance,
)
from azgym.site.reader import MAX_INTEGER, Reader, shown

__all__ = ["MAX_LEG_PAIRS", "ON_WALL_TOLERANCE", "Obstacles", "check_beacons_outside_racks",
           "check_route_names_unique", "parse_beacons", "parse_bump", "parse_light", "parse_rack",
           "parse_route", "parse_unmapped", "parse_wall"]

_DEFAULT_KEYS = {"width", "z"}
_BEACON_KEYS = {"id", "xy", "xyz", "width", "z", "moved_to"}
_UNMAPPED_KEYS = {"id", "xy", "xyz", "width", "z"}
_RACK_KEYS = {"center", "size", "angle_deg", "height", "reflectivity"}
_WALL_KEYS = {"start", "end", "height", "reflectivity"}
_ROUTE_KEYS = {"name", "waypoints", "reverse", "speed"}
_BUMP_KEYS = {"center", "size", "tilt_deg"}
_LIGHT_KEYS = {"name", "xyz", "width", "tall", "power"}

ON_WALL_TOLERANCE = 0.05
"""How far outside the room's bounds a beacon may stand [m]: beacons hang on the walls, and one
mounted on a wall's face has its centre a few centimetres off the wall's line."""
MAX_LEG_PAIRS = 500_000
"""The most (route leg, rack or wall) pairs a scenario may ask to check, all routes together:
tens of routes of tens of legs among hundreds of racks, and a bound on the time a crafted file
can take to load (about a second)."""
MAX_ROUTE_SPEED = 20.0
"""The fastest a route may be driven [m/s]: no warehouse vehicle is faster."""


# --------------------------------------------------------------------------- beacons

def parse_beacons(read: Reader, data: dict[str, Any],
                  bounds: tuple[float, float, float, float]) -> tuple[BeaconMap, FloatArray]:
    """The ``[[beacons]]`` as a map, and where each physically is (see ``moved_to``), (N, 3).

    Both positions of a beacon must be in the room: within ``ON_WALL_TOLERANCE`` of its bounds.
    """
    defaults = read.table(data.get("beacon_defaults", {}), "beacon_defaults", _DEFAULT_KEYS)
    default_width = read.number(defaults.get("width", 0.03), "beacon_defaults.width",
                                positive=True)
    default_z = read.number(defaults.get("z", 0.0), "beacon_defaults.z")
    entries = read.require(data, "beacons")
    if not isinstance(entries, list) or len(entries) < 3:
        raise read.fail("beacons", "must be an array of at least 3 [[beacons]] tables")
    read.count(entries, "beacons")
    ids: list[int] = []
    xyz, width, physical = [], [], []
    for k, entry in enumerate(entries):
        where = f"beacons[{k}]."
        read.table(entry, f"beacons[{k}]", _BEACON_KEYS)
        ids.append(_beacon_id(read, entry, where, ids))
        position = _beacon_position(read, entry, where, default_z)
        xyz.append(_in_room(read, position, f"{where}{'xyz' if 'xyz' in entry else 'xy'}",
                            ids[-1], bounds))
        physical.append(_in_room(read, _moved_to(read, entry, position, where),
                                 f"{where}moved_to", ids[-1], bounds))
        width.append(read.number(entry.get("width", default_width), f"{where}width",
                                 positive=True))
    return BeaconMap(np.array(ids), np.array(xyz), np.array(width)), np.array(physical)


def parse_unmapped(read: Reader, data: dict[str, Any], bounds: tuple[float, float, float, float],
                   beacons: BeaconMap) -> BeaconMap | None:
    """The ``[[unmapped]]`` markers: coded, seen like beacons, but with codes the map lacks.

    Each has an ``id`` no map beacon has (and no other marker), a position in the room
    (``xy`` and ``z``, or ``xyz``; ``z`` and ``width`` default to ``[beacon_defaults]``'s).
    None when the file has none.
    """
    entries = data.get("unmapped", [])
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise read.fail("unmapped", "must be an array of [[unmapped]] tables")
    if not entries:
        return None
    read.count(entries, "unmapped")
    defaults = data.get("beacon_defaults", {})
    default_width, default_z = defaults.get("width", 0.03), defaults.get("z", 0.0)
    mapped = {int(i): k for k, i in enumerate(beacons.ids)}
    ids: list[int] = []
    xyz, width = [], []
    for k, entry in enumerate(entries):
        where = f"unmapped[{k}]."
        read.table(entry, f"unmapped[{k}]", _UNMAPPED_KEYS)
        marker = _beacon_id(read, entry, where, ids)
        if marker in mapped:
            raise read.fail(f"{where}id", f"{marker} is a map beacon's id (beacons"
                            f"[{mapped[marker]}]); an unmapped marker's code is not in the map")
        ids.append(marker)
        position = _beacon_position(read, entry, where, default_z)
        xyz.append(_in_room(read, position, f"{where}{'xyz' if 'xyz' in entry else 'xy'}",
                            marker, bounds))
        width.append(read.number(entry.get("width", default_width), f"{where}width",
                                 positive=True))
    return BeaconMap(np.array(ids), np.array(xyz), np.array(width))


def _beacon_id(read: Reader, entry: dict[str, Any], where: str, earlier: list[int]) -> int:
    """A beacon's ``id``: an integer >= 0 that none of the ``earlier`` beacons has.

    Negative ids are refused: −1 marks the empty slots of an environment's observation.
    """
    value = read.require(entry, "id", where)
    if isinstance(value, int) and not isinstance(value, bool) and value < 0:
        raise read.fail(f"{where}id", f"must be >= 0 (-1 marks an empty slot in observations), "
                        f"got {shown(value)}")
    beacon_id = read.integer(value, f"{where}id", minimum=0, maximum=MAX_INTEGER)
    if beacon_id in earlier:
        raise read.fail(f"{where}id",
                        f"duplicate id {beacon_id} (also beacons[{earlier.index(beacon_id)}])")
    return beacon_id


def _beacon_position(read: Reader, entry: dict[str, Any], where: str,
                     default_z: float) -> list[float]:
    """A beacon's map position: ``xyz`` = [x, y, z], or ``xy`` = [x, y] and ``z`` (or default)."""
    if ("xy" in entry) == ("xyz" in entry):
        raise read.fail(f"{where}xy", "give exactly one of xy = [x, y] or xyz = [x, y, z]")
    if "xyz" in entry:
        if "z" in entry:
            raise read.fail(f"{where}z", "z is already given by xyz")
        return read.vector(entry["xyz"], f"{where}xyz", 3)
    return read.vector(entry["xy"], f"{where}xy", 2) + [
        read.number(entry.get("z", default_z), f"{where}z")]


def _moved_to(read: Reader, entry: dict[str, Any], position: list[float],
              where: str) -> list[float]:
    """Where a beacon physically is: ``moved_to`` = [x, y] or [x, y, z], else its map position."""
    if "moved_to" not in entry:
        return position
    moved = entry["moved_to"]
    if isinstance(moved, list) and len(moved) == 2:
        return read.vector(moved, f"{where}moved_to", 2) + [position[2]]
    return read.vector(moved, f"{where}moved_to", 3)


def _in_room(read: Reader, xyz: list[float], field: str, beacon_id: int,
             bounds: tuple[float, float, float, float]) -> list[float]:
    """``xyz``, checked to be in the room: within ``ON_WALL_TOLERANCE`` of its ``bounds``."""
    x_min, y_min, x_max, y_max = bounds
    if not (x_min - ON_WALL_TOLERANCE <= xyz[0] <= x_max + ON_WALL_TOLERANCE
            and y_min - ON_WALL_TOLERANCE <= xyz[1] <= y_max + ON_WALL_TOLERANCE):
        raise read.fail(field, f"beacon {beacon_id} at ({xyz[0]:g}, {xyz[1]:g}) is outside the "
                        f"room [{x_min:g}, {x_max:g}] x [{y_min:g}, {y_max:g}] (by more than "
                        f"{ON_WALL_TOLERANCE:g} m)")
    return xyz


def check_beacons_outside_racks(read: Reader, ids: IntArray, physical_xyz: FloatArray,
                                racks: tuple[Rack, ...], table: str = "beacons") -> None:
    """Reject a beacon whose physical position lies in a rack's footprint (the first such).

    ``table`` names the array the positions come from (``beacons`` or ``unmapped``).
    """
    first: tuple[int, int] | None = None  # (beacon, rack): the first beacon, its first rack
    for r, rack in enumerate(racks):  # every beacon at once, rack by rack: O(beacons) memory
        inside = np.flatnonzero(rack.contains(physical_xyz[:, 0], physical_xyz[:, 1]))
        if inside.size and (first is None or inside[0] < first[0]):
            first = (int(inside[0]), r)
    if first is not None:
        k, r = first
        raise read.fail(f"{table}[{k}]", f"beacon {ids[k]} at ({physical_xyz[k, 0]:g}, "
                        f"{physical_xyz[k, 1]:g}) is inside racks[{r}]")


# --------------------------------------------------------------------------- racks and walls

def _footprint(read: Reader, entry: dict[str, Any], where: str) -> tuple[list[float], ...]:
    """A rectangle's ``center`` = [x, y] and positive ``size`` = [x extent, y extent] [m]."""
    center = read.vector(read.require(entry, "center", where), f"{where}center", 2)
    size = read.vector(read.require(entry, "size", where), f"{where}size", 2)
    if min(size) <= 0:
        raise read.fail(f"{where}size", f"must be positive [length, depth], got {size}")
    return center, size


def _reflectivity(read: Reader, entry: dict[str, Any], where: str) -> float:
    """A surface's share of light it mirrors, in [0, 1]; 0 (matte) when not given."""
    return read.fraction(entry.get("reflectivity", 0.0), f"{where}reflectivity")


def parse_rack(read: Reader, entry: dict[str, Any], k: int) -> Rack:
    """The ``k``-th ``[[racks]]`` table: footprint, turn, height and reflectivity."""
    where = f"racks[{k}]."
    read.keys(entry, _RACK_KEYS, where)
    center, size = _footprint(read, entry, where)
    return Rack(
        center=(center[0], center[1]), size=(size[0], size[1]),
        angle=math.radians(read.number(entry.get("angle_deg", 0.0), f"{where}angle_deg",
                                       maximum=360.0)),
        height=read.number(read.require(entry, "height", where), f"{where}height",
                           positive=True),
        reflectivity=_reflectivity(read, entry, where),
    )


def parse_wall(read: Reader, entry: dict[str, Any], k: int) -> Wall:
    """The ``k``-th ``[[walls]]`` table: two distinct end points, height and reflectivity."""
    where = f"walls[{k}]."
    read.keys(entry, _WALL_KEYS, where)
    start = read.vector(read.require(entry, "start", where), f"{where}start", 2)
    end = read.vector(read.require(entry, "end", where), f"{where}end", 2)
    if start == end:
        raise read.fail(f"{where}end", f"must differ from start, got {end}")
    return Wall(start=(start[0], start[1]), end=(end[0], end[1]),
                height=read.number(read.require(entry, "height", where), f"{where}height",
                                   positive=True),
                reflectivity=_reflectivity(read, entry, where))


# --------------------------------------------------------------------------- routes

class Obstacles:
    """The racks and walls a route's legs must keep ``ROUTE_CLEARANCE`` off.

    Each one's bounding box, grown by the clearance, is kept, and a route's legs are compared
    with all of them in one array step: a leg is measured exactly only against the few whose box
    its own box meets, so a site of many racks and long routes still loads in seconds.
    """

    def __init__(self, racks: tuple[Rack, ...], walls: tuple[Wall, ...]) -> None:
        self.racks, self.walls = racks, walls
        self.pairs_left = MAX_LEG_PAIRS

    @functools.cached_property
    def _boxes(self) -> tuple[FloatArray, FloatArray]:
        """Lowest and highest (x, y) of each obstacle, grown by the clearance, (O, 2) each."""
        shapes = [rack.corners() for rack in self.racks] + [
            np.array([wall.start, wall.end]) for wall in self.walls]
        low = np.array([shape.min(axis=0) for shape in shapes]).reshape(-1, 2)
        high = np.array([shape.max(axis=0) for shape in shapes]).reshape(-1, 2)
        return low - ROUTE_CLEARANCE, high + ROUTE_CLEARANCE

    def near(self, read: Reader, points: FloatArray, field: str) -> list[list[int]]:
        """(leg, obstacle) pairs whose boxes meet, leg by leg; obstacles are racks, then walls.

        Args:
            read: Reports the route (``field``) that takes the scenario past ``MAX_LEG_PAIRS``.
            points: A route's waypoints, shape (P, 2); leg k runs from point k to point k + 1.
            field: The route's ``waypoints`` field.
        """
        pairs = (len(points) - 1) * (len(self.racks) + len(self.walls))
        if pairs > self.pairs_left:
            raise read.fail(field, f"too many legs to check against {len(self.racks)} racks and "
                            f"{len(self.walls)} walls: a scenario's routes may make at most "
                            f"{MAX_LEG_PAIRS} (leg, rack or wall) pairs")
        self.pairs_left -= pairs
        low, high = self._boxes
        leg_low = np.minimum(points[:-1], points[1:])[:, None, :]
        leg_high = np.maximum(points[:-1], points[1:])[:, None, :]
        meet = ((low <= leg_high) & (high >= leg_low)).all(axis=2)  # (legs, obstacles)
        return np.argwhere(meet).tolist()


def parse_route(read: Reader, entry: dict[str, Any], k: int, *,
                bounds: tuple[float, float, float, float], obstacles: Obstacles) -> Route:
    """The ``k``-th ``[[routes]]`` table: waypoints in the room, legs clear of racks and walls."""
    where = f"routes[{k}]."
    read.keys(entry, _ROUTE_KEYS, where)
    name = read.text(read.require(entry, "name", where), f"{where}name")
    points = _waypoints(read, entry, where, bounds)
    reverse = entry.get("reverse", [False] * (len(points) - 1))
    if not (isinstance(reverse, list) and len(reverse) == len(points) - 1):
        raise read.fail(f"{where}reverse",
                        f"must be a list of {len(points) - 1} booleans, one per leg")
    reverse = [read.boolean(r, f"{where}reverse[{i}]") for i, r in enumerate(reverse)]
    _check_legs_clear(read, points, obstacles, where, name)
    speed = read.number(entry.get("speed", 1.5), f"{where}speed", positive=True,
                        maximum=MAX_ROUTE_SPEED)
    return Route(name=name, waypoints=points, reverse=tuple(reverse), speed=speed)


def _waypoints(read: Reader, entry: dict[str, Any], where: str,
               bounds: tuple[float, float, float, float]) -> FloatArray:
    """A route's ``waypoints``: at least 2 [x, y] points inside the room, shape (P, 2)."""
    raw = read.require(entry, "waypoints", where)
    if not isinstance(raw, list) or len(raw) < 2:
        raise read.fail(f"{where}waypoints", "must be a list of at least 2 [x, y] points")
    read.count(raw, f"{where}waypoints")
    points = np.array([read.vector(p, f"{where}waypoints[{i}]", 2) for i, p in enumerate(raw)])
    for i, (x, y) in enumerate(points):
        if not (bounds[0] <= x <= bounds[2] and bounds[1] <= y <= bounds[3]):
            raise read.fail(f"{where}waypoints[{i}]", f"({x:g}, {y:g}) is outside the room")
    return points


def _check_legs_clear(read: Reader, points: FloatArray, obstacles: Obstacles, where: str,
                      name: str) -> None:
    """Reject a route leg within ``ROUTE_CLEARANCE`` of a rack or a wall.

    The forklift would scrape it, or (a wall crossed) drive into it: pymunk's racks and walls
    are solid.
    """
    xy = points.tolist()  # plain floats for the exact tests
    n_racks = len(obstacles.racks)
    for leg, index in obstacles.near(read, points, f"{where}waypoints"):
        start, end = xy[leg], xy[leg + 1]
        if index < n_racks:
            if not leg_hits_rack(start, end, obstacles.racks[index], ROUTE_CLEARANCE):
                continue
            problem, what = f"passes within {ROUTE_CLEARANCE} m of", f"racks[{index}]"
        else:
            distance = leg_wall_distance(start, end, obstacles.walls[index - n_racks])
            if distance >= ROUTE_CLEARANCE:
                continue
            problem = "crosses" if distance == 0.0 else f"passes within {ROUTE_CLEARANCE} m of"
            what = f"walls[{index - n_racks}]"
        raise read.fail(f"{where}waypoints", f"leg {leg} from ({start[0]:g}, {start[1]:g}) to "
                        f"({end[0]:g}, {end[1]:g}) {problem} {what} (route {shown(name)})")


def check_route_names_unique(read: Reader, routes: tuple[Route, ...]) -> None:
    """Reject a route named like an earlier one: routes are chosen by name."""
    names = [route.name for route in routes]
    for k, route_name in enumerate(names):
        if route_name in names[:k]:
            raise read.fail(f"routes[{k}].name", f"duplicate route name {route_name!r}")


# --------------------------------------------------------------------------- bumps and lights

def parse_bump(read: Reader, entry: dict[str, Any], k: int) -> Bump:
    """The ``k``-th ``[[bumps]]`` table: footprint and tilt in [0, 45) degrees."""
    where = f"bumps[{k}]."
    read.keys(entry, _BUMP_KEYS, where)
    center, size = _footprint(read, entry, where)
    tilt = read.number(read.require(entry, "tilt_deg", where), f"{where}tilt_deg",
                       non_negative=True, below=45.0)
    return Bump(center=(center[0], center[1]), size=(size[0], size[1]),
                tilt=math.radians(tilt))


def parse_light(read: Reader, entry: dict[str, Any], k: int, *,
                racks: tuple[Rack, ...]) -> Light:
    """The ``k``-th ``[[lights]]`` table: a lamp or window outside the racks."""
    where = f"lights[{k}]."
    read.keys(entry, _LIGHT_KEYS, where)
    xyz = read.vector(read.require(entry, "xyz", where), f"{where}xyz", 3)
    for r, rack in enumerate(racks):
        if rack.contains(xyz[0], xyz[1]) and xyz[2] < rack.height:
            raise read.fail(f"{where}xyz", f"({xyz[0]:g}, {xyz[1]:g}, {xyz[2]:g}) is inside "
                            f"racks[{r}]")
    width = read.number(entry.get("width", 0.3), f"{where}width", positive=True)
    return Light(name=read.text(entry.get("name", f"light {k}"), f"{where}name"),
                 xyz=(xyz[0], xyz[1], xyz[2]), width=width,
                 tall=read.number(entry.get("tall", width), f"{where}tall", positive=True),
                 power=read.number(entry.get("power", 20.0), f"{where}power", positive=True))
