"""Scenario files' contents, validated: parsed TOML data in, a :class:`Scenario` out.

Every problem is reported with the file, the field and what is wrong, e.g.
``paper-room.toml: beacons[3].width: must be > 0, got -0.01``.

This module holds the file's top level: which tables it may have, its name, description,
version and ``[room]``, and the order in which the tables are read (so a file with several
problems always reports the same one first). The tables themselves are read by
:mod:`azgym.site.parse_layout` (what is on the floor) and :mod:`azgym.site.parse_sensor` (the
camera), with the field-level checks and messages of :mod:`azgym.site.reader`.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from azgym.profile import DIFFERENTIAL_DRIVE, FORKLIFT, VEHICLE_KINDS
from azgym.site.elements import Route, Vehicle
from azgym.site.parse_layout import (
    Obstacles,
    check_beacons_outside_racks,
    check_route_names_unique,
    parse_beacons,
    parse_bump,
    parse_light,
    parse_rack,
    parse_route,
    parse_unmapped,
    parse_wall,
)
from azgym.site.parse_sensor import parse_camera, parse_error_model, parse_faults, parse_fisheye
from azgym.site.reader import Reader, parse_tables, shown
from azgym.site.scenario import Scenario

__all__ = ["parse_scenario"]

_TOP_KEYS = {"name", "description", "version", "room", "error_model", "beacon_defaults",
             "beacons", "camera", "faults", "racks", "walls", "routes",
             "bumps", "fisheye", "lights", "vehicle", "unmapped"}
_ROOM_KEYS = {"bounds"}
_VEHICLE_KEYS = {"kind", "camera_ahead"}
MAX_CAMERA_AHEAD = 10.0
"""The farthest a camera may sit from the turning axis [m] (a profile's bound)."""


def parse_scenario(data: dict[str, Any], origin: str = "<scenario>") -> Scenario:
    """Build a :class:`Scenario` from parsed TOML, validating every field.

    The sections are read in a fixed order, so a file with several problems always reports the
    same one first.

    Raises:
        ScenarioError: Naming the origin, the field and the problem.
    """
    read = Reader(origin)
    read.keys(data, _TOP_KEYS, "")
    name = read.name(read.require(data, "name"), "name")
    description = read.text(read.require(data, "description"), "description")
    version = read.integer(read.require(data, "version"), "version", minimum=1)
    bounds = _parse_room(read, data)
    vehicle = _parse_vehicle(read, data.get("vehicle", {}))
    error_model = parse_error_model(read, data.get("error_model", {}))
    beacons, physical_xyz = parse_beacons(read, data, bounds)
    racks = parse_tables(read, data, "racks", parse_rack)
    walls = parse_tables(read, data, "walls", parse_wall)
    check_beacons_outside_racks(read, beacons.ids, physical_xyz, racks)
    unmapped = parse_unmapped(read, data, bounds, beacons)
    if unmapped is not None:
        check_beacons_outside_racks(read, unmapped.ids, unmapped.xyz, racks, "unmapped")
    routes = parse_tables(read, data, "routes",
                          functools.partial(parse_route, bounds=bounds,
                                            obstacles=Obstacles(racks, walls)))
    check_route_names_unique(read, routes)
    if vehicle.kind == DIFFERENTIAL_DRIVE:
        _check_forwards(read, routes)
    return Scenario(name=name, description=description, version=version, bounds=bounds,
                    beacons=beacons, error_model=error_model, racks=racks, walls=walls,
                    routes=routes, bumps=parse_tables(read, data, "bumps", parse_bump),
                    fisheye=parse_fisheye(read, data.get("fisheye", {})),
                    lights=parse_tables(read, data, "lights",
                                        functools.partial(parse_light, racks=racks)),
                    camera=parse_camera(read, data.get("camera", {})),
                    faults=parse_faults(read, data.get("faults", {})),
                    physical_xyz=None if np.array_equal(physical_xyz, beacons.xyz)
                    else physical_xyz, vehicle=vehicle, unmapped=unmapped)


def _parse_vehicle(read: Reader, table: Any) -> Vehicle:
    """The ``[vehicle]`` table: its ``kind`` and, for a differential drive, ``camera_ahead``.

    Without the table, a forklift. A differential drive's camera sits ``camera_ahead`` metres
    ahead of its turning axis (default 0: on it); a forklift's sits where its model puts it.
    """
    read.table(table, "vehicle", _VEHICLE_KEYS)
    kind = table.get("kind", FORKLIFT)
    if kind not in VEHICLE_KINDS:
        raise read.fail("vehicle.kind", f"must be one of {', '.join(map(repr, VEHICLE_KINDS))}, "
                        f"got {shown(kind)}")
    if kind == FORKLIFT:
        if "camera_ahead" in table:
            raise read.fail("vehicle.camera_ahead", "a forklift's camera sits where its model "
                            "puts it; camera_ahead is for a differential-drive robot")
        return Vehicle(kind)
    return Vehicle(kind, read.number(table.get("camera_ahead", 0.0), "vehicle.camera_ahead",
                                     maximum=MAX_CAMERA_AHEAD))


def _check_forwards(read: Reader, routes: tuple[Route, ...]) -> None:
    """Reject a reversed leg: a differential-drive robot drives its routes forwards."""
    for k, route in enumerate(routes):
        if any(route.reverse):
            leg = route.reverse.index(True)
            raise read.fail(f"routes[{k}].reverse[{leg}]", "a differential-drive robot drives "
                            "its routes forwards (it turns on the spot instead of reversing)")


def _parse_room(read: Reader, data: dict[str, Any]) -> tuple[float, float, float, float]:
    """The ``[room]`` table's ``bounds`` = [x_min, y_min, x_max, y_max] [m]."""
    room = read.table(read.require(data, "room"), "room", _ROOM_KEYS)
    bounds = read.vector(read.require(room, "bounds", "room."), "room.bounds", 4)
    if bounds[2] <= bounds[0] or bounds[3] <= bounds[1]:
        raise read.fail("room.bounds", f"must be [x_min, y_min, x_max, y_max] with max > min, "
                        f"got {bounds}")
    return bounds[0], bounds[1], bounds[2], bounds[3]
