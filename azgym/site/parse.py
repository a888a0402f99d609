"""Scenario files' contents, validated: parsed TOML data in, a :class:`Scenario` out.

Every problem is reported with the file, the field and what is wrong, e.g.
``paper-room.toml: beacons[3].width: must be > 0, got -0.01``.
"""

from __future__ import annotations

import difflib
import math
from typing import Any

import numpy as np

from azgym.core import BeaconMap
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


class _Reader:
    """Reads fields of one file, raising :class:`ScenarioError` that names file and field."""

    def __init__(self, origin: str) -> None:
        self.origin = origin

    def fail(self, field: str, problem: str) -> ScenarioError:
        return ScenarioError(f"{self.origin}: {field}: {problem}")

    def keys(self, table: dict[str, Any], allowed: set[str], where: str) -> None:
        for key in table:
            if key not in allowed:
                close = difflib.get_close_matches(key, sorted(allowed), n=1)
                hint = f" Did you mean {close[0]!r}?" if close else ""
                raise self.fail(f"{where}{key}", f"unknown key.{hint} "
                                f"Valid keys: {', '.join(sorted(allowed))}")

    def require(self, table: dict[str, Any], key: str, where: str = "") -> Any:
        if key not in table:
            raise self.fail(f"{where}{key}", "missing")
        return table[key]

    def number(self, value: Any, field: str, *, positive: bool = False,
               non_negative: bool = False) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                not math.isfinite(value):
            raise self.fail(field, f"must be a finite number, got {value!r}")
        if positive and not value > 0:
            raise self.fail(field, f"must be > 0, got {value!r}")
        if non_negative and value < 0:
            raise self.fail(field, f"must be >= 0, got {value!r}")
        return float(value)

    def vector(self, value: Any, field: str, length: int) -> list[float]:
        if not isinstance(value, list) or len(value) != length:
            raise self.fail(field, f"must be a list of {length} numbers, got {value!r}")
        return [self.number(v, f"{field}[{k}]") for k, v in enumerate(value)]

    def text(self, value: Any, field: str) -> str:
        if not isinstance(value, str) or not value.strip():
            raise self.fail(field, f"must be a non-empty string, got {value!r}")
        return value


def parse_scenario(data: dict[str, Any], origin: str = "<scenario>") -> Scenario:
    """Build a :class:`Scenario` from parsed TOML, validating every field.

    Raises:
        ScenarioError: Naming the origin, the field and the problem.
    """
    read = _Reader(origin)
    read.keys(data, _TOP_KEYS, "")
    name = read.text(read.require(data, "name"), "name")
    description = read.text(read.require(data, "description"), "description")
    version = read.require(data, "version")
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise read.fail("version", f"must be an integer >= 1, got {version!r}")

    room = read.require(data, "room")
    if not isinstance(room, dict):
        raise read.fail("room", "must be a table")
    read.keys(room, _ROOM_KEYS, "room.")
    bounds = read.vector(read.require(room, "bounds", "room."), "room.bounds", 4)
    if bounds[2] <= bounds[0] or bounds[3] <= bounds[1]:
        raise read.fail("room.bounds", f"must be [x_min, y_min, x_max, y_max] with max > min, "
                        f"got {bounds}")

    error_model = _parse_error_model(read, data.get("error_model", {}))

    defaults = data.get("beacon_defaults", {})
    if not isinstance(defaults, dict):
        raise read.fail("beacon_defaults", "must be a table")
    read.keys(defaults, _DEFAULT_KEYS, "beacon_defaults.")
    default_width = read.number(defaults.get("width", 0.03), "beacon_defaults.width",
                                positive=True)
    default_z = read.number(defaults.get("z", 0.0), "beacon_defaults.z")

    entries = read.require(data, "beacons")
    if not isinstance(entries, list) or len(entries) < 3:
        raise read.fail("beacons", "must be an array of at least 3 [[beacons]] tables")
    ids, xyz, width, physical = [], [], [], []
    seen: dict[int, int] = {}
    for k, entry in enumerate(entries):
        where = f"beacons[{k}]."
        if not isinstance(entry, dict):
            raise read.fail(f"beacons[{k}]", "must be a table")
        read.keys(entry, _BEACON_KEYS, where)
        beacon_id = read.require(entry, "id", where)
        if isinstance(beacon_id, bool) or not isinstance(beacon_id, int):
            raise read.fail(f"{where}id", f"must be an integer, got {beacon_id!r}")
        if beacon_id in seen:
            raise read.fail(f"{where}id",
                            f"duplicate id {beacon_id} (also beacons[{seen[beacon_id]}])")
        seen[beacon_id] = k
        if ("xy" in entry) == ("xyz" in entry):
            raise read.fail(f"{where}xy", "give exactly one of xy = [x, y] or xyz = [x, y, z]")
        if "xyz" in entry:
            if "z" in entry:
                raise read.fail(f"{where}z", "z is already given by xyz")
            position = read.vector(entry["xyz"], f"{where}xyz", 3)
        else:
            position = read.vector(entry["xy"], f"{where}xy", 2) + [
                read.number(entry.get("z", default_z), f"{where}z")]
        ids.append(beacon_id)
        xyz.append(position)
        physical.append(_moved_to(read, entry, position, where))
        width.append(read.number(entry.get("width", default_width), f"{where}width",
                                 positive=True))
    beacons = BeaconMap(np.array(ids), np.array(xyz), np.array(width))
    racks = tuple(_parse_rack(read, entry, k) for k, entry in enumerate(
        _array_of_tables(read, data, "racks")))
    walls = tuple(_parse_wall(read, entry, k) for k, entry in enumerate(
        _array_of_tables(read, data, "walls")))
    physical_xyz = np.array(physical)
    for k, position in enumerate(physical_xyz):
        for r, rack in enumerate(racks):
            if rack.contains(position[0], position[1]):
                raise read.fail(f"beacons[{k}]", f"beacon {ids[k]} at ({position[0]:g}, "
                                f"{position[1]:g}) is inside racks[{r}]")
    routes = tuple(_parse_route(read, entry, k, bounds, racks) for k, entry in enumerate(
        _array_of_tables(read, data, "routes")))
    names = [route.name for route in routes]
    for k, route_name in enumerate(names):
        if route_name in names[:k]:
            raise read.fail(f"routes[{k}].name", f"duplicate route name {route_name!r}")
    return Scenario(name=name, description=description, version=version,
                    bounds=(bounds[0], bounds[1], bounds[2], bounds[3]), beacons=beacons,
                    error_model=error_model, racks=racks, walls=walls, routes=routes,
                    bumps=tuple(_parse_bump(read, entry, k) for k, entry in enumerate(
                        _array_of_tables(read, data, "bumps"))),
                    fisheye=_parse_fisheye(read, data.get("fisheye", {})),
                    lights=tuple(_parse_light(read, entry, k, racks) for k, entry in enumerate(
                        _array_of_tables(read, data, "lights"))),
                    camera=_parse_camera(read, data.get("camera", {})),
                    faults=_parse_faults(read, data.get("faults", {})),
                    physical_xyz=None if np.array_equal(physical_xyz, beacons.xyz)
                    else physical_xyz)


def _array_of_tables(read: _Reader, data: dict[str, Any], key: str) -> list[dict[str, Any]]:
    entries = data.get(key, [])
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise read.fail(key, f"must be an array of [[{key}]] tables")
    return entries


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


def _parse_rack(read: _Reader, entry: dict[str, Any], k: int) -> Rack:
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


def _parse_route(read: _Reader, entry: dict[str, Any], k: int, bounds: list[float],
                 racks: tuple[Rack, ...]) -> Route:
    where = f"routes[{k}]."
    read.keys(entry, _ROUTE_KEYS, where)
    name = read.text(read.require(entry, "name", where), f"{where}name")
    raw = read.require(entry, "waypoints", where)
    if not isinstance(raw, list) or len(raw) < 2:
        raise read.fail(f"{where}waypoints", "must be a list of at least 2 [x, y] points")
    points = np.array([read.vector(p, f"{where}waypoints[{i}]", 2) for i, p in enumerate(raw)])
    for i, (x, y) in enumerate(points):
        if not (bounds[0] <= x <= bounds[2] and bounds[1] <= y <= bounds[3]):
            raise read.fail(f"{where}waypoints[{i}]", f"({x:g}, {y:g}) is outside the room")
    reverse = entry.get("reverse", [False] * (len(points) - 1))
    if not (isinstance(reverse, list) and len(reverse) == len(points) - 1
            and all(isinstance(r, bool) for r in reverse)):
        raise read.fail(f"{where}reverse",
                        f"must be a list of {len(points) - 1} booleans, one per leg")
    for leg in range(len(points) - 1):
        for r, rack in enumerate(racks):
            if leg_hits_rack(points[leg], points[leg + 1], rack, ROUTE_CLEARANCE):
                raise read.fail(
                    f"{where}waypoints",
                    f"leg {leg} from ({points[leg][0]:g}, {points[leg][1]:g}) to "
                    f"({points[leg + 1][0]:g}, {points[leg + 1][1]:g}) passes within "
                    f"{ROUTE_CLEARANCE} m of racks[{r}]")
    speed = read.number(entry.get("speed", 1.5), f"{where}speed", positive=True)
    return Route(name=name, waypoints=points, reverse=tuple(reverse), speed=speed)


def _parse_bump(read: _Reader, entry: dict[str, Any], k: int) -> Bump:
    where = f"bumps[{k}]."
    read.keys(entry, _BUMP_KEYS, where)
    center, size = _footprint(read, entry, where)
    tilt = read.number(read.require(entry, "tilt_deg", where), f"{where}tilt_deg",
                       non_negative=True)
    if tilt >= 45.0:
        raise read.fail(f"{where}tilt_deg", f"must be < 45, got {tilt}")
    return Bump(center=(center[0], center[1]), size=(size[0], size[1]),
                tilt=math.radians(tilt))


def _parse_light(read: _Reader, entry: dict[str, Any], k: int,
                 racks: tuple[Rack, ...]) -> Light:
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
    if not isinstance(table, dict):
        raise read.fail("fisheye", "must be a table")
    read.keys(table, _FISHEYE_KEYS, "fisheye.")
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


def _reflectivity(read: _Reader, entry: dict[str, Any], where: str) -> float:
    value = read.number(entry.get("reflectivity", 0.0), f"{where}reflectivity", non_negative=True)
    if value > 1.0:
        raise read.fail(f"{where}reflectivity", f"must be in [0, 1], got {value}")
    return value


def _parse_camera(read: _Reader, table: Any) -> Camera:
    if not isinstance(table, dict):
        raise read.fail("camera", "must be a table")
    read.keys(table, _CAMERA_KEYS, "camera.")
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
    if not isinstance(table, dict):
        raise read.fail("faults", "must be a table")
    read.keys(table, _FAULT_KEYS, "faults.")
    rate = read.number(table.get("misdecode_rate", 0.0), "faults.misdecode_rate",
                       non_negative=True)
    if rate > 1.0:
        raise read.fail("faults.misdecode_rate", f"must be in [0, 1], got {rate}")
    return Faults(misdecode_rate=rate)


def _parse_error_model(read: _Reader, table: Any) -> ErrorModel:
    if not isinstance(table, dict):
        raise read.fail("error_model", "must be a table")
    read.keys(table, _ERROR_KEYS, "error_model.")
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
                          non_negative=True)
    if degrees >= 90.0:
        raise read.fail("error_model.delta_alpha_d_deg", f"must be < 90, got {degrees}")
    return ErrorModel(delta_alpha_d=math.radians(degrees), coverage=coverage)
