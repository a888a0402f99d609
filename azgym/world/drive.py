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

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from azgym.core import Measurements, Pose
from azgym.errors import InvalidInputError, unknown_name
from azgym.sensing.geometry.sensor import GeometrySensor
from azgym.sensing.motion import (
    Imu,
    ImuModel,
    ImuSamples,
    Odometer,
    OdometryModel,
    OdometrySamples,
)
from azgym.sensing.protocol import DetectionTruth, Observation, Sensor
from azgym.site import Scenario, load_scenario
from azgym.site.elements import Route
from azgym.world.driver import PurePursuit
from azgym.world.forklift import ForkliftSpec
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


def _drive(scenario: Scenario, route: Route, dt: float,
           spec: ForkliftSpec | None) -> Iterator[tuple[World, bool]]:
    """Step the world along the route: yields (world, route done) before each physics step."""
    world = World(scenario, route.start_pose(), spec, dt)
    forklift = world.forklift
    driver = PurePursuit(route, forklift.spec)
    while True:
        yield world, driver.done and abs(forklift.speed) < 0.05
        x, y, heading = forklift.pose
        world.step(*driver.command(x, y, heading, forklift.speed))


def camera_trajectory(scenario: Scenario, route: Route, camera_rate_hz: float = 10.0,
                      dt: float = 0.02, spec: ForkliftSpec | None = None,
                      max_time: float = 600.0) -> np.ndarray:
    """The camera pose (x, y, heading) at each frame of a route, shape (F, 3).

    The drive is deterministic (no random draw), the same for every seed; ``simulate`` adds the
    sensors along it.
    """
    poses = []
    next_frame = 0.0
    for world, done in _drive(scenario, route, dt, spec):
        if world.time + 1e-9 >= next_frame:
            poses.append((*world.forklift.camera_position(), world.forklift.pose[2]))
            next_frame += 1.0 / camera_rate_hz
            if done or world.time > max_time:
                break
    return np.array(poses)


def simulate(
    scenario: Scenario | str,
    route: str | Route | None = None,
    seed: int | Sequence[int] = 0,
    *,
    sensor: Sensor | None = None,
    camera_rate_hz: float = 10.0,
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
        camera_rate_hz: Camera frames per second.
        dt: Physics step [s].
        spec: The forklift (default: :class:`ForkliftSpec`).
        odometry: Wheel odometry errors (default: :class:`OdometryModel`).
        imu: IMU errors (default: :class:`ImuModel`).
        max_time: Stop after this much simulated time even if the route is not finished [s].
    """
    scenario = load_scenario(scenario)
    chosen = _route(scenario, route)
    if not camera_rate_hz > 0 or not dt > 0:
        raise InvalidInputError(f"camera_rate_hz and dt must be > 0, got {camera_rate_hz}, {dt}")
    streams = np.random.SeedSequence(seed).spawn(5)
    camera_stream, odometry_stream, imu_stream, sway_stream = (
        np.random.default_rng(stream) for stream in streams[:4])
    sensor = sensor or GeometrySensor(scenario)
    sensor.reset(streams[4])
    odometer = Odometer(odometry or OdometryModel(), odometry_stream)
    inertial = Imu(imu or ImuModel(), imu_stream)
    period = 1.0 / camera_rate_hz
    sway = CameraSway(scenario, period, spec)
    next_frame = 0.0
    index = 0
    contacts_seen = 0
    velocity = None
    for world, done in _drive(scenario, chosen, dt, spec):
        forklift = world.forklift
        if velocity is not None:  # the sensors of the step just taken
            new_velocity = forklift.body.velocity
            ax, ay = (new_velocity.x - velocity.x) / dt, (new_velocity.y - velocity.y) / dt
            heading = forklift.body.angle
            c, s = math.cos(heading), math.sin(heading)
            odometer.update(world.time, forklift.speed, forklift.steer)
            inertial.update(world.time, forklift.body.angular_velocity,
                            (c * ax + s * ay, -s * ax + c * ay), heading)
        velocity = forklift.body.velocity
        if world.time + 1e-9 >= next_frame:
            _, _, heading = forklift.pose
            cx, cy = forklift.camera_position()
            tilt = sway.step(cx, cy, sway_stream)
            pose = (cx, cy, heading)
            yield Frame(index=index, time=world.time,
                        observation=sensor.observe(pose, camera_stream, tilt), pose=pose,
                        odometry=odometer.take(), imu=inertial.take(),
                        contacts=len(world.contacts) - contacts_seen)
            contacts_seen = len(world.contacts)
            index += 1
            next_frame += period
            if done or world.time > max_time:
                return
