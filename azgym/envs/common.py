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
    """The first K detections of a frame by azimuth, padded to K: what an agent is shown.

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
    """The first ``size`` detections by azimuth (a stable order), padded (see :class:`Shown`)."""
    measurements, truth = observation.measurements, observation.truth
    order = np.argsort(measurements.azimuth, kind="stable")[:size]
    count = order.size
    ids = np.full(size, -1, dtype=np.int64)
    azimuth = np.zeros(size, dtype=np.float32)
    quality = np.zeros((size, quality_columns), dtype=np.float32)
    valid = np.zeros(size, dtype=np.int8)
    labels = np.full(size, -1, dtype=np.int64)
    beacons = np.full(size, -1, dtype=np.int64)
    ids[:count] = measurements.ids[order]
    azimuth[:count] = measurements.azimuth[order]
    if measurements.quality is not None:
        quality[:count] = measurements.quality[order].reshape(count, quality_columns)
    valid[:count] = 1
    labels[:count] = truth.label[order]
    beacons[:count] = truth.beacon[order]
    return Shown(ids, azimuth, quality[:, 0] if quality_columns == 1 else quality, valid,
                 labels, beacons)
