"""What the environments share: argument checks and the fixed-size view of an observation.

Every argument is checked by azgym's one number rule (:class:`azgym.fields.Number`) where the
environment is made, and refused with its name: a flag must be a bool (:func:`flag`), a reward
weight a finite number in [0, :data:`MAX_REWARD_WEIGHT`] (:func:`reward_weights`), and a size
(detections shown, range rays, frames of an episode) a whole number up to :data:`MAX_SIZE`
(:func:`size`), so that no argument makes a reward infinite or a step run out of memory.
"""

from __future__ import annotations

import functools

import numpy as np

from azgym.arguments import whole_number
from azgym.errors import InvalidInputError
from azgym.fields import Flag, Number, argument_error, require
from azgym.sensing.protocol import AZIMUTH, BEACON, ID, LABEL, Observation
from azgym.world.drive import checked_camera_rate

__all__ = ["MAX_REWARD_WEIGHT", "MAX_SIZE", "Padder", "check_camera_rate", "check_render_mode",
           "flag", "reward_weights", "size"]

MAX_REWARD_WEIGHT = 1e6
"""The largest weight of a reward term. Every term is a weight times a bounded quantity: a
distance or a cost to go within a site (whose coordinates are at most 1e5 m,
:data:`azgym.site.reader.MAX_MAGNITUDE`, so under 1e6 m even clearance-weighted), an angle up to
π, or a count of 1; a step's reward is therefore at most a few 1e12 in magnitude, and an
episode's return stays finite by a margin of some 1e20 even in float32 (3.4e38), the type RL
libraries keep rewards in. Weights set the terms' relative scale (the defaults are 0.01-10):
a million times another is already beyond any use. Without the bound a weight of 1e308 gave a
reward of -inf."""

MAX_SIZE = 65_536
"""The largest size argument of an environment (``max_detections``, ``n_rays``,
``episode_length``). Each unit costs arrays built on every step or reset (a detection's padded
entries in four int64 and several float32 arrays, copied into each observation; a ray's reading,
its observation entry, its space bounds and its field name; a frame's pose drawn at reset): under
1 KiB, so a step stays under 64 MiB. It is far beyond any camera's detections or any range
sensor's rays; without it ``max_detections=10**9`` asked for 30 GiB and failed with a bare
MemoryError."""

_PYTHON_FLAG = Flag(python=True)
_WEIGHT = Number(0, MAX_REWARD_WEIGHT)
_SIZE = Number(high=MAX_SIZE, integer=True)


def flag(name: str, value: object) -> bool:
    """``value`` as a flag: True or False (a NumPy bool too), never a string or a number."""
    require(value, _PYTHON_FLAG, functools.partial(argument_error, name))
    return bool(value)


def size(name: str, value: object, minimum: int = 1) -> int:
    """``value`` as a size: a whole number in [``minimum``, :data:`MAX_SIZE`]."""
    count = whole_number(name, value, minimum)
    return _SIZE.as_int(count, lambda problem: argument_error(
        name, f"{problem} (every unit costs memory on each step)"))


def check_render_mode(render_mode: str | None, modes: list[str]) -> None:
    """Refuse an unknown render mode, and "human" where no window can be opened."""
    if render_mode is not None and render_mode not in modes:
        raise InvalidInputError(f"render_mode must be one of {modes}, got {render_mode!r}")
    if render_mode == "human":
        from azgym.envs.render import require_display

        require_display()


def reward_weights(**weights: float) -> dict[str, float]:
    """The weights of named reward terms, each a finite number in [0, MAX_REWARD_WEIGHT]."""
    return {name: _WEIGHT.as_float(value, functools.partial(argument_error, f"{name} weight"))
            for name, value in weights.items()}


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
        return self._shown(ints, floats, valid)

    def pad_frame(self, floats: np.ndarray, ints: np.ndarray, count: int
                  ) -> dict[str, np.ndarray]:
        """As :meth:`pad`, from a geometry sensor's frame buffers (``FrameBuffers``).

        Their rows are an observation's, and their entries past ``count`` are padded as
        :meth:`pad` pads; they must be at least :attr:`size` long. No Observation is made.
        """
        valid = self._valid.copy()
        valid[:count] = 1
        return self._shown(ints[:, :self.size].copy(),
                           floats[:1 + self.quality_columns, :self.size].astype(np.float32), valid)

    def _shown(self, ints: np.ndarray, floats: np.ndarray, valid: np.ndarray
               ) -> dict[str, np.ndarray]:
        quality = floats[1] if self.quality_columns == 1 else floats[1:].T.copy()
        return {"ids": ints[ID], "azimuth": floats[AZIMUTH], "valid": valid, "quality": quality,
                "labels": ints[LABEL], "beacons": ints[BEACON]}
