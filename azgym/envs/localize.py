"""The localization environment: the agent answers each camera frame with a pose estimate."""

from __future__ import annotations

import math
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from azgym.core import pose_error, wrap_angle
from azgym.envs.common import Padder, check_camera_rate, check_render_mode, reward_weights, size
from azgym.errors import InvalidInputError, unknown_name
from azgym.sensing.catalog import make_sensor
from azgym.sensing.geometry.sensor import FrameBuffers, GeometrySensor
from azgym.sensing.protocol import Observation
from azgym.site import Scenario, load_scenario
from azgym.site.sampling import random_free_pose
from azgym.world.drive import camera_trajectory
from azgym.world.sway import CameraSway

__all__ = ["LocalizeEnv"]

LocalizeObservation = dict[str, np.ndarray] | np.ndarray
"""An observation: the padded measurements and the map (a dict), or the image (an array)."""


def _copy(observation: LocalizeObservation) -> LocalizeObservation:
    if isinstance(observation, dict):
        return {key: value.copy() for key, value in observation.items()}
    return observation.copy()


class LocalizeEnv(gym.Env):
    """Localization: estimate the camera's pose from each frame of a drive through a warehouse.

    ## Description

    A forklift drives one of a scenario's routes through the warehouse; its upward fisheye camera
    sees the beacons — and the faults the warehouse makes: racks hide beacons or cover part of
    them, reflective walls and rack faces add ghosts with the real beacon's id, ids are misread,
    a beacon may have been moved. Each step is one camera frame (10 Hz). The agent answers every
    frame with its estimate of the camera pose and is rewarded for its accuracy. A scenario
    without routes (``paper-room``) shows the camera at a random pose in every frame instead.

    ## Action Space

    ``Box(-1, 1, (3,), float32)``: the estimated camera pose, normalised: x and y scaled from the
    room's bounds to [-1, 1], the heading divided by π (the form RL libraries expect).
    ``env.unwrapped.pose_to_action(x, y, heading)`` and ``action_to_pose(action)`` convert. A NaN,
    an action of the wrong shape or one outside [-1, 1] raises :class:`azgym.InvalidInputError`.

    ## Observation Space

    ``Dict`` of fixed-size arrays, K = ``max_detections`` (padded past the frame's M detections):

    | key | space | meaning |
    |---|---|---|
    | ``ids`` | ``Box(-1, max id, (K,), int64)`` | decoded beacon id, −1 for padding |
    | ``azimuth`` | ``Box(-π, π, (K,), float32)`` | azimuth in the camera frame [rad] |
    | ``valid`` | ``MultiBinary(K)`` | which entries are detections |
    | ``quality`` | ``Box(0, 10, (K,), float32)`` | log10 of the blob's brightness over threshold |
    | ``beacon_ids`` | ``Box(min id, max id, (N,), int64)`` | the beacon map: ids (constant) |
    | ``beacon_xyz`` | ``Box((3N,), float32)`` | the map: x, y, z of each beacon in turn [m] |

    With ``sensor="image"`` the measurements come from the fisheye image path
    (:mod:`azgym.sensing.image.sensor`): beacons rendered, detected from pixels and identified
    (``ids="oracle"``, or ``ids="blink"``: decoded from the beacons' blinking over successive
    frames). ``quality`` then has three columns, ``Box(0, high, (K, 3), float32)``: each
    blob's area [px], peak grey level and elongation (the sensor's ``quality_names``). Detections
    past K are dropped (the first K by azimuth are shown). With ``observation="image"`` the
    observation is the frame itself,
    ``Box(0, 255, (height, width, 1), uint8)``, whatever ``sensor`` says; the map is
    ``env.unwrapped.scenario.beacons``.

    ## Rewards

    Named terms, each weighted by the argument of the same name, summed, and reported in
    ``info["rewards"]``: ``position_error`` = −weight · distance [m] and ``heading_error`` =
    −weight · |wrapped heading error| [rad].

    ## Starting State

    ``reset`` picks the route (``options={"route": name}``, the ``route`` argument, or uniformly
    at random) and shows its first frame. The route's trajectory is deterministic; the sensor's
    noise, misread ids and the camera's sway come from the environment's generator.

    ## Episode End

    Terminated after the answer to the route's last frame (or ``episode_length`` frames for a
    scenario without routes). There is no truncation of its own. Frames are
    ``camera_rate_hz`` apart along the route: 10 Hz, or 30 Hz with ``ids="blink"`` (a
    frame-rate on-off code needs small blob motion between frames; see ``azgym study ids``).

    ## Arguments

    ``gym.make("azgym/Localize-WarehouseSmall-v1", scenario=..., route=None, max_detections=32,
    position_error=1.0, heading_error=0.1, episode_length=200, sensor="geometry", ids="oracle",
    observation="measurements", camera_rate_hz=None, render_mode=None)``.
    ``scenario`` accepts a shipped name or the path of a user's TOML file.

    ``info`` holds the true ``pose`` of the answered frame and, for the returned observation,
    ``labels`` (see ``azgym.sensing.labels.LABEL_NAMES``, −1 for padding) and ``true_beacons``
    (map rows) — ground truth kept beside the observation, never in it.

    ## Version History

    * v0: initial version. Revised with azgym's suites warehouse-routes v2 and image-routes v2:
      the camera's sway on bumps is a damped oscillation (consecutive frames see nearly the same
      tilt) instead of independent draws per frame, which changes warehouse-paper's episodes.
    * v1: with ``sensor="image"`` the blob quality is under the key ``quality`` (was ``blob``),
      and ``reset(seed=...)`` also draws the image sensor's noise frames and blinking phases (they
      were fixed); every heading is wrapped by one rule, which leaves in-range angles untouched
      (the routes' camera poses move in their last bits); the random poses of a scenario without
      routes keep 0.5 m from the walls and 0.8 m from racks, like the benchmark's;
      ``env.unwrapped.camera`` and ``last_observation`` replace ``image_sensor`` and
      ``image_frame``.

    ## Example

    >>> import gymnasium as gym, azgym
    >>> env = gym.make("azgym/Localize-WarehouseSmall-v1")
    >>> observation, info = env.reset(seed=0)
    >>> observation, reward, terminated, truncated, info = env.step(env.action_space.sample())
    """

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 10}

    def __init__(
        self,
        scenario: str | Scenario = "warehouse-small",
        route: str | None = None,
        max_detections: int = 32,
        position_error: float = 1.0,
        heading_error: float = 0.1,
        episode_length: int = 200,
        sensor: str = "geometry",
        ids: str = "oracle",
        observation: str = "measurements",
        camera_rate_hz: float | None = None,
        render_mode: str | None = None,
    ) -> None:
        self.scenario = load_scenario(scenario)
        self._check_options(route, max_detections, ids, observation, camera_rate_hz,
                            render_mode)
        self.route = route
        self.max_detections = size("max_detections", max_detections, minimum=3)
        self.weights = reward_weights(position_error=position_error,
                                      heading_error=heading_error)
        self.episode_length = size("episode_length", episode_length)
        self.render_mode = render_mode
        self.observation = observation
        self.camera = make_sensor(self.scenario, "image" if observation == "image" else sensor,
                                  ids)
        self.camera_rate_hz = camera_rate_hz or self.camera.frame_rate_hz
        self._sway = CameraSway(self.scenario, 1.0 / self.camera_rate_hz)
        self._padder = Padder(self.max_detections, len(self.camera.quality_names))
        self._last: Observation | None = None
        self._direct: tuple[GeometrySensor, FrameBuffers] | None = None
        self._count = 0
        if isinstance(self.camera, GeometrySensor) and observation == "measurements":
            # Straight into the padded arrays, with no Observation made (``last_observation``).
            self._direct = self.camera, self.camera.new_buffers(max(self.camera.capacity,
                                                                    self.max_detections))
        self._shown: dict[str, np.ndarray] = {}
        self._trajectories: dict[str, np.ndarray] = {}
        x_min, y_min, x_max, y_max = self.scenario.bounds
        self._centre = ((x_min + x_max) / 2, (y_min + y_max) / 2, 0.0)
        self._half = ((x_max - x_min) / 2, (y_max - y_min) / 2, math.pi)
        self.action_space = spaces.Box(-1.0, 1.0, (3,), np.float32)
        self.observation_space = self._observation_space()
        self._beacon_ids = self.scenario.beacons.ids.astype(np.int64)
        self._beacon_xyz = self.scenario.beacons.xyz.astype(np.float32).ravel()
        self._poses = np.zeros((1, 3))
        self._frame = 0
        self._route_name: str | None = None
        self._estimate: tuple[float, float, float] | None = None

    def _check_options(self, route: str | None, max_detections: int, ids: str,
                       observation: str, camera_rate_hz: float | None,
                       render_mode: str | None) -> None:
        """Refuse bad arguments, naming them (the sensor's own are checked by make_sensor)."""
        if observation not in ("measurements", "image"):
            raise unknown_name("observation", observation, ("measurements", "image"))
        check_camera_rate(camera_rate_hz)
        if ids == "blink" and not self.scenario.routes:
            raise InvalidInputError(
                f'ids="blink" decodes ids over successive frames of a route, and scenario '
                f'{self.scenario.name!r} has no routes')
        names = [r.name for r in self.scenario.routes]
        if route is not None and route not in names:
            raise unknown_name("route", route, names)
        check_render_mode(render_mode, self.metadata["render_modes"])

    def _observation_space(self) -> spaces.Space:
        """The frame's pixels, or the padded detections with the map (see the class)."""
        if self.observation == "image":
            width, height = self.scenario.fisheye.image_size
            return spaces.Box(0, 255, (height, width, 1), np.uint8)
        size, beacons = self.max_detections, self.scenario.beacons
        ids = beacons.ids
        high = np.tile(np.array(self.camera.quality_high, dtype=np.float32), (size, 1))
        quality = spaces.Box(np.zeros_like(high), high, dtype=np.float32)
        if len(self.camera.quality_names) == 1:
            quality = spaces.Box(0.0, high[:, 0], dtype=np.float32)
        z_low = float(min(0.0, beacons.xyz[:, 2].min()))
        z_high = float(beacons.xyz[:, 2].max()) + 1.0
        span = max(abs(v) for v in self.scenario.bounds) + 100.0
        return spaces.Dict({
            "ids": spaces.Box(-1, int(ids.max()), (size,), np.int64),
            "azimuth": spaces.Box(-math.pi, math.pi, (size,), np.float32),
            "valid": spaces.MultiBinary(size),
            "quality": quality,
            "beacon_ids": spaces.Box(int(ids.min()), int(ids.max()), (len(ids),), np.int64),
            "beacon_xyz": spaces.Box(
                low=np.tile(np.array([-span, -span, z_low], dtype=np.float32), len(ids)),
                high=np.tile(np.array([span, span, z_high], dtype=np.float32), len(ids)),
                dtype=np.float32),
        })

    # -- episode -------------------------------------------------------------------------------

    def _trajectory(self, name: str) -> np.ndarray:
        if name not in self._trajectories:
            route = next(r for r in self.scenario.routes if r.name == name)
            self._trajectories[name] = camera_trajectory(self.scenario, route,
                                                         camera_rate_hz=self.camera_rate_hz)
        return self._trajectories[name]

    def _random_poses(self) -> np.ndarray:
        """Poses for a scenario without routes: random free poses (as the benchmark draws them)."""
        return np.array([random_free_pose(self.scenario, self.np_random)
                         for _ in range(self.episode_length)])

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[LocalizeObservation, dict]:
        """Start an episode: pick the route and show its first frame."""
        super().reset(seed=seed)
        options = options or {}
        if self.scenario.routes:
            names = [r.name for r in self.scenario.routes]
            name = options.get("route", self.route)
            if name is None:
                name = names[int(self.np_random.integers(len(names)))]
            elif name not in names:
                raise unknown_name("route", str(name), names)
            self._route_name = name
            self._poses = self._trajectory(name)
        else:
            self._route_name = None
            self._poses = self._random_poses()
        self._frame = 0
        self._estimate = None
        self._sway.reset()
        self.camera.reset(self.np_random)
        observation = self._observe()
        if self.render_mode == "human":
            self.render()
        return observation, self._frame_info()

    def step(self, action: np.ndarray) -> tuple[LocalizeObservation, float, bool, bool, dict]:
        """Score the estimate of the current frame's pose, then show the next frame."""
        estimate = self.action_to_pose(self._check_action(action))
        x, y, heading = self.true_pose()
        position_error, heading_error = pose_error(estimate, (x, y, heading))
        rewards = {"position_error": -self.weights["position_error"] * position_error,
                   "heading_error": -self.weights["heading_error"] * heading_error}
        answered = (x, y, heading)
        self._estimate = estimate
        terminated = self._frame + 1 >= len(self._poses)
        if not terminated:
            self._frame += 1
            observation = self._observe()
        else:
            observation = _copy(self._observation)
        info = self._frame_info()
        info.update(pose=answered, rewards=rewards, position_error=position_error,
                    heading_error=heading_error)
        if self.render_mode == "human":
            self.render()
        return observation, float(sum(rewards.values())), terminated, False, info

    # -- helpers -------------------------------------------------------------------------------

    def _observe(self) -> LocalizeObservation:
        x, y, heading = self._poses[self._frame]
        tilt = self._sway.step(x, y, self.np_random)
        if self._direct is not None:
            camera, buffers = self._direct
            self._count = camera.observe_into((x, y, heading), self.np_random, buffers, tilt)
            self._last = None
            shown = self._shown = self._padder.pad_frame(buffers.floats, buffers.ints,
                                                         self._count)
        else:
            observed = self._last = self.camera.observe((x, y, heading), self.np_random, tilt)
            shown = self._shown = self._padder.pad(observed)
        if self.observation == "image":
            assert self._last is not None and self._last.image is not None, \
                "an image sensor's frame carries its image"
            self._observation: LocalizeObservation = self._last.image[:, :, None]
        else:
            self._observation = {"ids": shown["ids"], "azimuth": shown["azimuth"],
                                 "valid": shown["valid"], "quality": shown["quality"],
                                 "beacon_ids": self._beacon_ids.copy(),
                                 "beacon_xyz": self._beacon_xyz.copy()}
        return self._observation

    def _frame_info(self) -> dict[str, Any]:
        return {"frame": self._frame, "route": self._route_name,
                "labels": self._shown["labels"], "true_beacons": self._shown["beacons"],
                "true_pose": self.true_pose()}

    def _check_action(self, action: Any) -> tuple[float, float, float]:
        estimate = np.asarray(action)
        if estimate.shape != (3,):
            raise InvalidInputError(
                f"action must be a pose estimate (x, y, heading) of shape (3,), got shape "
                f"{estimate.shape}"
            )
        values = x, y, heading = float(estimate[0]), float(estimate[1]), float(estimate[2])
        if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(heading)):
            raise InvalidInputError(f"action must be finite, got {list(values)}")
        if abs(x) > 1.0 + 1e-6 or abs(y) > 1.0 + 1e-6 or abs(heading) > 1.0 + 1e-6:
            raise InvalidInputError(
                f"action {list(values)} is outside the action space [-1, 1]^3 (use "
                "pose_to_action to normalise a pose)"
            )
        return values

    def pose_to_action(self, x: float, y: float, heading: float) -> np.ndarray:
        """The normalised action for the pose estimate (x, y, heading), clipped to [-1, 1]."""
        pose = np.array([x, y, float(wrap_angle(heading))])
        return np.clip((pose - self._centre) / np.array(self._half), -1.0, 1.0).astype(np.float32)

    def action_to_pose(self, action: Any) -> tuple[float, float, float]:
        """The pose (x, y, heading) an action stands for."""
        centre, half = self._centre, self._half
        return (centre[0] + float(action[0]) * half[0], centre[1] + float(action[1]) * half[1],
                float(action[2]) * half[2])

    @property
    def last_observation(self) -> Observation | None:
        """The camera's frame last observed (None before the first)."""
        if self._last is None and self._direct is not None and self._shown:
            self._last = self._direct[1].observation(self._count)
        return self._last

    def true_pose(self) -> tuple[float, float, float]:
        """The true camera pose of the frame last observed."""
        x, y, heading = self._poses[self._frame].tolist()
        return x, y, heading

    def last_estimate(self) -> tuple[float, float, float] | None:
        """The agent's last answer, if any in this episode."""
        return self._estimate

    def render(self) -> np.ndarray | None:
        """Draw the top-down view, and the camera's frame beside it with the image sensor.

        See :mod:`azgym.envs.render`.
        """
        from azgym.envs.render import render_frame

        return render_frame(self, self.render_mode)
