"""The navigation environment: drive the forklift to a goal on the pose a localizer estimates."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.error import ResetNeeded
from gymnasium.utils import seeding

from azgym.arguments import positive_number, whole_number
from azgym.core import Pose, estimated_pose, interpolate_pose, pose_error, wrap_scalar
from azgym.envs.common import check_camera_rate, check_render_mode, flag, reward_weights, size
from azgym.localize.registry import SupportsLocalize
from azgym.nav.controls import CONTROL_STEPS, DISCRETE_CONTROLS, controls
from azgym.nav.estimator import feed_for, resolve_estimator
from azgym.nav.geodesic import shortest_paths_for
from azgym.nav.guidance import SUPPORT_SCALE, Guidance
from azgym.nav.planner import planner_for
from azgym.nav.pose_keeper import PoseKeeper
from azgym.nav.spots import HEADING_SPREAD, aisle_headings, draw_route, spots_of
from azgym.sensing.catalog import make_sensor
from azgym.sensing.protocol import Observation
from azgym.site import Scenario, load_scenario
from azgym.site.elements import occluder_table
from azgym.track.base import SupportsTrack
from azgym.world.forklift import ForkliftSpec
from azgym.world.sway import CameraSway
from azgym.world.world import PHYSICS_DT, World

__all__ = ["MAX_STEPS", "NavigateEnv"]

MAX_STEPS = 600
"""Control steps before an episode is truncated (``max_steps``'s default: 60 s)."""

class NavigateEnv(gym.Env):
    """Navigation: drive the forklift along a planned path to a spot, seeing the estimated pose.

    ## Description

    The forklift starts at one of the scenario's spots (its routes' waypoints: aisle ends and
    crossings) and must reach another, the way an AGV is driven: a global planner on the known
    map (:mod:`azgym.nav.planner`: racks and walls inflated by the forklift's half-width and a
    margin, cheapest paths keeping to the middle of the aisles) gives the path, and the agent is
    the local controller. It does not know where it is: every control period (10 Hz) its camera
    takes a frame, with all the warehouse's faults, and a localizer or tracker — ``ransac`` by
    default, any registered name, spec or object, or ``"truth"`` as an oracle — estimates the
    pose. The path is followed from that estimate and shown in its frame
    (:mod:`azgym.nav.guidance`). Between answers (``ok=False``), the navigator dead-reckons from
    the drive's speed and steering, and it rejects answers that jump implausibly
    (:mod:`azgym.nav.pose_keeper`); the observation says how old its pose is.

    A tracker (``tkf``, ``lpkf``, ``gated-ekf``, ``robust``, ``dead-reckoning`` or an object with
    ``reset``, ``predict`` and ``update``) also hears the forklift's wheel odometry and IMU,
    sampled after every physics step: on each frame it localizes it predicts with the samples up
    to that frame's time, then updates (:mod:`azgym.nav.estimator`). It starts each episode
    without the start pose; its sensors' noise and its seed come from the environment's
    generator, drawn only for a tracker.

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
    (the ``NavigateDiscrete`` ids): ``Discrete(15)``, every throttle (accelerate, hold, brake)
    with every steering (straight, gentle and full turns each way), in the order of
    ``azgym.nav.controls.DISCRETE_CONTROLS``. A NaN, a wrong shape or an out-of-range action raises
    :class:`azgym.InvalidInputError`.

    ## Observation Space

    ``Box(-1, 1, (12 + n_rays,), float32)``, named in order by
    ``azgym.nav.guidance.fields(n_rays)``: the localizer's health (answered this step; seconds
    since the last pose; how many measurements agree with it), the planned path's points 1.5, 3
    and 5 m ahead in the estimated body frame and its remaining length, speed and steering as
    shares of their limits, and ``n_rays`` range readings around the body
    (:mod:`azgym.nav.guidance`).

    ## Rewards

    Named terms, each weighted by the argument of the same name and reported in
    ``info["rewards"]``: ``progress`` (the fall of the planner's cost to go at the true pose, in
    metres: shaping by a potential, which leaves the best policy unchanged; Ng, Harada & Russell
    1999), ``collision`` (−1 in a step that begins a contact), ``time`` (−1 per step) and
    ``success`` (+1 on arrival).

    ## Starting State

    Start and goal are two different spots at least 5 m apart, drawn by the environment's
    generator; the forklift stands along one of the aisles that meet at its spot, either way,
    within 15° (``azgym.nav.spots.aisle_headings``). The sensor's noise and the camera's sway
    come from the same generator; the image sensor's tracks are reset with the episode.

    ## Episode End

    Terminated when the true position is within ``goal_radius`` of the goal; truncated after
    ``max_steps`` steps. ``info`` carries what navigation is scored on: ``shortest_path`` (SPL's
    l: the geodesic shortest path of the body's centre from the start to within ``goal_radius``
    of the goal, a lower bound of any drive, :mod:`azgym.nav.geodesic`; ``shortest_path(seed)``
    gives an episode's without resetting), ``travelled`` (the true path of the body's centre so
    far), ``contacts``, ``position_error`` (of this step's answer, None without one; gated or
    not), ``answered``, ``localized`` (answered and through the jump gate) and ``rejected``
    (answers the jump gate has refused so far, :mod:`azgym.nav.pose_keeper`).

    ## Arguments

    ``gym.make("azgym/Navigate-WarehouseSmall-v2", scenario=..., localizer="ransac",
    discrete=False, max_steps=600, progress=1.0, collision=1.0, time=0.01, success=10.0,
    goal_radius=1.0, n_rays=8, ray_range=10.0, sensor="geometry", ids="oracle",
    camera_rate_hz=None, render_mode=None)``. ``localizer`` is a localizer or tracker: a name or
    spec (``azgym localizers`` lists them), an object, or ``"truth"``; a localizer wrapped as a
    tracker (``azgym.make_tracker("ransac")``) runs as the localizer. With ``render_mode`` and
    ``sensor="image"`` the render shows the camera's last frame beside the top-down view.

    ## Version History

    * v0: initial version. Revised with azgym's suites warehouse-routes v2 and image-routes v2:
      the camera's sway on bumps is a damped oscillation (consecutive frames see nearly the same
      tilt) instead of independent draws per frame, which changes warehouse-paper's episodes.
    * v1: ``reset(seed=...)`` also draws the image sensor's noise frames and blinking phases
      (they were fixed); with a camera faster than the navigator every frame is observed,
      whatever the sensor; every heading is wrapped by one rule, which leaves in-range angles
      untouched (poses move in their last bits); ``env.unwrapped.camera`` and
      ``last_observation`` replace ``image_sensor`` and ``image_frame``.
    * v2: the planner in the loop. The observation shows the planned path ahead and the
      localizer's health instead of the straight-line goal (12 + n_rays entries, was 5 + n_rays),
      the navigator dead-reckons between poses and gates jumps, progress is measured along the
      planned path, the forklift starts along an aisle (its heading was uniform),
      and the discrete actions are 15 (were 5: coast, forward, back, forward-left,
      forward-right). Localize ids stay at v1. Revised for SPL against the geodesic:
      ``info["shortest_path"]`` (the geodesic shortest path) replaces ``info["path_length"]``
      (the planned path, which a driver could beat by cutting corners); the episodes are the
      same.

    ## Example

    >>> import gymnasium as gym, azgym
    >>> env = gym.make("azgym/Navigate-WarehouseSmall-v2", localizer="ransac")
    >>> observation, info = env.reset(seed=0)
    >>> observation, reward, terminated, truncated, info = env.step(env.action_space.sample())
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 10}

    def __init__(
        self,
        scenario: str | Scenario = "warehouse-small",
        localizer: str | SupportsLocalize | SupportsTrack = "ransac",
        discrete: bool = False,
        max_steps: int = MAX_STEPS,
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
        self.spots = spots_of(self.scenario)
        self._headings = aisle_headings(self.scenario, self.spots)
        check_render_mode(render_mode, self.metadata["render_modes"])
        self.weights = reward_weights(progress=progress, collision=collision, time=time,
                                      success=success)
        self.localizer_name = localizer if isinstance(localizer, str) else type(localizer).__name__
        self.localizer = resolve_estimator(localizer)
        self._feed = feed_for(self.localizer, PHYSICS_DT)
        self.discrete = flag("discrete", discrete)
        self.max_steps = whole_number("max_steps", max_steps)
        self.goal_radius = positive_number("goal_radius", goal_radius, "m")
        self.n_rays = size("n_rays", n_rays)
        self.ray_range = positive_number("ray_range", ray_range, "m")
        self.render_mode = render_mode
        self.camera = make_sensor(self.scenario, sensor, ids)
        self.camera_rate_hz = float(camera_rate_hz or self.camera.frame_rate_hz)
        # Physics steps per frame; the frame of index k is taken after k * this many steps.
        self._frame_steps = 1.0 / (PHYSICS_DT * self.camera_rate_hz)
        self._sway = CameraSway(self.scenario, 1.0 / self.camera_rate_hz)
        self.last_observation: Observation | None = None
        self._frames = 0
        self.planner = planner_for(self.scenario, self.spots)
        self.shortest_paths = shortest_paths_for(self.scenario, self.spots, self.goal_radius)
        self._guidance = Guidance(self.planner, occluder_table(self.scenario.racks,
                                                               self.scenario.walls),
                                  self.n_rays, self.ray_range)
        self.action_space = (spaces.Discrete(len(DISCRETE_CONTROLS)) if self.discrete else
                             spaces.Box(-1.0, 1.0, (2,), np.float32))
        self.observation_space = spaces.Box(-1.0, 1.0, (self._guidance.size,), np.float32)
        self._world: World | None = None
        self._goal_index = 0
        self._goal = np.zeros(2)
        self._pose = PoseKeeper(ForkliftSpec())

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict]:
        """Place the forklift at a spot facing a random way, and pick a goal spot."""
        super().reset(seed=seed)
        start, goal = draw_route(self.np_random, self.spots)
        headings = self._headings[start]
        heading = wrap_scalar(float(headings[self.np_random.integers(len(headings))]
                                    + self.np_random.uniform(-HEADING_SPREAD, HEADING_SPREAD)))
        self._world = World(self.scenario, (*self.spots[start], heading), dt=PHYSICS_DT)
        self._sway.reset()
        self.camera.reset(self.np_random)
        self.last_observation = None
        self._goal_index = goal
        self._goal = self.spots[goal].astype(np.float64)
        self._steps = 0
        pose = self._world.forklift.pose
        self._potential = self._cost_to_go(pose)
        self._guidance.start(self._goal_index, *self.spots[start])
        self._shortest_path = float(self.shortest_paths[start, goal])
        self._travelled = 0.0
        self._pose.reset()
        self._localized = False
        self._answer: Pose | None = None
        self._frames = 1  # frame 0 is taken now, at the start
        if self._feed is not None:
            self._feed.reset(self._world, self.np_random)
        self._look([(self._camera_pose(), 0.0)])
        observation = self._observe(pose)
        if self.render_mode == "human":
            self.render()
        return observation, self._info(pose)

    def step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict]:
        """Drive for one control period (0.1 s), taking camera frames on the way; localize."""
        throttle, steer = controls(action, self.discrete)
        world = self._episode()
        contacts_before = len(world.contacts)
        frames = self._due_frames(world.steps)
        forklift = world.forklift
        x, y, _ = pose = forklift.pose
        poses = [pose]  # the body i physics steps into the period
        for _ in range(CONTROL_STEPS):
            world.step(throttle, steer)
            if self._feed is not None:
                self._feed.step(world)
            self._pose.coast(forklift.speed, forklift.steer, PHYSICS_DT)
            previous_x, previous_y = x, y
            x, y, _ = pose = forklift.pose
            poses.append(pose)
            self._travelled += math.hypot(x - previous_x, y - previous_y)
        self._steps += 1
        camera = forklift.camera_pose_at
        self._look([(interpolate_pose(camera(poses[i]), camera(poses[i + 1]), fraction), time)
                    for i, fraction, time in frames])
        potential = self._cost_to_go(pose)
        arrived = math.hypot(self._goal[0] - x, self._goal[1] - y) < self.goal_radius
        rewards = {
            "progress": self.weights["progress"] * (self._potential - potential),
            "collision": -self.weights["collision"] * (len(world.contacts) > contacts_before),
            "time": -self.weights["time"],
            "success": self.weights["success"] * arrived,
        }
        self._potential = potential
        observation = self._observe(pose)
        info = self._info(pose)
        info["rewards"] = rewards
        if self.render_mode == "human":
            self.render()
        return (observation, float(sum(rewards.values())), bool(arrived),
                self._steps >= self.max_steps and not arrived, info)


    def _cost_to_go(self, pose: Pose | None = None) -> float:
        """The planner's cost to go from the body's true pose (default: now): the potential."""
        x, y, _ = self._episode().forklift.pose if pose is None else pose
        return self.planner.cost_to_go(self._goal_index, x, y)

    def _episode(self) -> World:
        """The episode's world; refuses a call before :meth:`reset`."""
        if self._world is None:
            raise ResetNeeded("NavigateEnv: call reset() before step() or render()")
        return self._world

    def _camera_pose(self) -> tuple[float, float, float]:
        forklift = self._episode().forklift
        return forklift.camera_pose_at(forklift.pose)

    def _due_frames(self, start: int) -> list[tuple[int, float, float]]:
        """The frames due in the control period after physics step ``start``, in time order.

        Frame k (``_frames`` counts the frames taken) is due after k · ``_frame_steps``
        physics steps, snapped to a whole step when within rounding of one. Each is given as
        (i, fraction, time): it lies ``fraction`` of the way, in (0, 1], from the state i steps
        into the period to the state i + 1 steps in, at ``time`` on the world's clock (a whole
        step's time is the world's own, bit for bit).
        """
        frames: list[tuple[int, float, float]] = []
        while True:
            due = self._frames * self._frame_steps
            if abs(due - round(due)) < 1e-9 * max(1.0, due):
                due = float(round(due))
            offset = due - start
            if offset > CONTROL_STEPS:
                return frames
            i = math.ceil(offset) - 1
            frames.append((i, offset - i, due * PHYSICS_DT))
            self._frames += 1

    def _look(self, frames: list[tuple[tuple[float, float, float], float]]) -> None:
        """Take the frames at (pose, time) (in time order) and localize on the last one.

        The sway steps through every frame, and the camera observes every one (a sensor may keep
        state between frames, as the blinking ids' tracker does). A tracker predicts up to the
        last frame's time with the motion samples since its previous one, then updates.
        """
        if not frames:  # no frame this period: the pose is dead-reckoned on
            self._answer, self._localized = None, False
            return
        for pose, _ in frames:
            tilt = self._sway.step(pose[0], pose[1], self.np_random)
            self.last_observation = observed = self.camera.observe(pose, self.np_random, tilt)
        pose, time = frames[-1]
        measurements, beacons = observed.measurements, self.scenario.beacons
        if self._feed is None:  # the truth
            self._answer, support = pose, SUPPORT_SCALE
        else:
            estimate = self._feed.estimate(time, measurements, beacons)
            self._answer = estimated_pose(estimate)
            support = int(np.count_nonzero(estimate.inliers)) if self._answer else 0
        self._localized = self._pose.offer(self._answer, support)

    def _observe(self, pose: Pose | None = None) -> np.ndarray:
        """The agent's observation with the body at its true ``pose`` (default: now)."""
        forklift = self._episode().forklift
        spec = forklift.spec
        return self._guidance.observe(
            self._pose.body_pose(), self._pose.age, self._pose.support, self._localized,
            forklift.speed / spec.max_speed, forklift.steer / spec.max_steer, pose or forklift.pose)

    def _info(self, pose: Pose) -> dict[str, Any]:
        """The step's info with the body at its true ``pose``."""
        world = self._episode()
        x, y, heading = pose
        answer = self._answer
        error = pose_error(answer, world.forklift.camera_pose_at(pose))[0] if answer else None
        return {"true_pose": (x, y, heading), "estimate": self._pose.pose,
                "answered": answer is not None, "localized": self._localized,
                "rejected": self._pose.rejected, "position_error": error,
                "goal": tuple(self._goal), "distance": math.hypot(self._goal[0] - x,
                                                                  self._goal[1] - y),
                "shortest_path": self._shortest_path, "travelled": self._travelled,
                "contacts": len(world.contacts)}

    def shortest_path(self, seed: int) -> float:
        """``info["shortest_path"]`` of the episode ``reset(seed=seed)`` starts, without resetting.

        The start and goal are the first draws of the generator that ``reset`` seeds.
        """
        start, goal = draw_route(seeding.np_random(seed)[0], self.spots)
        return float(self.shortest_paths[start, goal])

    def true_pose(self) -> tuple[float, float, float]:
        """The camera's true pose."""
        return self._camera_pose()

    def last_estimate(self) -> tuple[float, float, float] | None:
        """The camera pose the navigator believes (None before the first answer)."""
        return self._pose.pose

    def goal(self) -> tuple[float, float]:
        """The episode's goal spot [m]."""
        return float(self._goal[0]), float(self._goal[1])

    def planned_path(self) -> np.ndarray:
        """The path followed now, (N, 2) [m]: the planner's, from the start or the last replan."""
        return self._guidance.path

    def render(self) -> np.ndarray | None:
        """Draw the top-down view, and the camera's last frame beside it with the image sensor.

        See :mod:`azgym.envs.render`.
        """
        from azgym.envs.render import render_frame

        return render_frame(self, self.render_mode)
