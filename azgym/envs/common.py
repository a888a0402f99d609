"""What the environments share: argument checks and the fixed-size view of an observation."""

from __future__ import annotations

import math

import numpy as np

from azgym.errors import InvalidInputError
from azgym.sensing.protocol import AZIMUTH, BEACON, ID, LABEL, Observation
from azgym.world.drive import checked_camera_rate

__all__ = ["Padder", "check_camera_rate", "check_render_mode", "reward_weights"]


def check_render_mode(render_mode: str | None, modes: list[str]) -> None:
    """Refuse an unknown render mode, and "human" where no window can be opened."""
    if render_mode is not None and render_mode not in modes:
        raise InvalidInputError(f"render_mode must be one of {modes}, got {render_mode!r}")
    if render_mode == "human":
        from azgym.envs.render import require_display

        require_display()


def reward_weights(**weights: float) -> dict[str, float]:
    """The weights of named reward terms, each a finite number >= 0."""
    for name, value in weights.items():
        if isinstance(value, bool) or not (isinstance(value, (int, float))
                                           and math.isfinite(value) and value >= 0):
            raise InvalidInputError(f"{name} weight must be a number >= 0, got {value!r}")
    return {name: float(value) for name, value in weights.items()}


def check_camera_rate(camera_rate_hz: float | None) -> None:
    """Refuse a frame rate outside the drive's range (None: the sensor's own rate)."""
    if camera_rate_hz is not None:
        checked_camera_rate(camera_rate_hz)


class Padder:
    """The first K detections of every frame, padded to K: what an agent is shown.

    Args:
        size: K.
        quality_columns: Q, the sensor's number of quality columns.
    """

    def __init__(self, size: int, quality_columns: int) -> None:
        self.size = size
        self.quality_columns = quality_columns
        self._ints = np.full((4, size), -1, dtype=np.int64)
        self._floats = np.zeros((1 + quality_columns, size), dtype=np.float32)
        self._valid = np.zeros(size, dtype=np.int8)

    def pad(self, observation: Observation) -> dict[str, np.ndarray]:
        """Fresh arrays of the frame, −1 or 0 where padded.

        ``ids``, ``azimuth``, ``valid``, ``quality`` ((K,) for one column, else (K, Q)), and the
        truth's ``labels`` and ``beacons``. A step's hot path: each packed array is padded in one
        call.
        """
        count = min(len(observation), self.size)
        ints, floats, valid = self._ints.copy(), self._floats.copy(), self._valid.copy()
        ints[:, :count] = observation.ints[:, :count]
        floats[:, :count] = observation.measured[:, :count]
        valid[:count] = 1
        quality = floats[1] if self.quality_columns == 1 else floats[1:].T.copy()
        return {"ids": ints[ID], "azimuth": floats[AZIMUTH], "valid": valid, "quality": quality,
                "labels": ints[LABEL], "beacons": ints[BEACON]}
