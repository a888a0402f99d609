"""Argument checks shared by the environments."""

from __future__ import annotations

import math
import numbers

from azgym.errors import InvalidInputError, unknown_name
from azgym.sensing.image_sensor import ID_MODES

SENSORS = ("geometry", "image")
"""The camera models: the compiled geometry, or rendered and detected fisheye frames."""


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


def check_sensor_options(sensor: str, ids: str, camera_rate_hz: float | None,
                         pixels: bool) -> None:
    """Refuse an unknown sensor or id mode, blinking ids without pixels, a bad frame rate.

    Args:
        sensor: "geometry" or "image".
        ids: One of the image sensor's ``ID_MODES``.
        camera_rate_hz: Frames per second, or None for the environment's default.
        pixels: Whether the environment renders frames (blinking needs them).
    """
    if not isinstance(sensor, str) or sensor not in SENSORS:
        raise unknown_name("sensor", str(sensor), SENSORS)
    if not isinstance(ids, str) or ids not in ID_MODES:
        raise unknown_name("ids", str(ids), ID_MODES)
    if ids == "blink" and not pixels:
        raise InvalidInputError('ids="blink" needs the image path: sensor="image"')
    if camera_rate_hz is not None and (
            isinstance(camera_rate_hz, bool) or not isinstance(camera_rate_hz, numbers.Real)
            or not (math.isfinite(camera_rate_hz) and camera_rate_hz > 0)):
        raise InvalidInputError(f"camera_rate_hz must be a finite number > 0 [Hz], got "
                                f"{camera_rate_hz!r}")
