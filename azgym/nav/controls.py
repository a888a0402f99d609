"""The navigator's actions and what chooses them.

An action is (throttle, steer) in [−1, 1], or one of 15 discrete commands; a :class:`Policy`
chooses it from an observation.
"""

from __future__ import annotations

from typing import Any, Protocol

import numpy as np

from azgym.errors import InvalidInputError

__all__ = ["CONTROL_STEPS", "DISCRETE_CONTROLS", "Policy", "controls", "nearest_discrete"]

CONTROL_STEPS = 5
"""Physics steps per control period: the navigator acts and the camera looks every 0.1 s."""
DISCRETE_THROTTLES = (1.0, 0.0, -1.0)
"""Throttle of the discrete actions: accelerate, hold the speed, brake (or reverse)."""
DISCRETE_STEERS = (0.0, 0.35, -0.35, 1.0, -1.0)
"""Steering of the discrete actions, as shares of full lock: straight, gentle and full turns."""
DISCRETE_CONTROLS = np.array([(throttle, steer) for throttle in DISCRETE_THROTTLES
                              for steer in DISCRETE_STEERS], dtype=np.float32)
"""(throttle, steer) of each discrete action: every throttle with every steering, 15 in all."""


def controls(action: Any, discrete: bool) -> tuple[float, float]:
    """The (throttle, steer) an action asks for.

    Raises:
        InvalidInputError: A discrete action that is not a whole number in [0, 15), or a
            continuous one that is not two finite numbers in [−1, 1].
    """
    if discrete:
        value = np.asarray(action)
        if not (value.shape == () and value.dtype.kind in "iuf" and np.isfinite(value)
                and value == np.floor(value) and 0 <= value < len(DISCRETE_CONTROLS)):
            raise InvalidInputError(
                f"action must be an integer in [0, {len(DISCRETE_CONTROLS)}), got {action!r}")
        throttle, steer = DISCRETE_CONTROLS[int(action)]
        return float(throttle), float(steer)
    values = np.asarray(action, dtype=np.float64)
    if values.shape != (2,):
        raise InvalidInputError(
            f"action must be (throttle, steer) of shape (2,), got shape {values.shape}")
    throttle, steer = float(values[0]), float(values[1])
    if not (abs(throttle) <= 1.0 + 1e-6 and abs(steer) <= 1.0 + 1e-6):  # NaN fails too
        raise InvalidInputError(f"action must be finite and within [-1, 1], got {values.tolist()}")
    return throttle, steer


def nearest_discrete(throttle: float, steer: float) -> int:
    """The discrete action nearest to (throttle, steer)."""
    return int(np.argmin((DISCRETE_CONTROLS[:, 0] - throttle) ** 2
                         + (DISCRETE_CONTROLS[:, 1] - steer) ** 2))


class Policy(Protocol):
    """What drives: ``act(observation)`` gives an action; ``reset()`` starts an episode."""

    def act(self, observation: np.ndarray) -> Any:
        """The action for one observation."""

    def reset(self) -> None:
        """Start an episode (forget the last one)."""
