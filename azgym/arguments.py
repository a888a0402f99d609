"""One rule per kind of numeric argument: whole numbers, positive numbers, seeds, time limits.

Environments, the runner, the sweeps, the exports and the command line check their numeric
arguments with these, so a ``workers=1.5``, a ``ray_range=0`` or a ``seed=-1`` is refused where it
is given, with the argument's name, instead of failing later deep inside a loop.
"""

from __future__ import annotations

import math
import numbers

from azgym.errors import InvalidInputError

__all__ = ["MAX_SEED", "MIN_TIME_LIMIT", "positive_number", "seed", "time_limit", "whole_number"]


def whole_number(name: str, value: object, minimum: int = 1) -> int:
    """``value`` as an int, refusing anything that is not a whole number >= ``minimum``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < minimum:
        raise InvalidInputError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return int(value)


def positive_number(name: str, value: object, unit: str) -> float:
    """``value`` as a float, refusing anything that is not a finite number > 0."""
    if (isinstance(value, bool) or not isinstance(value, numbers.Real)
            or not math.isfinite(value) or value <= 0):
        raise InvalidInputError(f"{name} must be a finite number > 0 [{unit}], got {value!r}")
    return float(value)


MAX_SEED = 2**31
"""Seeds are whole numbers in [0, MAX_SEED): any seed numpy's generators take, and the same range
everywhere a seed is given (runs, sweeps, layout analyses, exports, result files)."""


def seed(name: str, value: object) -> int:
    """``value`` as a seed: a whole number in [0, :data:`MAX_SEED`)."""
    if (isinstance(value, bool) or not isinstance(value, numbers.Integral)
            or not 0 <= int(value) < MAX_SEED):
        raise InvalidInputError(f"{name} must be a whole number in [0, 2**31), got {value!r}")
    return int(value)


MIN_TIME_LIMIT = 0.01
"""The shortest time limit a localizer may be given per frame [s]. Below it the limit times the
operating system, not the localizer: a frame's allowance runs on the runner's clock and includes
handing the frame to a worker and its answer back (a pipe, a scheduler's time slice, a Ray
round trip), so every frame would time out, each costing a worker, and the run would be all
timeouts whatever the localizer."""


def time_limit(name: str, value: object) -> float:
    """``value`` as a time limit in seconds: a finite number >= :data:`MIN_TIME_LIMIT`."""
    if (isinstance(value, bool) or not isinstance(value, numbers.Real)
            or not math.isfinite(value) or value < MIN_TIME_LIMIT):
        raise InvalidInputError(f"{name} must be a number of seconds >= {MIN_TIME_LIMIT:g}, "
                                f"got {value!r}")
    return float(value)
