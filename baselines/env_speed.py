"""Steps per second of the environments as a share of CartPole-v1's (targets: Localize >= 0.3,
Navigate with ransac >= 0.06), best of several rounds.

    python baselines/env_speed.py [--seconds 1.0] [--rounds 5]

Each environment is stepped with a fixed action (a no-op pose answer for Localize; gentle throttle
and steering for Navigate) for ``--seconds`` per round, resetting at episode ends; the least
disturbed round is reported, beside the speed of Gymnasium's CartPole-v1 measured the same way in
the same process as a reference.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np

import azgym  # noqa: F401  (registers the environments)

TARGETS = {"azgym/Localize-WarehouseSmall-v1": 0.3, "azgym/Navigate-WarehouseSmall-v2": 0.06}
"""Steps per second over CartPole-v1's in the same run (with the default localizer, ransac)."""


def steps_per_second(env_id: str, action, seconds: float, rounds: int, **kwargs) -> float:
    env = gym.make(env_id, disable_env_checker=True, **kwargs).unwrapped
    env.reset(seed=0)
    for _ in range(200):
        if any(env.step(action)[2:4]):
            env.reset()
    best = 0.0
    for _ in range(rounds):
        count, start = 0, time.perf_counter()
        while time.perf_counter() - start < seconds:
            _, _, terminated, truncated, _ = env.step(action)
            count += 1
            if terminated or truncated:
                env.reset()
        best = max(best, count / (time.perf_counter() - start))
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=1.0)
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    reference = steps_per_second("CartPole-v1", 0, args.seconds, args.rounds)
    rows = [
        ("azgym/Localize-WarehouseSmall-v1", np.zeros(3, np.float32), {}),
        ("azgym/Navigate-WarehouseSmall-v2", np.array([0.5, 0.1], np.float32), {}),
        ("azgym/Navigate-WarehouseSmall-v2", np.array([0.5, 0.1], np.float32),
         {"localizer": "truth"}),
    ] + [("azgym/Navigate-WarehouseSmall-v2", np.array([0.5, 0.1], np.float32),
          {"localizer": tracker}) for tracker in ("lpkf", "gated-ekf")]
    print(f"{'environment':<60} {'steps/s':>9} {'CartPole ratio':>15} {'target':>7}")
    print(f"{'CartPole-v1 (reference)':<60} {reference:9.0f}")
    for env_id, action, kwargs in rows:
        rate = steps_per_second(env_id, action, args.seconds, args.rounds, **kwargs)
        label = env_id + (f" {kwargs}" if kwargs else "")
        target = TARGETS.get(env_id) if not kwargs else None
        print(f"{label:<60} {rate:9.0f} {rate / reference:15.3f} {target or '':>7}")


if __name__ == "__main__":
    main()
