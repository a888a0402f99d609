"""One rule per kind of numeric argument: whole numbers, positive numbers, seeds, time limits.

Environments, the runner, the sweeps, the exports and the command line check their numeric
arguments with these, so a ``workers=1.5``, a ``ray_range=0`` or a ``seed=-1`` is refused where it
is given, with the argument's name, instead of failing later deep inside a loop. Each is a
:class:`azgym.fields.Number` rule, worded after the argument's name (``workers must be an integer
>= 1, got 1.5``, ``ray_range must be > 0 m, got 0``).
"""

from __future__ import annotations

import functools

from azgym.fields import Number, argument_error

__all__ = ["MAX_SEED", "MIN_TIME_LIMIT", "positive_number", "seed", "time_limit", "whole_number"]


def whole_number(name: str, value: object, minimum: int = 1) -> int:
    """``value`` as an int, refusing anything that is not a whole number >= ``minimum``."""
    return Number(minimum, integer=True).as_int(value, functools.partial(argument_error, name))


def positive_number(name: str, value: object, unit: str) -> float:
    """``value`` as a float, refusing anything that is not a finite number > 0 [``unit``].

    A dimensionless number's unit is "": its message quotes none.
    """
    rule = Number(0, low_open=True, unit=unit)
    return rule.as_float(value, functools.partial(argument_error, name))


MAX_SEED = 2**31
"""Seeds are whole numbers in [0, MAX_SEED): any seed numpy's generators take, and the same range
everywhere a seed is given (runs, sweeps, layout analyses, exports, result files)."""

_SEED = Number(0, MAX_SEED, high_open=True, integer=True)


def seed(name: str, value: object) -> int:
    """``value`` as a seed: a whole number in [0, :data:`MAX_SEED`)."""
    return _SEED.as_int(value, functools.partial(argument_error, name))


MIN_TIME_LIMIT = 0.01
"""The shortest time limit a localizer may be given per frame [s]. Below it the limit times the
operating system, not the localizer: a frame's allowance runs on the runner's clock and includes
handing the frame to a worker and its answer back (a pipe, a scheduler's time slice, a Ray
round trip), so every frame would time out, each costing a worker, and the run would be all
timeouts whatever the localizer."""

_TIME_LIMIT = Number(MIN_TIME_LIMIT, unit="s")


def time_limit(name: str, value: object) -> float:
    """``value`` as a time limit in seconds: a finite number >= :data:`MIN_TIME_LIMIT`."""
    return _TIME_LIMIT.as_float(value, functools.partial(argument_error, name))
