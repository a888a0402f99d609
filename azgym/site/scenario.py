"""The scenario model: a site's room, beacons, racks, walls, routes, lights and cameras.

A :class:`Scenario` is immutable and always valid: it is built by :func:`azgym.site.parse.
parse_scenario` (from TOML data, every field checked) or by ``dataclasses.replace`` on one.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from azgym.core import BeaconMap, FloatArray
from azgym.profile import DIFFERENTIAL_DRIVE, Profile, SensorProfile, VehicleProfile
from azgym.site.elements import Bump, Camera, Faults, Light, Rack, Route, Vehicle, Wall
from azgym.site.error_model import ErrorModel
from azgym.site.fisheye import FisheyeCamera

__all__ = ["Scenario"]


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
        vehicle: What drives the routes (a forklift, or a differential-drive robot).
        unmapped: Coded markers the camera reads whose codes the map lacks (another robot's
            tag, a marker never surveyed), or None; their detections are labelled distractors.
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
    vehicle: Vehicle = Vehicle()
    unmapped: BeaconMap | None = None
    source: Path | None = None

    @property
    def differential_drive(self) -> bool:
        """Whether a differential-drive robot drives the routes (else a forklift)."""
        return self.vehicle.kind == DIFFERENTIAL_DRIVE

    @property
    def profile(self) -> Profile:
        """The vehicle and sensor this scenario simulates, as a log's manifest states them.

        The vehicle's kind and camera offset (a forklift's offset is its model's, left out), and
        the camera's eq. 1 half-width Δα_d, coverage error and field of view. The motion
        sensors' errors are the models' of :mod:`azgym.sensing.motion`, not the scenario's.
        """
        return Profile(
            vehicle=VehicleProfile(kind=self.vehicle.kind, camera_ahead=self.vehicle.camera_ahead),
            sensor=SensorProfile(delta_alpha_d=self.error_model.delta_alpha_d,
                                 coverage=self.error_model.coverage,
                                 field_of_view=self.camera.field_of_view))

    @property
    def beacon_positions(self) -> FloatArray:
        """Where the beacons physically are, shape (N, 3) [m].

        The map's positions, except for beacons moved after the map was made (``moved_to``).
        """
        return self.beacons.xyz if self.physical_xyz is None else self.physical_xyz

