"""Scenario files' contents, validated: parsed TOML data in, a :class:`Scenario` out.

Every problem is reported with the file, the field and what is wrong, e.g.
``paper-room.toml: beacons[3].width: must be > 0, got -0.01``.
"""

from __future__ import annotations

import difflib
import functools
import math
from collections.abc import Callable
from typing import Any, TypeVar

import numpy as np

from azgym.core import BeaconMap, FloatArray, IntArray
from azgym.errors import InvalidInputError, ScenarioError
from azgym.site.elements import (
    ROUTE_CLEARANCE,
    Bump,
    Camera,
    Faults,
    Light,
    Rack,
    Route,
    Wall,
    leg_hits_rack,
)
from azgym.site.error_model import ErrorModel
from azgym.site.fisheye import FisheyeCamera
from azgym.site.scenario import Scenario

_TOP_KEYS = {"name", "description", "version", "room", "error_model", "beacon_defaults",
             "beacons", "camera", "faults", "racks", "walls", "routes",
             "bumps", "fisheye", "lights"}
_CAMERA_KEYS = {"height", "min_elevation_deg", "max_range"}
_FAULT_KEYS = {"misdecode_rate"}
_RACK_KEYS = {"center", "size", "angle_deg", "height", "reflectivity"}
_WALL_KEYS = {"start", "end", "height", "reflectivity"}
_ROUTE_KEYS = {"name", "waypoints", "reverse", "speed"}
_BUMP_KEYS = {"center", "size", "tilt_deg"}
_LIGHT_KEYS = {"name", "xyz", "width", "tall", "power"}
_FISHEYE_KEYS = {"focal_px", "principal_point", "image_size", "distortion"}
_ROOM_KEYS = {"bounds"}
_ERROR_KEYS = {"delta_alpha_d_deg", "center_error_px", "horizon_radius_px", "coverage"}
_DEFAULT_KEYS = {"width", "z"}
_BEACON_KEYS = {"id", "xy", "xyz", "width", "z", "moved_to"}

_Element = TypeVar("_Element")


class _Reader:
    """Reads fields of one file, raising :class:`ScenarioError` that names file and field."""

    def __init__(self, origin: str) -> None:
        self.origin = origin

    def fail(self, field: str, problem: str) -> ScenarioError:
        """The error for a problem with ``field``, prefixed with the file's name."""
        return ScenarioError(f"{self.origin}: {field}: {problem}")

    def keys(self, table: dict[str, Any], allowed: set[str], where: str) -> None:
        """Reject a key not in ``allowed``, suggesting the closest valid one (typos)."""
        for key in table:
            if key not in allowed:
                close = difflib.get_close_matches(key, sorted(allowed), n=1)
                hint = f" Did you mean {close[0]!r}?" if close else ""
                raise self.fail(f"{where}{key}", f"unknown key.{hint} "
                                f"Valid keys: {', '.join(sorted(allowed))}")

    def table(self, value: Any, field: str, allowed: set[str]) -> dict[str, Any]:
        """``value``, checked to be a table whose keys are all in ``allowed``."""
        if not isinstance(value, dict):
            raise self.fail(field, "must be a table")
        self.keys(value, allowed, f"{field}.")
        return value

    def require(self, table: dict[str, Any], key: str, where: str = "") -> Any:
        """``table[key]``, which must be given."""
        if key not in table:
            raise self.fail(f"{where}{key}", "missing")
        return table[key]

    def number(self, value: Any, field: str, *, positive: bool = False,
               non_negative: bool = False, below: float | None = None) -> float:
        """``value`` as a finite float, optionally > 0, >= 0 and/or < ``below``."""
        if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                not math.isfinite(value):
            raise self.fail(field, f"must be a finite number, got {value!r}")
        if positive and not value > 0:
            raise self.fail(field, f"must be > 0, got {value!r}")
        if non_negative and value < 0:
            raise self.fail(field, f"must be >= 0, got {value!r}")
        if below is not None and value >= below:
            raise self.fail(field, f"must be < {below:g}, got {float(value)}")
        return float(value)

    def fraction(self, value: Any, field: str) -> float:
        """``value`` as a number in [0, 1]: a share, a rate or a reflectivity."""
        share = self.number(value, field, non_negative=True)
        if share > 1.0:
            raise self.fail(field, f"must be in [0, 1], got {share}")
        return share

    def integer(self, value: Any, field: str, minimum: int | None = None) -> int:
        """``value`` as an integer (booleans are not), optionally >= ``minimum``."""
        if isinstance(value, bool) or not isinstance(value, int) or \
                (minimum is not None and value < minimum):
            bound = "" if minimum is None else f" >= {minimum}"
            raise self.fail(field, f"must be an integer{bound}, got {value!r}")
        return value

    def vector(self, value: Any, field: str, length: int) -> list[float]:
        """``value`` as a list of ``length`` finite numbers."""
        if not isinstance(value, list) or len(value) != length:
            raise self.fail(field, f"must be a list of {length} numbers, got {value!r}")
        return [self.number(v, f"{field}[{k}]") for k, v in enumerate(value)]

    def text(self, value: Any, field: str) -> str:
        """``value`` as a string that is not blank."""
        if not isinstance(value, str) or not value.strip():
            raise self.fail(field, f"must be a non-empty string, got {value!r}")
        return value


def parse_scenario(data: dict[str, Any], origin: str = "<scenario>") -> Scenario:
    """Build a :class:`Scenario` from parsed TOML, validating every field.

    The sections are read in a fixed order, so a file with several problems always reports the
    same one first.

    Raises:
        ScenarioError: Naming the origin, the field and the problem.
    """
    read = _Reader(origin)
    read.keys(data, _TOP_KEYS, "")
    name = read.text(read.require(data, "name"), "name")
    description = read.text(read.require(data, "description"), "description")
    version = read.integer(read.require(data, "version"), "version", minimum=1)
    bounds = _parse_room(read, data)
    error_model = _parse_error_model(read, data.get("error_model", {}))
    beacons, physical_xyz = _parse_beacons(read, data)
    racks = _parse_tables(read, data, "racks", _parse_rack)
    walls = _parse_tables(read, data, "walls", _parse_wall)
    _check_beacons_outside_racks(read, beacons.ids, physical_xyz, racks)
    routes = _parse_tables(read, data, "routes",
                           functools.partial(_parse_route, bounds=bounds, racks=racks))
    _check_route_names_unique(read, routes)
    return Scenario(name=name, description=description, version=version, bounds=bounds,
                    beacons=beacons, error_model=error_model, racks=racks, walls=walls,
                    routes=routes, bumps=_parse_tables(read, data, "bumps", _parse_bump),
                    fisheye=_parse_fisheye(read, data.get("fisheye", {})),
                    lights=_parse_tables(read, data, "lights",
                                         functools.partial(_parse_light, racks=racks)),
                    camera=_parse_camera(read, data.get("camera", {})),
                    faults=_parse_faults(read, data.get("faults", {})),
                    physical_xyz=None if np.array_equal(physical_xyz, beacons.xyz)
                    else physical_xyz)


def _parse_room(read: _Reader, data: dict[str, Any]) -> tuple[float, float, float, float]:
    """The ``[room]`` table's ``bounds`` = [x_min, y_min, x_max, y_max] [m]."""
    room = read.table(read.require(data, "room"), "room", _ROOM_KEYS)
    bounds = read.vector(read.require(room, "bounds", "room."), "room.bounds", 4)
    if bounds[2] <= bounds[0] or bounds[3] <= bounds[1]:
        raise read.fail("room.bounds", f"must be [x_min, y_min, x_max, y_max] with max > min, "
                        f"got {bounds}")
    return bounds[0], bounds[1], bounds[2], bounds[3]


def _parse_beacons(read: _Reader, data: dict[str, Any]) -> tuple[BeaconMap, FloatArray]:
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


def _beacon_id(read: _Reader, entry: dict[str, Any], where: str, earlier: list[int]) -> int:
    """A beacon's ``id``: an integer that none of the ``earlier`` beacons has."""
    beacon_id = read.integer(read.require(entry, "id", where), f"{where}id")
    if beacon_id in earlier:
        raise read.fail(f"{where}id",
                        f"duplicate id {beacon_id} (also beacons[{earlier.index(beacon_id)}])")
    return beacon_id


def _beacon_position(read: _Reader, entry: dict[str, Any], where: str,
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


def _check_beacons_outside_racks(read: _Reader, ids: IntArray, physical_xyz: FloatArray,
                                 racks: tuple[Rack, ...]) -> None:
    """Reject a beacon whose physical position lies in a rack's footprint."""
    for k, position in enumerate(physical_xyz):
        for r, rack in enumerate(racks):
            if rack.contains(position[0], position[1]):
                raise read.fail(f"beacons[{k}]", f"beacon {ids[k]} at ({position[0]:g}, "
                                f"{position[1]:g}) is inside racks[{r}]")


def _check_route_names_unique(read: _Reader, routes: tuple[Route, ...]) -> None:
    """Reject a route named like an earlier one: routes are chosen by name."""
    names = [route.name for route in routes]
    for k, route_name in enumerate(names):
        if route_name in names[:k]:
            raise read.fail(f"routes[{k}].name", f"duplicate route name {route_name!r}")


def _parse_tables(read: _Reader, data: dict[str, Any], key: str,
                  parse: Callable[[_Reader, dict[str, Any], int], _Element]
                  ) -> tuple[_Element, ...]:
    """Each table of the optional array ``[[key]]``, read by ``parse(read, table, index)``."""
    entries = data.get(key, [])
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise read.fail(key, f"must be an array of [[{key}]] tables")
    return tuple(parse(read, entry, k) for k, entry in enumerate(entries))


def _moved_to(read: _Reader, entry: dict[str, Any], position: list[float],
              where: str) -> list[float]:
    """Where a beacon physically is: ``moved_to`` = [x, y] or [x, y, z], else its map position."""
    if "moved_to" not in entry:
        return position
    moved = entry["moved_to"]
    if isinstance(moved, list) and len(moved) == 2:
        return read.vector(moved, f"{where}moved_to", 2) + [position[2]]
    return read.vector(moved, f"{where}moved_to", 3)


def _footprint(read: _Reader, entry: dict[str, Any], where: str) -> tuple[list[float], ...]:
    """A rectangle's ``center`` = [x, y] and positive ``size`` = [x extent, y extent] [m]."""
    center = read.vector(read.require(entry, "center", where), f"{where}center", 2)
    size = read.vector(read.require(entry, "size", where), f"{where}size", 2)
    if min(size) <= 0:
        raise read.fail(f"{where}size", f"must be positive [length, depth], got {size}")
    return center, size


def _reflectivity(read: _Reader, entry: dict[str, Any], where: str) -> float:
    """A surface's share of light it mirrors, in [0, 1]; 0 (matte) when not given."""
    return read.fraction(entry.get("reflectivity", 0.0), f"{where}reflectivity")


def _parse_rack(read: _Reader, entry: dict[str, Any], k: int) -> Rack:
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


def _parse_wall(read: _Reader, entry: dict[str, Any], k: int) -> Wall:
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


def _parse_route(read: _Reader, entry: dict[str, Any], k: int, *,
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


def _waypoints(read: _Reader, entry: dict[str, Any], where: str,
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


def _check_legs_clear_racks(read: _Reader, points: FloatArray, racks: tuple[Rack, ...],
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


def _parse_bump(read: _Reader, entry: dict[str, Any], k: int) -> Bump:
    """The ``k``-th ``[[bumps]]`` table: footprint and tilt in [0, 45) degrees."""
    where = f"bumps[{k}]."
    read.keys(entry, _BUMP_KEYS, where)
    center, size = _footprint(read, entry, where)
    tilt = read.number(read.require(entry, "tilt_deg", where), f"{where}tilt_deg",
                       non_negative=True, below=45.0)
    return Bump(center=(center[0], center[1]), size=(size[0], size[1]),
                tilt=math.radians(tilt))


def _parse_light(read: _Reader, entry: dict[str, Any], k: int, *,
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


def _parse_fisheye(read: _Reader, table: Any) -> FisheyeCamera:
    """The ``[fisheye]`` table: intrinsics, each defaulting to :class:`FisheyeCamera`'s."""
    read.table(table, "fisheye", _FISHEYE_KEYS)
    default = FisheyeCamera()
    size = table.get("image_size", list(default.image_size))
    if not (isinstance(size, list) and len(size) == 2 and all(isinstance(v, int) for v in size)):
        raise read.fail("fisheye.image_size", f"must be [width, height] in pixels, got {size!r}")
    point = read.vector(table.get("principal_point", list(default.principal_point)),
                        "fisheye.principal_point", 2)
    distortion = read.vector(table.get("distortion", list(default.distortion)),
                             "fisheye.distortion", 4)
    focal = read.number(table.get("focal_px", default.focal_px), "fisheye.focal_px")
    try:
        return FisheyeCamera(focal_px=focal, principal_point=(point[0], point[1]),
                             image_size=(size[0], size[1]),
                             distortion=(distortion[0], distortion[1], distortion[2],
                                         distortion[3]))
    except InvalidInputError as exc:  # it names the field; add the file
        field = str(exc).split(" ", 1)[0].replace("FisheyeCamera.", "fisheye.")
        raise read.fail(field, str(exc).split(" ", 1)[1]) from None


def _parse_camera(read: _Reader, table: Any) -> Camera:
    """The ``[camera]`` table: height, elevation limit and range; :class:`Camera`'s by default."""
    read.table(table, "camera", _CAMERA_KEYS)
    default = Camera()
    elevation = read.number(table.get("min_elevation_deg", math.degrees(default.min_elevation)),
                            "camera.min_elevation_deg")
    if not -90.0 < elevation < 90.0:
        raise read.fail("camera.min_elevation_deg", f"must be in (-90, 90), got {elevation}")
    return Camera(
        height=read.number(table.get("height", default.height), "camera.height", positive=True),
        min_elevation=math.radians(elevation),
        max_range=read.number(table.get("max_range", default.max_range), "camera.max_range",
                              positive=True),
    )


def _parse_faults(read: _Reader, table: Any) -> Faults:
    """The ``[faults]`` table: the misread rate of oracle ids, in [0, 1]."""
    read.table(table, "faults", _FAULT_KEYS)
    return Faults(misdecode_rate=read.fraction(table.get("misdecode_rate", 0.0),
                                               "faults.misdecode_rate"))


def _parse_error_model(read: _Reader, table: Any) -> ErrorModel:
    """The ``[error_model]`` table: Δα_d in degrees, or the camera's pixel errors (eq. 1)."""
    read.table(table, "error_model", _ERROR_KEYS)
    coverage = table.get("coverage", True)
    if not isinstance(coverage, bool):
        raise read.fail("error_model.coverage", f"must be true or false, got {coverage!r}")
    camera_keys = {"center_error_px", "horizon_radius_px"} & set(table)
    if camera_keys and "delta_alpha_d_deg" in table:
        raise read.fail("error_model.delta_alpha_d_deg",
                        "give either delta_alpha_d_deg or center_error_px + horizon_radius_px")
    if camera_keys:
        center = read.number(read.require(table, "center_error_px", "error_model."),
                             "error_model.center_error_px", non_negative=True)
        radius = read.number(read.require(table, "horizon_radius_px", "error_model."),
                             "error_model.horizon_radius_px", positive=True)
        return ErrorModel.from_camera(center, radius, coverage=coverage)
    degrees = read.number(table.get("delta_alpha_d_deg", 0.4), "error_model.delta_alpha_d_deg",
                          non_negative=True, below=90.0)
    return ErrorModel(delta_alpha_d=math.radians(degrees), coverage=coverage)
