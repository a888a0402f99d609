"""The frame source: drive a scenario's route and yield what the vehicle's sensors saw, per frame.

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

A scenario whose vehicle is a differential-drive robot is driven by :mod:`azgym.world.robot`
instead: a unicycle, odometry of speed and turn rate at a logger's irregular stamps
(:class:`~azgym.sensing.motion.DifferentialOdometryModel`), no IMU unless one is given, a level
camera ``camera_ahead`` of the turning axis.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import TypeVar

import numpy as np

from azgym.core import Measurements, Pose
from azgym.errors import InvalidInputError, unknown_name
from azgym.sensing.geometry.sensor import GeometrySensor
from azgym.sensing.motion import (
    DifferentialOdometryModel,
    ImuModel,
    ImuSamples,
    Motion,
    OdometryModel,
    OdometrySamples,
)
from azgym.sensing.protocol import LEVEL, DetectionTruth, Observation, Sensor, Tilt
from azgym.site import Scenario, load_scenario
from azgym.site.elements import CAMERA_RATES_HZ, Route
from azgym.world.driver import PurePursuit
from azgym.world.forklift import ForkliftSpec
from azgym.world.motion_sensors import MotionSensors, RobotMotionSensors
from azgym.world.robot import Robot, RobotDriver, RobotSpec
from azgym.world.sway import CameraSway
from azgym.world.world import World

__all__ = ["Frame", "camera_trajectory", "checked_camera_rate", "motion_models", "simulate"]


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


STOPPED_SPEED = 0.05
"""Below this speed [m/s] a vehicle at the end of its route has stopped: the drive is over."""
FRAME_TIME_TOLERANCE = 1e-9
"""A physics step ending this close before a frame's time [s] takes the frame (rounding)."""
FORKLIFT_DEFAULTS = (0.02, 600.0)
"""A forklift's physics step and a drive's time limit [s]."""
ROBOT_DEFAULTS = (0.01, 1800.0)
"""A robot's step (its odometry's nominal interval) and a drive's time limit [s]: the real
recordings it follows are 15 min long."""


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


def _robot_frames(scenario: Scenario, route: Route, camera_rate_hz: float, dt: float,
                  spec: RobotSpec | None, max_time: float,
                  on_step: Callable[[Robot], None] | None = None) -> Iterator[Robot]:
    """Like :func:`_frames`, for a differential-drive robot: the robot at every frame time.

    ``on_step`` sees the robot after every step. The drive ends at the frame after the robot
    has stopped at the route's end, or after ``max_time``.
    """
    robot = Robot(route.start_pose(), spec or RobotSpec(), dt,
                  scenario.vehicle.robot_camera_ahead)
    driver = RobotDriver(route, robot.spec)
    period = 1.0 / checked_camera_rate(camera_rate_hz)
    next_frame = 0.0
    while True:
        if robot.time + FRAME_TIME_TOLERANCE >= next_frame:
            done = driver.done and abs(robot.speed) < STOPPED_SPEED
            yield robot
            next_frame += period
            if done or robot.time > max_time:
                return
        robot.step(*driver.command(*robot.pose))
        if on_step is not None:
            on_step(robot)


def _camera_pose(world: World) -> Pose:
    return world.forklift.camera_pose_at(world.forklift.pose)


_Part = TypeVar("_Part")


def _vehicle_part(scenario: Scenario, name: str, what: str, value: object,
                  wanted: type[_Part]) -> _Part | None:
    """``value`` (None: the default) if it is a ``wanted``, the scenario's vehicle's kind.

    Raises:
        InvalidInputError: A part of the other vehicle (a spec or an odometry model).
    """
    if value is not None and not isinstance(value, wanted):
        raise InvalidInputError(f"{name}: scenario {scenario.name!r} is driven by a "
                                f"{scenario.vehicle.kind}, whose {what} is a {wanted.__name__}, "
                                f"got {type(value).__name__}")
    return value


def _checked_sensor(scenario: Scenario, sensor: Sensor | None) -> Sensor:
    """The camera model: ``sensor``, or the scenario's geometry sensor; refusing a non-Sensor."""
    sensor = GeometrySensor(scenario) if sensor is None else sensor
    if not isinstance(sensor, Sensor):
        raise InvalidInputError(f"sensor must be an azgym Sensor (reset and observe), got "
                                f"{type(sensor).__name__}; make one with "
                                f"azgym.sensing.catalog.make_sensor")
    return sensor


def _defaults(scenario: Scenario, dt: float | None, max_time: float | None
              ) -> tuple[float, float]:
    """The physics step and time limit [s]: the given ones, else the vehicle's defaults."""
    step, limit = ROBOT_DEFAULTS if scenario.differential_drive else FORKLIFT_DEFAULTS
    dt = step if dt is None else dt
    if not (isinstance(dt, numbers.Real) and math.isfinite(dt) and dt > 0):
        raise InvalidInputError(f"dt must be > 0 [s], got {dt!r}")
    return float(dt), limit if max_time is None else max_time


def camera_trajectory(scenario: Scenario, route: Route, camera_rate_hz: float = 10.0,
                      dt: float | None = None, spec: ForkliftSpec | RobotSpec | None = None,
                      max_time: float | None = None) -> np.ndarray:
    """The camera pose (x, y, heading) at each frame of a route, shape (F, 3).

    The drive is deterministic (no random draw), the same for every seed; ``simulate`` adds the
    sensors along it.
    """
    if scenario.differential_drive:
        robot_spec = _vehicle_part(scenario, "spec", "spec", spec, RobotSpec)
        dt, max_time = _defaults(scenario, dt, max_time)
        return np.array([robot.camera_pose() for robot in _robot_frames(
            scenario, route, camera_rate_hz, dt, robot_spec, max_time)])
    forklift_spec = _vehicle_part(scenario, "spec", "spec", spec, ForkliftSpec)
    dt, max_time = _defaults(scenario, dt, max_time)
    return np.array([_camera_pose(world) for world in _frames(
        scenario, route, camera_rate_hz, dt, forklift_spec, max_time)])


def motion_models(scenario: Scenario, rate_hz: float | None = None
                  ) -> tuple[OdometryModel | DifferentialOdometryModel, ImuModel | None]:
    """The scenario's vehicle's default odometry and IMU models (None: no IMU).

    A forklift's: :class:`OdometryModel` and :class:`ImuModel`; a differential-drive robot's:
    :class:`DifferentialOdometryModel` and no IMU. ``rate_hz`` [Hz] sets the odometry's (and
    IMU's) rate: a robot's nominal interval becomes 1 / ``rate_hz``, its jitter scaled alike.
    """
    if scenario.differential_drive:
        return _robot_odometry(rate_hz), None
    return _forklift_models(rate_hz)


def _robot_odometry(rate_hz: float | None = None) -> DifferentialOdometryModel:
    """A robot's default odometry (see :func:`motion_models`)."""
    robot = DifferentialOdometryModel()
    if rate_hz is None:
        return robot
    scale = 1.0 / (rate_hz * robot.period)
    return dataclasses.replace(robot, period=robot.period * scale,
                               period_jitter=robot.period_jitter * scale)


def _forklift_models(rate_hz: float | None = None) -> tuple[OdometryModel, ImuModel]:
    """A forklift's default odometry and IMU (see :func:`motion_models`)."""
    odometry, imu = OdometryModel(), ImuModel()
    if rate_hz is None:
        return odometry, imu
    return (dataclasses.replace(odometry, rate_hz=rate_hz),
            dataclasses.replace(imu, rate_hz=rate_hz))


_Moment = tuple[float, Pose, Tilt, OdometrySamples, ImuSamples, int]
"""What the vehicle did up to a frame: time, camera pose, tilt, motion samples, new contacts."""


def _forklift_moments(spec: ForkliftSpec | None, odometry: OdometryModel | None,
                      imu: ImuModel | None, scenario: Scenario, route: Route,
                      camera_rate_hz: float, dt: float, max_time: float,
                      rngs: list[np.random.Generator]) -> Iterator[_Moment]:
    """The forklift's frames: pymunk, its odometry and IMU, the mast's sway on bumps."""
    odometry_rng, imu_rng, sway_rng = rngs
    default_odometry, default_imu = _forklift_models()
    motion = MotionSensors(odometry or default_odometry, imu or default_imu,
                           odometry_rng, imu_rng, dt)
    sway = CameraSway(scenario, 1.0 / camera_rate_hz, spec)
    contacts_seen = 0
    for world in _frames(scenario, route, camera_rate_hz, dt, spec, max_time,
                         on_step=motion.step):
        pose = _camera_pose(world)
        tilt = sway.step(pose[0], pose[1], sway_rng)
        yield (world.time, pose, tilt, *motion.take(), len(world.contacts) - contacts_seen)
        contacts_seen = len(world.contacts)


def _robot_moments(spec: RobotSpec | None, odometry: DifferentialOdometryModel | None,
                   imu: ImuModel | None, scenario: Scenario, route: Route,
                   camera_rate_hz: float, dt: float, max_time: float,
                   rngs: list[np.random.Generator]) -> Iterator[_Moment]:
    """The robot's frames: the unicycle, its odometry (and IMU if asked for); a level camera."""
    odometry_rng, imu_rng, _ = rngs
    motion = RobotMotionSensors(odometry or _robot_odometry(), imu, odometry_rng, imu_rng)
    for robot in _robot_frames(scenario, route, camera_rate_hz, dt, spec, max_time,
                               on_step=motion.step):
        yield (robot.time, robot.camera_pose(), LEVEL, *motion.take(robot.time), 0)


_Drive = Callable[[Scenario, Route, float, float, float, list[np.random.Generator]],
                  Iterator[_Moment]]
"""A vehicle's moments, parts bound: (scenario, route, camera rate, dt, time limit, rngs)."""


def _vehicle_moments(scenario: Scenario, spec: ForkliftSpec | RobotSpec | None,
                     odometry: OdometryModel | DifferentialOdometryModel | None,
                     imu: ImuModel | None) -> _Drive:
    """The scenario's vehicle's moments, refusing a spec or odometry of the other vehicle."""
    if scenario.differential_drive:
        return functools.partial(
            _robot_moments, _vehicle_part(scenario, "spec", "spec", spec, RobotSpec),
            _vehicle_part(scenario, "odometry", "odometry model", odometry,
                          DifferentialOdometryModel), imu)
    return functools.partial(
        _forklift_moments, _vehicle_part(scenario, "spec", "spec", spec, ForkliftSpec),
        _vehicle_part(scenario, "odometry", "odometry model", odometry, OdometryModel), imu)


def simulate(
    scenario: Scenario | str,
    route: str | Route | None = None,
    seed: int | Sequence[int] = 0,
    *,
    sensor: Sensor | None = None,
    camera_rate_hz: float | None = None,
    dt: float | None = None,
    spec: ForkliftSpec | RobotSpec | None = None,
    odometry: OdometryModel | DifferentialOdometryModel | None = None,
    imu: ImuModel | None = None,
    max_time: float | None = None,
) -> Iterator[Frame]:
    """Drive ``route`` through ``scenario`` and yield a :class:`Frame` per camera frame.

    The scenario's vehicle drives: a forklift (pymunk, wheel odometry of speed and steering
    angle, an IMU, a swaying mast) or a differential-drive robot (a unicycle, odometry of speed
    and turn rate at a logger's irregular stamps, no IMU unless ``imu`` is given, a level
    camera).

    Args:
        scenario: The scenario or its name.
        route: The route's name or the route (default: the scenario's first route).
        seed: Seed of every random draw.
        sensor: The camera model (default: a :class:`GeometrySensor` of the scenario); it is
            reset here, from its own stream of the seed.
        camera_rate_hz: Camera frames per second (default: the sensor's ``frame_rate_hz``: the
            scenario camera's rate, or 30 Hz for blinking ids).
        dt: Physics step [s] (default: 0.02 for a forklift, 0.01 for a robot).
        spec: The vehicle (default: :class:`ForkliftSpec` or :class:`RobotSpec`).
        odometry: Wheel odometry errors (default: :class:`OdometryModel` for a forklift,
            :class:`DifferentialOdometryModel` for a robot).
        imu: IMU errors (default: :class:`ImuModel` for a forklift, none for a robot).
        max_time: Stop after this much simulated time even if the route is not finished [s]
            (default: 600 for a forklift, 1800 for a robot).

    Raises:
        InvalidInputError: A sensor, spec or odometry model that does not fit the scenario.
    """
    scenario = load_scenario(scenario)
    chosen = _route(scenario, route)
    sensor = _checked_sensor(scenario, sensor)
    drive = _vehicle_moments(scenario, spec, odometry, imu)
    dt, max_time = _defaults(scenario, dt, max_time)
    camera_rate_hz = checked_camera_rate(
        sensor.frame_rate_hz if camera_rate_hz is None else camera_rate_hz)
    streams = np.random.SeedSequence(seed).spawn(5)
    camera_rng, *rngs = (np.random.default_rng(stream) for stream in streams[:4])
    sensor.reset(streams[4])
    moments = drive(scenario, chosen, camera_rate_hz, dt, max_time, rngs)
    for index, (time, pose, tilt, odometry_samples, imu_samples, contacts) in enumerate(moments):
        observation = sensor.observe(pose, camera_rng, tilt)
        yield Frame(index=index, time=time, observation=observation, pose=pose,
                    odometry=odometry_samples, imu=imu_samples, contacts=contacts)
