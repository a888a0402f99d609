"""The frame source: drive a scenario's route and yield what the forklift's sensors saw, per frame.

``simulate(scenario, route, seed)`` runs the world (pymunk physics at ``dt``), the pure-pursuit
driver, wheel odometry and the IMU at their own rates, and the camera at ``camera_rate_hz``
through any :class:`~azgym.sensing.protocol.Sensor` (the geometry sensor by default, or the
fisheye image sensor). Each :class:`Frame` holds the camera's observation (measurements with
their ground truth beside them), the odometry and IMU samples since the previous frame, and the
true camera pose. The same seed gives the same frames, bit for bit: one seed is split into
independent streams for the camera's frames, the odometry, the IMU, the camera's sway on bumpy
stretches and the sensor's own sequence (its ``reset``), so that changing one sensor's settings
leaves the others' draws alone. On a bump the camera sways (:class:`~azgym.world.sway.CameraSway`:
a damped mast that the bumps shake, so consecutive frames see nearly the same tilt).
"""

from __future__ import annotations

import numbers
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from azgym.core import Measurements, Pose
from azgym.errors import InvalidInputError, unknown_name
from azgym.sensing.geometry.sensor import GeometrySensor
from azgym.sensing.motion import ImuModel, ImuSamples, Motion, OdometryModel, OdometrySamples
from azgym.sensing.protocol import DetectionTruth, Observation, Sensor
from azgym.site import Scenario, load_scenario
from azgym.site.elements import Route
from azgym.world.driver import PurePursuit
from azgym.world.forklift import ForkliftSpec
from azgym.world.motion_sensors import MotionSensors
from azgym.world.sway import CameraSway
from azgym.world.world import World


@dataclass(frozen=True, eq=False)
class Frame:
    """One camera frame and everything that happened since the previous one.

    Attributes:
        index: Frame number, from 0.
        time: Simulated time [s].
        observation: What the camera saw: its detections, their ground truth, the image.
        pose: True camera pose (x, y, heading) [m, m, rad].
        odometry: Wheel odometry samples since the previous frame.
        imu: IMU samples since the previous frame.
        contacts: Collisions recorded since the previous frame.
    """

    index: int
    time: float
    observation: Observation
    pose: Pose
    odometry: OdometrySamples
    imu: ImuSamples
    contacts: int

    @property
    def measurements(self) -> Measurements:
        """The camera's detections."""
        return self.observation.measurements

    @property
    def motion(self) -> Motion:
        """The odometry and IMU samples since the previous frame, up to this frame's time."""
        return Motion(self.time, self.odometry, self.imu)

    @property
    def truth(self) -> DetectionTruth:
        """Their ground truth (labels, true beacons, noise-free azimuths)."""
        return self.observation.truth


def _route(scenario: Scenario, route: str | Route | None) -> Route:
    if isinstance(route, Route):
        return route
    if not scenario.routes:
        raise InvalidInputError(f"scenario {scenario.name!r} has no routes to drive")
    if route is None:
        return scenario.routes[0]
    names = {r.name: r for r in scenario.routes}
    if route not in names:
        raise unknown_name("route", str(route), names)
    return names[route]


CAMERA_RATES_HZ = (0.1, 1000.0)
"""The camera frame rates azgym accepts [Hz]: slower would leave a route without frames (and
take forever to reach the next one), faster is no camera."""
STOPPED_SPEED = 0.05
"""Below this speed [m/s] a forklift at the end of its route has stopped: the drive is over."""
FRAME_TIME_TOLERANCE = 1e-9
"""A physics step ending this close before a frame's time [s] takes the frame (rounding)."""


def checked_camera_rate(camera_rate_hz: float) -> float:
    """``camera_rate_hz`` as a float, refusing a value outside ``CAMERA_RATES_HZ``."""
    low, high = CAMERA_RATES_HZ
    if (isinstance(camera_rate_hz, bool) or not isinstance(camera_rate_hz, numbers.Real)
            or not low <= camera_rate_hz <= high):
        raise InvalidInputError(f"camera_rate_hz must be a finite number > 0 [Hz] from {low} "
                                f"to {high}, got {camera_rate_hz!r}")
    return float(camera_rate_hz)


def _frames(scenario: Scenario, route: Route, camera_rate_hz: float, dt: float,
            spec: ForkliftSpec | None, max_time: float,
            on_step: Callable[[World], None] | None = None) -> Iterator[World]:
    """Drive the route; yield the world at every camera frame time k / ``camera_rate_hz``.

    ``on_step`` sees the world after every physics step (and at the start). The drive ends at
    the frame after the forklift has stopped at the route's end, or after ``max_time``.
    """
    if not dt > 0:
        raise InvalidInputError(f"dt must be > 0 [s], got {dt}")
    world = World(scenario, route.start_pose(), spec, dt)
    forklift = world.forklift
    driver = PurePursuit(route, forklift.spec)
    period = 1.0 / checked_camera_rate(camera_rate_hz)
    next_frame = 0.0
    while True:
        if on_step is not None:
            on_step(world)
        if world.time + FRAME_TIME_TOLERANCE >= next_frame:
            done = driver.done and abs(forklift.speed) < STOPPED_SPEED
            yield world
            next_frame += period
            if done or world.time > max_time:
                return
        x, y, heading = forklift.pose
        world.step(*driver.command(x, y, heading, forklift.speed))


def _camera_pose(world: World) -> Pose:
    x, y = world.forklift.camera_position()
    return x, y, world.forklift.pose[2]


def camera_trajectory(scenario: Scenario, route: Route, camera_rate_hz: float = 10.0,
                      dt: float = 0.02, spec: ForkliftSpec | None = None,
                      max_time: float = 600.0) -> np.ndarray:
    """The camera pose (x, y, heading) at each frame of a route, shape (F, 3).

    The drive is deterministic (no random draw), the same for every seed; ``simulate`` adds the
    sensors along it.
    """
    return np.array([_camera_pose(world) for world in _frames(
        scenario, route, camera_rate_hz, dt, spec, max_time)])


def simulate(
    scenario: Scenario | str,
    route: str | Route | None = None,
    seed: int | Sequence[int] = 0,
    *,
    sensor: Sensor | None = None,
    camera_rate_hz: float | None = None,
    dt: float = 0.02,
    spec: ForkliftSpec | None = None,
    odometry: OdometryModel | None = None,
    imu: ImuModel | None = None,
    max_time: float = 600.0,
) -> Iterator[Frame]:
    """Drive ``route`` through ``scenario`` and yield a :class:`Frame` per camera frame.

    Args:
        scenario: The scenario or its name.
        route: The route's name or the route (default: the scenario's first route).
        seed: Seed of every random draw.
        sensor: The camera model (default: a :class:`GeometrySensor` of the scenario); it is
            reset here, from its own stream of the seed.
        camera_rate_hz: Camera frames per second (default: the sensor's ``frame_rate_hz``,
            10 Hz, or 30 Hz for blinking ids).
        dt: Physics step [s].
        spec: The forklift (default: :class:`ForkliftSpec`).
        odometry: Wheel odometry errors (default: :class:`OdometryModel`).
        imu: IMU errors (default: :class:`ImuModel`).
        max_time: Stop after this much simulated time even if the route is not finished [s].
    """
    scenario = load_scenario(scenario)
    chosen = _route(scenario, route)
    sensor = GeometrySensor(scenario) if sensor is None else sensor
    if not isinstance(sensor, Sensor):
        raise InvalidInputError(f"sensor must be an azgym Sensor (reset and observe), got "
                                f"{type(sensor).__name__}; make one with "
                                f"azgym.sensing.catalog.make_sensor")
    camera_rate_hz = checked_camera_rate(
        sensor.frame_rate_hz if camera_rate_hz is None else camera_rate_hz)
    streams = np.random.SeedSequence(seed).spawn(5)
    camera_rng, odometry_rng, imu_rng, sway_rng = (
        np.random.default_rng(stream) for stream in streams[:4])
    sensor.reset(streams[4])
    motion = MotionSensors(odometry or OdometryModel(), imu or ImuModel(), odometry_rng, imu_rng,
                           dt)
    sway = CameraSway(scenario, 1.0 / camera_rate_hz, spec)
    contacts_seen = 0
    for index, world in enumerate(_frames(scenario, chosen, camera_rate_hz, dt, spec, max_time,
                                          on_step=motion.step)):
        pose = _camera_pose(world)
        tilt = sway.step(pose[0], pose[1], sway_rng)
        odometry_samples, imu_samples = motion.take()
        observation = sensor.observe(pose, camera_rng, tilt)
        yield Frame(index=index, time=world.time, observation=observation, pose=pose,
                    odometry=odometry_samples, imu=imu_samples,
                    contacts=len(world.contacts) - contacts_seen)
        contacts_seen = len(world.contacts)
