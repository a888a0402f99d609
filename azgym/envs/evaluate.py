"""Run a localizer as the agent of a localization environment: ``azgym.evaluate(env, "ransac")``."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np

from azgym.core import Measurements, estimated_pose, pose_error
from azgym.envs.localize import LocalizeEnv
from azgym.errors import InvalidInputError
from azgym.localize.registry import SupportsLocalize, make_localizer
from azgym.metrics import ErrorStats, summarize_errors

__all__ = ["Evaluation", "evaluate", "measurements_from_observation"]


class Evaluation(ErrorStats[float]):
    """What :func:`evaluate` returns: the error statistics, and the episodes' total reward."""

    total_reward: float


def measurements_from_observation(observation: dict[str, np.ndarray]) -> Measurements:
    """The detections of a Localize observation (its valid entries) as Measurements.

    The ``quality`` entries are the measurements' quality (with the image sensor, each blob's
    area, peak and elongation).
    """
    valid = observation["valid"].astype(bool)
    return Measurements(observation["ids"][valid],
                        observation["azimuth"][valid].astype(np.float64),
                        observation["quality"][valid].astype(np.float64))


def evaluate(env: gym.Env, localizer: str | SupportsLocalize = "ransac", episodes: int = 1,
             seed: int | None = None) -> Evaluation:
    """Drive ``episodes`` episodes of a Localize environment with a localizer as the agent.

    Each frame's estimate is the action (when the localizer gives none, the previous answer is
    repeated, but the frame counts as unavailable: a missing estimate is never a zero error).

    Args:
        env: A Localize environment (``gym.make("azgym/Localize-...")``).
        localizer: A registered name or spec, or an object with ``localize``.
        episodes: How many episodes.
        seed: Seed of the first episode (then seed + 1, ...); None: unseeded.

    Returns:
        The statistics of :func:`azgym.metrics.summarize_errors` over every frame, and the
        episodes' total reward.
    """
    inner = env.unwrapped
    if not isinstance(inner, LocalizeEnv):
        raise InvalidInputError(
            f"evaluate needs a Localize environment, got {type(inner).__name__}"
        )
    if inner.observation == "image":
        raise InvalidInputError(
            'evaluate feeds a localizer measurements; this environment observes pixels '
            '(observation="image"): use sensor="image" for detected measurements')
    agent = make_localizer(localizer) if isinstance(localizer, str) else localizer
    beacons = inner.scenario.beacons
    position, heading, ok, total = [], [], [], 0.0
    for episode in range(episodes):
        observation, info = env.reset(seed=None if seed is None else seed + episode)
        action = np.zeros(3, dtype=np.float32)
        done = False
        while not done:
            estimate = agent.localize(measurements_from_observation(observation), beacons)
            pose = estimated_pose(estimate)
            ok.append(pose is not None)
            if pose is not None:
                position_error, heading_error = pose_error(pose, info["true_pose"])
                position.append(position_error)
                heading.append(heading_error)
                action = inner.pose_to_action(*pose)
            else:
                position.append(math.nan)
                heading.append(math.nan)
            observation, reward, terminated, truncated, info = env.step(action)
            total += float(reward)
            done = terminated or truncated
    stats = summarize_errors(np.array(position), np.array(heading), np.array(ok))
    return {**stats, "total_reward": total}
