"""Driving a navigation environment with a policy, and the scores of the drive.

A navigator is scored as embodied agents are (Anderson et al. 2018, "On Evaluation of Embodied
Navigation Agents"): success rate, and SPL, success weighted by path length,
S · l / max(p, l) for the shortest path's length l and the path p driven. l is the geodesic
shortest path of the body's centre from the start to the goal region
(:mod:`azgym.nav.geodesic`), a lower bound of every drive, so p ≥ l and SPL is 1 only for a
drive along it; p is the true path of the same point. azgym adds what a warehouse cares
about: collisions per episode (contacts begun with racks and walls) and the share of episodes
with any (a forklift pinned against a rack begins contact after contact, so the mean alone is
ruled by a few such episodes), time to the goal (of the successful episodes), and the
localization error along the way (every step the localizer answered), which ties a localizer
to where it gets the forklift.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

from azgym.envs.navigate import NavigateEnv
from azgym.errors import InvalidInputError
from azgym.nav.controls import CONTROL_STEPS, Policy
from azgym.world.world import PHYSICS_DT

__all__ = ["drive", "summarize", "wilson_interval"]


def drive(env: gym.Env, policy: Policy, episodes: int, seed: int,
          progress: Callable[[int], None] | None = None) -> dict[str, Any]:
    """Drive ``episodes`` episodes (seeds seed, seed + 1, ...) and score them.

    Returns:
        ``episodes`` (one dict per episode: success, spl, collisions, time, shortest_path,
        travelled, errors) and the summary of :func:`summarize`.
    """
    inner = env.unwrapped
    if not isinstance(inner, NavigateEnv):
        raise InvalidInputError(
            f"a navigator drives a Navigate environment, got {type(inner).__name__}")
    period = CONTROL_STEPS * PHYSICS_DT
    records = []
    for episode in range(episodes):
        observation, info = env.reset(seed=seed + episode)
        policy.reset()
        errors, steps, done, terminated = [], 0, False, False
        while not done:
            observation, _, terminated, truncated, info = env.step(policy.act(observation))
            steps += 1
            error = info["position_error"]
            errors.append(math.nan if error is None else error)
            done = terminated or truncated
        length, travelled = info["shortest_path"], info["travelled"]
        records.append({
            "success": bool(terminated), "collisions": int(info["contacts"]),
            "spl": float(terminated) * length / max(travelled, length),
            "time": steps * period, "shortest_path": length, "travelled": travelled,
            "errors": np.array(errors)})
        if progress is not None:
            progress(episode + 1)
    return {"episodes": records, **summarize(records)}


def summarize(records: list[dict[str, Any]]) -> dict[str, Any]:
    """Success rate (and its 95 % interval), SPL, collisions, time to goal, localization error."""
    errors = np.concatenate([record["errors"] for record in records])
    answered = errors[np.isfinite(errors)]
    successes = [record["time"] for record in records if record["success"]]
    return {
        "success": float(np.mean([record["success"] for record in records])),
        "success_interval": wilson_interval(sum(record["success"] for record in records),
                                            len(records)),
        "spl": float(np.mean([record["spl"] for record in records])),
        "collisions": float(np.mean([record["collisions"] for record in records])),
        "collided": float(np.mean([record["collisions"] > 0 for record in records])),
        "time_to_goal": float(np.mean(successes)) if successes else math.nan,
        "answered": float(answered.size / errors.size) if errors.size else math.nan,
        "error_median_cm": float(100 * np.median(answered)) if answered.size else math.nan,
        "error_p95_cm": float(100 * np.percentile(answered, 95)) if answered.size else math.nan,
    }


def wilson_interval(successes: int, trials: int, z: float = 1.959964) -> list[float]:
    """The Wilson score interval of a success rate (95 % for the default ``z``).

    Unlike the normal approximation it stays within [0, 1] and is not empty at 0 or 100 %
    success (Wilson 1927; Brown, Cai & DasGupta 2001 recommend it for small samples).
    """
    if trials <= 0:
        return [math.nan, math.nan]
    rate = successes / trials
    scale = 1.0 + z * z / trials
    centre = (rate + z * z / (2 * trials)) / scale
    half = z * math.sqrt(rate * (1.0 - rate) / trials + z * z / (4 * trials * trials)) / scale
    return [max(0.0, centre - half), min(1.0, centre + half)]
