"""The navigation environment: drive the forklift to a goal on the pose a localizer estimates."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from azgym.arguments import positive_number, whole_number
from azgym.core import estimated_pose, wrap_scalar
from azgym.envs.common import check_camera_rate, check_render_mode, reward_weights
from azgym.errors import InvalidInputError
from azgym.localize.registry import SupportsLocalize, make_localizer
from azgym.sensing.catalog import make_sensor
from azgym.sensing.geometry import occluders as G
from azgym.sensing.protocol import Observation
from azgym.site import Scenario, load_scenario
from azgym.site.elements import occluder_table
from azgym.world.sway import CameraSway
from azgym.world.world import World

PHYSICS_DT = 0.02
"""The world's physics step [s]."""
CONTROL_STEPS = 5
"""Physics steps per control period: the navigator acts and the camera looks every 0.1 s."""

DISCRETE_CONTROLS = np.array([[0.0, 0.0], [1.0, 0.0], [-1.0, 0.0], [0.6, 1.0], [0.6, -1.0]],
                             dtype=np.float32)
"""(throttle, steer) of the discrete actions: coast, forward, back, forward-left, forward-right."""

MIN_GOAL_DISTANCE = 5.0
"""A goal spot is at least this far from the start [m]."""
GOAL_SCALE = 20.0
"""Goal offsets in the observation are divided by this [m]."""



class NavigateEnv(gym.Env):
    """Navigation: drive the forklift to a pick or drop spot, seeing only the estimated pose.

    ## Description

    The forklift starts at one of the scenario's spots (its routes' waypoints: aisle ends and
    crossings) and must reach another. It does not know where it is: every control period (10 Hz)
    its camera takes a frame, with all the warehouse's faults, and a localizer — ``ransac`` by
    default, any registered name or object, or ``"truth"`` as an oracle — estimates the pose. The
    goal is given in the frame of that estimate. When the localizer fails (``ok=False``) the
    observation says so and gives no goal, rather than inventing a pose.

    With ``sensor="image"`` the localizer reads the fisheye image path
    (:mod:`azgym.sensing.image.sensor`): beacons rendered, detected from pixels and identified
    (``ids="oracle"``, or ``ids="blink"``: decoded from the beacons' blinking over successive
    frames). It gets each frame's blobs as they are — unidentified ones with id −1, which
    localizers ignore like any id not in the map — with their (area, peak, elongation) as the
    quality; the last frame is ``env.unwrapped.last_observation``.

    The camera takes frames at ``camera_rate_hz``, at the exact times k / rate since the start,
    whatever the physics step: the camera pose of a frame is interpolated between the two
    physics states around it (the heading along the shorter arc). By default it takes one frame
    per control period, at its end; with ``ids="blink"`` 30 per second, three per period, every
    one fed to the blob tracker. Every frame is observed (a sensor may keep state between
    frames, as the blinking ids' tracker does), and the localizer answers the period's last
    frame; in a period without a frame (a camera slower than 10 Hz) the previous estimate stands.

    ## Action Space

    ``Box(-1, 1, (2,), float32)``: throttle (share of the maximum acceleration, negative to
    brake or reverse) and steering (share of full lock, positive left). With ``discrete=True``
    (the ``NavigateDiscrete`` ids): ``Discrete(5)`` — coast, forward, back, forward-left,
    forward-right. A NaN, a wrong shape or an out-of-range action raises
    :class:`azgym.InvalidInputError`.

    ## Observation Space

    ``Box(-1, 1, (5 + n_rays,), float32)``: ``[localized, goal_forward, goal_left, speed, steer,
    ranges...]`` — whether the localizer answered; the goal in the estimated body frame divided
    by 20 m (clipped, zero when not localized); speed and steering as shares of their limits; and
    ``n_rays`` range readings around the body, divided by ``ray_range``.

    ## Rewards

    Named terms, each weighted by the argument of the same name and reported in
    ``info["rewards"]``: ``progress`` (metres closer to the goal, by the true pose), ``collision``
    (−1 in a step that begins a contact), ``time`` (−1 per step) and ``success`` (+1 on arrival).

    ## Starting State

    Start and goal are two different spots at least 5 m apart, drawn by the environment's
    generator; the heading is uniform. The sensor's noise and the camera's sway come from the
    same generator; the image sensor's tracks are reset with the episode.

    ## Episode End

    Terminated when the true position is within ``goal_radius`` of the goal; truncated after
    ``max_steps`` steps.

    ## Arguments

    ``gym.make("azgym/Navigate-WarehouseSmall-v1", scenario=..., localizer="ransac",
    discrete=False, max_steps=600, progress=1.0, collision=1.0, time=0.01, success=10.0,
    goal_radius=1.0, n_rays=8, ray_range=10.0, sensor="geometry", ids="oracle",
    camera_rate_hz=None, render_mode=None)``. With ``render_mode`` and ``sensor="image"`` the
    render shows the camera's last frame beside the top-down view.

    ## Version History

    * v0: initial version. Revised with azgym's suites warehouse-routes v2 and image-routes v2:
      the camera's sway on bumps is a damped oscillation (consecutive frames see nearly the same
      tilt) instead of independent draws per frame, which changes warehouse-paper's episodes.
    * v1: ``reset(seed=...)`` also draws the image sensor's noise frames and blinking phases
      (they were fixed); with a camera faster than the navigator every frame is observed,
      whatever the sensor; every heading is wrapped by one rule, which leaves in-range angles
      untouched (poses move in their last bits); ``env.unwrapped.camera`` and
      ``last_observation`` replace ``image_sensor`` and ``image_frame``.

    ## Example

    >>> import gymnasium as gym, azgym
    >>> env = gym.make("azgym/Navigate-WarehouseSmall-v1", localizer="ransac")
    >>> observation, info = env.reset(seed=0)
    >>> observation, reward, terminated, truncated, info = env.step(env.action_space.sample())
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 10}

    def __init__(
        self,
        scenario: str | Scenario = "warehouse-small",
        localizer: str | SupportsLocalize = "ransac",
        discrete: bool = False,
        max_steps: int = 600,
        progress: float = 1.0,
        collision: float = 1.0,
        time: float = 0.01,
        success: float = 10.0,
        goal_radius: float = 1.0,
        n_rays: int = 8,
        ray_range: float = 10.0,
        sensor: str = "geometry",
        ids: str = "oracle",
        camera_rate_hz: float | None = None,
        render_mode: str | None = None,
    ) -> None:
        self.scenario = load_scenario(scenario)
        check_camera_rate(camera_rate_hz)
        if not self.scenario.routes:
            raise InvalidInputError(
                f"scenario {self.scenario.name!r} has no routes, whose waypoints are the "
                "navigation spots; add [[routes]] to it"
            )
        check_render_mode(render_mode, self.metadata["render_modes"])
        self.weights = reward_weights(progress=progress, collision=collision, time=time,
                                      success=success)
        self.localizer_name = localizer if isinstance(localizer, str) else type(localizer).__name__
        self.localizer = None if localizer == "truth" else (
            make_localizer(localizer) if isinstance(localizer, str) else localizer)
        if self.localizer is not None and not isinstance(self.localizer, SupportsLocalize):
            raise InvalidInputError(f"localizer must be a name, \"truth\" or an object with "
                                    f"localize(measurements, beacons), got {localizer!r}")
        self.discrete = bool(discrete)
        self.max_steps = whole_number("max_steps", max_steps)
        self.goal_radius = positive_number("goal_radius", goal_radius, "m")
        self.n_rays = whole_number("n_rays", n_rays)
        self.ray_range = positive_number("ray_range", ray_range, "m")
        self.render_mode = render_mode
        self.camera = make_sensor(self.scenario, sensor, ids)
        self.camera_rate_hz = float(camera_rate_hz or self.camera.frame_rate_hz)
        # Physics steps per frame; the frame of index k is taken after k * this many steps.
        self._frame_steps = 1.0 / (PHYSICS_DT * self.camera_rate_hz)
        self._sway = CameraSway(self.scenario, 1.0 / self.camera_rate_hz)
        self.last_observation: Observation | None = None
        self._frames = 0
        self._segments = occluder_table(self.scenario.racks, self.scenario.walls)
        self._rays = np.empty(self.n_rays)
        self.spots = _spots(self.scenario)
        self.action_space = (spaces.Discrete(len(DISCRETE_CONTROLS)) if self.discrete else
                             spaces.Box(-1.0, 1.0, (2,), np.float32))
        self.observation_space = spaces.Box(-1.0, 1.0, (5 + self.n_rays,), np.float32)
        self._world: World | None = None
        self._goal = np.zeros(2)
        self._estimate: tuple[float, float, float] | None = None

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        """Place the forklift at a spot facing a random way, and pick a goal spot."""
        super().reset(seed=seed)
        while True:
            start, goal = self.np_random.choice(len(self.spots), size=2, replace=False)
            if np.hypot(*(self.spots[goal] - self.spots[start])) >= MIN_GOAL_DISTANCE:
                break
        heading = float(self.np_random.uniform(-math.pi, math.pi))
        self._world = World(self.scenario, (*self.spots[start], heading), dt=PHYSICS_DT)
        self._sway.reset()
        self.camera.reset(self.np_random)
        self.last_observation = None
        self._goal = self.spots[goal].astype(np.float64)
        self._steps = 0
        self._distance = self._true_distance()
        self._estimate = None
        self._frames = 1  # frame 0 is taken now, at the start
        self._look([self._camera_pose()])
        observation = self._observe()
        if self.render_mode == "human":
            self.render()
        return observation, self._info()

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict]:
        """Drive for one control period (0.1 s), taking camera frames on the way; localize."""
        throttle, steer = self._controls(action)
        world = self._world
        contacts_before = len(world.contacts)
        frames = self._due_frames(world.steps)
        states = [self._camera_pose()]  # the camera pose i physics steps into the period
        for _ in range(CONTROL_STEPS):
            world.step(throttle, steer)
            states.append(self._camera_pose())
        self._look([_interpolate(states[i], states[i + 1], fraction) for i, fraction in frames])
        self._steps += 1
        distance = self._true_distance()
        arrived = distance < self.goal_radius
        rewards = {
            "progress": self.weights["progress"] * (self._distance - distance),
            "collision": -self.weights["collision"] * (len(world.contacts) > contacts_before),
            "time": -self.weights["time"],
            "success": self.weights["success"] * arrived,
        }
        self._distance = distance
        observation = self._observe()
        info = self._info()
        info["rewards"] = rewards
        if self.render_mode == "human":
            self.render()
        return (observation, float(sum(rewards.values())), bool(arrived),
                self._steps >= self.max_steps and not arrived, info)

    # -- helpers -------------------------------------------------------------------------------

    def _controls(self, action: Any) -> tuple[float, float]:
        if self.discrete:
            value = np.asarray(action)
            if not (value.shape == () and value.dtype.kind in "iuf" and np.isfinite(value)
                    and value == np.floor(value) and 0 <= value < len(DISCRETE_CONTROLS)):
                raise InvalidInputError(
                    f"action must be an integer in [0, {len(DISCRETE_CONTROLS)}), got {action!r}"
                )
            throttle, steer = DISCRETE_CONTROLS[int(action)]
            return float(throttle), float(steer)
        controls = np.asarray(action, dtype=np.float64)
        if controls.shape != (2,):
            raise InvalidInputError(
                f"action must be (throttle, steer) of shape (2,), got shape {controls.shape}"
            )
        if not np.isfinite(controls).all() or (np.abs(controls) > 1.0 + 1e-6).any():
            raise InvalidInputError(
                f"action must be finite and within [-1, 1], got {controls.tolist()}"
            )
        return float(controls[0]), float(controls[1])

    def _true_distance(self) -> float:
        x, y, _ = self._world.forklift.pose
        return math.hypot(self._goal[0] - x, self._goal[1] - y)

    def _camera_pose(self) -> tuple[float, float, float]:
        forklift = self._world.forklift
        return (*forklift.camera_position(), forklift.pose[2])

    def _due_frames(self, start: int) -> list[tuple[int, float]]:
        """The frames due in the control period after physics step ``start``, in time order.

        Frame k (``_frames`` counts the frames taken) is due after k · ``_frame_steps``
        physics steps, snapped to a whole step when within rounding of one. Each is given as
        (i, fraction): it lies ``fraction`` of the way, in (0, 1], from the state i steps into
        the period to the state i + 1 steps in.
        """
        frames = []
        while True:
            due = self._frames * self._frame_steps
            if abs(due - round(due)) < 1e-9 * max(1.0, due):
                due = float(round(due))
            offset = due - start
            if offset > CONTROL_STEPS:
                return frames
            i = math.ceil(offset) - 1
            frames.append((i, offset - i))
            self._frames += 1

    def _look(self, poses: list[tuple[float, float, float]]) -> None:
        """Take the frames at ``poses`` (in time order) and localize on the last one.

        The sway steps through every frame, and the camera observes every one (a sensor may keep
        state between frames, as the blinking ids' tracker does).
        """
        if not poses:
            return  # no frame this period: the previous estimate stands
        for pose in poses:
            tilt = self._sway.step(pose[0], pose[1], self.np_random)
            self.last_observation = self.camera.observe(pose, self.np_random, tilt)
        if self.localizer is None:
            self._estimate = pose
        else:
            estimate = self.localizer.localize(self.last_observation.measurements,
                                               self.scenario.beacons)
            self._estimate = estimated_pose(estimate)

    def _observe(self) -> np.ndarray:
        forklift = self._world.forklift
        x, y, heading = forklift.pose
        G.ray_ranges(x, y, heading, self._segments, self.n_rays, self.ray_range, self._rays)
        spec = forklift.spec
        observation = np.zeros(5 + self.n_rays, dtype=np.float32)
        if self._estimate is not None:
            ex, ey, eh = self._estimate
            dx, dy = self._goal[0] - ex, self._goal[1] - ey
            c, s = math.cos(eh), math.sin(eh)
            observation[0] = 1.0
            observation[1] = max(-1.0, min(1.0, (c * dx + s * dy) / GOAL_SCALE))
            observation[2] = max(-1.0, min(1.0, (-s * dx + c * dy) / GOAL_SCALE))
        observation[3] = max(-1.0, min(1.0, forklift.speed / spec.max_speed))
        observation[4] = max(-1.0, min(1.0, forklift.steer / spec.max_steer))
        observation[5:] = self._rays / self.ray_range
        return observation

    def _info(self) -> dict[str, Any]:
        x, y, heading = self._world.forklift.pose
        return {"true_pose": (x, y, heading), "estimate": self._estimate,
                "localized": self._estimate is not None, "goal": tuple(self._goal),
                "distance": self._distance, "contacts": len(self._world.contacts)}

    def true_pose(self) -> tuple[float, float, float]:
        """The camera's true pose."""
        return self._camera_pose()

    def last_estimate(self) -> tuple[float, float, float] | None:
        """The localizer's last estimate (None when it failed)."""
        return self._estimate

    def render(self) -> np.ndarray | None:
        """Draw the top-down view, and the camera's last frame beside it with the image sensor.

        See :mod:`azgym.envs.render`.
        """
        from azgym.envs.render import render_frame

        return render_frame(self, self.render_mode)


def _interpolate(a: tuple[float, float, float], b: tuple[float, float, float],
                 fraction: float) -> tuple[float, float, float]:
    """The pose ``fraction`` of the way from a to b, the heading along the shorter arc.

    ``fraction`` 1 gives b itself, bit for bit.
    """
    if fraction >= 1.0:
        return b
    turn = wrap_scalar(b[2] - a[2])
    return (a[0] + fraction * (b[0] - a[0]), a[1] + fraction * (b[1] - a[1]),
            wrap_scalar(a[2] + fraction * turn))


def _spots(scenario: Scenario) -> np.ndarray:
    """The pick and drop spots: every route's waypoints, once each, shape (S, 2) [m].

    Raises:
        InvalidInputError: No two spots are ``MIN_GOAL_DISTANCE`` apart: no episode can start.
    """
    spots = np.unique(np.concatenate([route.waypoints for route in scenario.routes]), axis=0)
    spread = np.hypot(*(spots[:, None, :] - spots[None, :, :]).transpose(2, 0, 1))
    if spread.max() < MIN_GOAL_DISTANCE:
        raise InvalidInputError(
            f"scenario {scenario.name!r}: no two spots (route waypoints) are "
            f"{MIN_GOAL_DISTANCE} m apart, so no start and goal can be drawn")
    return spots
