"""The scenario model: a site's room, beacons, racks, walls, routes, lights and cameras.

A :class:`Scenario` is immutable and always valid: it is built by :func:`azgym.site.parse.
parse_scenario` (from TOML data, every field checked) or by ``dataclasses.replace`` on one.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from azgym.core import BeaconMap, FloatArray
from azgym.site.elements import Bump, Camera, Faults, Light, Rack, Route, Wall
from azgym.site.error_model import ErrorModel
from azgym.site.fisheye import FisheyeCamera


@dataclass(frozen=True)
class Scenario:
    """A site: room bounds, beacon map and camera error model.

    Attributes:
        name: Identifier, also the file's stem.
        description: One line for listings.
        version: Bumped whenever the scenario changes what it simulates.
        bounds: (x_min, y_min, x_max, y_max) of the room [m].
        beacons: The beacon map.
        error_model: The camera's azimuth error model (eq. 1-3).
        racks: Shelf racks (occluders, mirrors if reflective).
        walls: Walls (occluders, mirrors if reflective).
        camera: The camera on the forklift (height, elevation limit, range).
        faults: Decoding faults (the misread rate of ids="oracle").
        routes: Routes the forklift drives.
        bumps: Bumpy stretches where the camera sways.
        fisheye: The fisheye's intrinsics, for the image path.
        lights: Lights that are not beacons (lamps, windows): distractors on the image.
        physical_xyz: Where the beacons really are, if some were moved after mapping.
        source: The file it was loaded from.
    """

    name: str
    description: str
    version: int
    bounds: tuple[float, float, float, float]
    beacons: BeaconMap
    error_model: ErrorModel
    racks: tuple[Rack, ...] = ()
    walls: tuple[Wall, ...] = ()
    camera: Camera = Camera()
    faults: Faults = Faults()
    routes: tuple[Route, ...] = ()
    bumps: tuple[Bump, ...] = ()
    fisheye: FisheyeCamera = FisheyeCamera()
    lights: tuple[Light, ...] = ()
    physical_xyz: FloatArray | None = None
    source: Path | None = None

    @property
    def beacon_positions(self) -> FloatArray:
        """Where the beacons physically are, shape (N, 3) [m].

        The map's positions, except for beacons moved after the map was made (``moved_to``).
        """
        return self.beacons.xyz if self.physical_xyz is None else self.physical_xyz

