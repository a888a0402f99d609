"""What the environments share: argument checks and the fixed-size view of an observation."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from azgym.core import IntArray
from azgym.errors import InvalidInputError
from azgym.sensing.protocol import Observation


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
    """Refuse a frame rate that is not a finite number > 0 (None: the sensor's own rate)."""
    if camera_rate_hz is not None and (
            isinstance(camera_rate_hz, bool) or not isinstance(camera_rate_hz, numbers.Real)
            or not (math.isfinite(camera_rate_hz) and camera_rate_hz > 0)):
        raise InvalidInputError(f"camera_rate_hz must be a finite number > 0 [Hz], got "
                                f"{camera_rate_hz!r}")


@dataclass(frozen=True, eq=False)
class Shown:
    """The first K detections of a frame (sensors list them by azimuth), padded to K.

    Attributes:
        ids: Decoded ids, −1 for padding, shape (K,).
        azimuth: Azimuths [rad], 0 for padding, shape (K,).
        quality: Quality columns, 0 for padding, shape (K,) for one column, else (K, Q).
        valid: 1 for a detection, 0 for padding, shape (K,).
        labels: Ground-truth labels, −1 for padding, shape (K,).
        beacons: Ground-truth map rows, −1 for padding, shape (K,).
    """

    ids: IntArray
    azimuth: np.ndarray
    quality: np.ndarray
    valid: np.ndarray
    labels: IntArray
    beacons: IntArray


def show(observation: Observation, size: int, quality_columns: int) -> Shown:
    """The first ``size`` detections, padded (see :class:`Shown`); fresh arrays every call.

    A step's hot path: the arrays are rows of two packed arrays, filled in a few numpy calls.
    """
    measurements, truth = observation.measurements, observation.truth
    count = min(len(measurements), size)
    ints = np.full((4, size), -1, dtype=np.int64)  # ids, labels, beacons, valid
    ints[0, :count] = measurements.ids[:count]
    ints[1, :count] = truth.label[:count]
    ints[2, :count] = truth.beacon[:count]
    valid = np.zeros(size, dtype=np.int8)
    valid[:count] = 1
    floats = np.zeros((size, 1 + quality_columns), dtype=np.float32)  # azimuth, quality...
    floats[:count, 0] = measurements.azimuth[:count]
    if measurements.quality is not None:
        floats[:count, 1:] = measurements.quality[:count].reshape(count, quality_columns)
    quality = floats[:, 1] if quality_columns == 1 else floats[:, 1:]
    return Shown(ids=ints[0], azimuth=floats[:, 0], quality=quality, valid=valid,
                 labels=ints[1], beacons=ints[2])
