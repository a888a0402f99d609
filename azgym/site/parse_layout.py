"""The floor's layout tables: beacons, racks, walls, routes, bumps and lights.

``[[beacons]]``, ``[[racks]]``, ``[[walls]]``, ``[[routes]]``, ``[[bumps]]`` and ``[[lights]]``
place things in the room, so besides their own fields they are checked against
each other: a beacon or a lamp must not sit inside a rack, a route's legs must keep
``ROUTE_CLEARANCE`` off the racks, route names must be unique. Those geometric rules are
kept here, next to the tables they relate; the sensor's tables (camera, fisheye, error model,
faults) are in :mod:`azgym.site.parse_sensor`, and field-level checks and their messages in
:mod:`azgym.site.reader`.
"""

from __future__ import annotations

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
)
from azgym.site.reader import Reader

_DEFAULT_KEYS = {"width", "z"}
_BEACON_KEYS = {"id", "xy", "xyz", "width", "z", "moved_to"}
_RACK_KEYS = {"center", "size", "angle_deg", "height", "reflectivity"}
_WALL_KEYS = {"start", "end", "height", "reflectivity"}
_ROUTE_KEYS = {"name", "waypoints", "reverse", "speed"}
_BUMP_KEYS = {"center", "size", "tilt_deg"}
_LIGHT_KEYS = {"name", "xyz", "width", "tall", "power"}


# --------------------------------------------------------------------------- beacons

def parse_beacons(read: Reader, data: dict[str, Any]) -> tuple[BeaconMap, FloatArray]:
    """The ``[[beacons]]`` as a map, and where each physically is (see ``moved_to``), (N, 3)."""
    defaults = read.table(data.get("beacon_defaults", {}), "beacon_defaults", _DEFAULT_KEYS)
    default_width = read.number(defaults.get("width", 0.03), "beacon_defaults.width",
                                positive=True)
    default_z = read.number(defaults.get("z", 0.0), "beacon_defaults.z")
    entries = read.require(data, "beacons")
    if not isinstance(entries, list) or len(entries) < 3:
        raise read.fail("beacons", "must be an array of at least 3 [[beacons]] tables")
    ids: list[int] = []
    xyz, width, physical = [], [], []
    for k, entry in enumerate(entries):
        where = f"beacons[{k}]."
        read.table(entry, f"beacons[{k}]", _BEACON_KEYS)
        ids.append(_beacon_id(read, entry, where, ids))
        position = _beacon_position(read, entry, where, default_z)
        xyz.append(position)
        physical.append(_moved_to(read, entry, position, where))
        width.append(read.number(entry.get("width", default_width), f"{where}width",
                                 positive=True))
    return BeaconMap(np.array(ids), np.array(xyz), np.array(width)), np.array(physical)


def _beacon_id(read: Reader, entry: dict[str, Any], where: str, earlier: list[int]) -> int:
    """A beacon's ``id``: an integer that none of the ``earlier`` beacons has."""
    beacon_id = read.integer(read.require(entry, "id", where), f"{where}id")
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


def check_beacons_outside_racks(read: Reader, ids: IntArray, physical_xyz: FloatArray,
                                racks: tuple[Rack, ...]) -> None:
    """Reject a beacon whose physical position lies in a rack's footprint."""
    for k, position in enumerate(physical_xyz):
        for r, rack in enumerate(racks):
            if rack.contains(position[0], position[1]):
                raise read.fail(f"beacons[{k}]", f"beacon {ids[k]} at ({position[0]:g}, "
                                f"{position[1]:g}) is inside racks[{r}]")


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
        angle=math.radians(read.number(entry.get("angle_deg", 0.0), f"{where}angle_deg")),
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

def parse_route(read: Reader, entry: dict[str, Any], k: int, *,
                bounds: tuple[float, float, float, float], racks: tuple[Rack, ...]) -> Route:
    """The ``k``-th ``[[routes]]`` table: waypoints in the room whose legs keep off the racks."""
    where = f"routes[{k}]."
    read.keys(entry, _ROUTE_KEYS, where)
    name = read.text(read.require(entry, "name", where), f"{where}name")
    points = _waypoints(read, entry, where, bounds)
    reverse = entry.get("reverse", [False] * (len(points) - 1))
    if not (isinstance(reverse, list) and len(reverse) == len(points) - 1
            and all(isinstance(r, bool) for r in reverse)):
        raise read.fail(f"{where}reverse",
                        f"must be a list of {len(points) - 1} booleans, one per leg")
    _check_legs_clear_racks(read, points, racks, where)
    speed = read.number(entry.get("speed", 1.5), f"{where}speed", positive=True)
    return Route(name=name, waypoints=points, reverse=tuple(reverse), speed=speed)


def _waypoints(read: Reader, entry: dict[str, Any], where: str,
               bounds: tuple[float, float, float, float]) -> FloatArray:
    """A route's ``waypoints``: at least 2 [x, y] points inside the room, shape (P, 2)."""
    raw = read.require(entry, "waypoints", where)
    if not isinstance(raw, list) or len(raw) < 2:
        raise read.fail(f"{where}waypoints", "must be a list of at least 2 [x, y] points")
    points = np.array([read.vector(p, f"{where}waypoints[{i}]", 2) for i, p in enumerate(raw)])
    for i, (x, y) in enumerate(points):
        if not (bounds[0] <= x <= bounds[2] and bounds[1] <= y <= bounds[3]):
            raise read.fail(f"{where}waypoints[{i}]", f"({x:g}, {y:g}) is outside the room")
    return points


def _check_legs_clear_racks(read: Reader, points: FloatArray, racks: tuple[Rack, ...],
                            where: str) -> None:
    """Reject a route leg within ``ROUTE_CLEARANCE`` of a rack: the forklift would scrape it."""
    for leg in range(len(points) - 1):
        for r, rack in enumerate(racks):
            if leg_hits_rack(points[leg], points[leg + 1], rack, ROUTE_CLEARANCE):
                raise read.fail(
                    f"{where}waypoints",
                    f"leg {leg} from ({points[leg][0]:g}, {points[leg][1]:g}) to "
                    f"({points[leg + 1][0]:g}, {points[leg + 1][1]:g}) passes within "
                    f"{ROUTE_CLEARANCE} m of racks[{r}]")


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
