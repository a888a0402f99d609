"""One rule for a number and for a flag; one reader naming the fields of a parsed file.

Scenario files, sweep configurations, log manifests and profiles are all read the same way: a
parsed mapping whose values are checked one field at a time, each problem named by its field's
path (``racks[3].height``, ``sensor.field_of_view``) and worded here:

- a number (:class:`Number`): a finite real number (an int, a float or a NumPy scalar; never a
  boolean, NaN or infinity, unless ``infinite`` lets +inf through) within its bounds, each end
  open or closed, and within a magnitude cap; ``must be a finite number [rad], got nan``,
  ``must be > 0, got -0.01``, ``must be in [0, 1.5708) rad, got 2.0``;
- an integer (:class:`Number` with ``integer``): an int or a NumPy integer (never a boolean or
  a float, even an integer-valued one) within its bounds; its message always states them:
  ``must be an integer in [1, 4096], got 480.5``;
- a flag (:class:`Flag`): ``true`` or ``false`` (:data:`FLAG`), never a string or a number;
  a Python argument's flag (``Flag(python=True)``) is ``True``, ``False`` or a NumPy bool.

The same rules check Python arguments (:mod:`azgym.arguments`, :mod:`azgym.hyperparameters`):
there a problem is worded after the argument's name (:func:`argument_error`:
``workers must be an integer >= 1, got 1.5``, ``Ransac.pr_hit must be in (0, 1), got 2``),
where a file's is worded after its field's path and a colon.

A :class:`Fields` reader either raises the first problem (a scenario, a sweep) or reports each
one to a collector and goes on (a log's manifest, a profile), so a file's problems are listed
together. A file may be hostile: a quoted value is shortened (:func:`shown`), and a number is
compared before it becomes a float (a 400-digit integer would overflow).
"""

from __future__ import annotations

import functools
import math
import numbers
import reprlib
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from azgym.errors import AzgymError, InvalidInputError, unknown_name

__all__ = ["FLAG", "Fields", "Flag", "Number", "Rule", "argument_error", "require", "shown"]

_SHORT = reprlib.Repr()
_SHORT.maxlevel, _SHORT.maxlist, _SHORT.maxstring, _SHORT.maxother = 2, 6, 40, 40
_SHORT.maxlong = 24


def shown(value: object) -> str:
    """``repr(value)``, shortened: a hostile value (huge, deeply nested) makes a short message."""
    return _SHORT.repr(value)


class Rule(Protocol):
    """What a field's value must be: :meth:`problem` says what is wrong with one, if anything."""

    def problem(self, value: object) -> str | None:
        """What is wrong with ``value`` (``must be ..., got ...``), or None when it is valid."""


def require(value: object, rule: Rule, fail: Callable[[str], Exception]) -> None:
    """Raise ``fail(problem)`` unless ``value`` satisfies ``rule``."""
    problem = rule.problem(value)
    if problem is not None:
        raise fail(problem)


def argument_error(name: str, problem: str) -> InvalidInputError:
    """The error for a problem of a Python argument: ``<name> <problem>``.

    A function's argument or a hyperparameter is named as it is written, without a colon
    (``workers must be an integer >= 1, got 1.5``); no name gives the problem alone (an argparse
    type, whose option argparse names itself).
    """
    return InvalidInputError(" ".join(part for part in (name, problem) if part))


def _bound(value: float) -> str:
    """A bound for a message: an int in full, a float as ``:g`` (``1.5708``, ``100000``)."""
    return str(value) if isinstance(value, int) else f"{value:g}"


@dataclass(frozen=True)
class Number:
    """The rule for a number field: its kind, bounds, magnitude cap and unit.

    Attributes:
        low: The lowest value (None: no lower bound).
        high: The highest value (None: no upper bound).
        low_open: Whether ``low`` itself is refused (``> low`` rather than ``>= low``).
        high_open: Whether ``high`` itself is refused.
        cap: The largest magnitude (None: no cap), a guard against hostile files checked after
            the bounds: a field's own bounds say what makes sense, the cap what is safe.
        unit: The unit, quoted in messages (``rad``: ``[rad]`` after the kind, ``rad`` after
            the bounds).
        integer: Whether only an integer (an int or a NumPy integer) is a value (else any
            real number: an int, a float, a NumPy scalar).
        infinite: Whether +inf is a value too (a gate that refuses nothing, say; not for an
            integer), if the bounds and the cap allow it.
    """

    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    cap: float | None = None
    unit: str = ""
    integer: bool = False
    infinite: bool = False

    def bounds(self) -> str:
        """The bounds in words: ``in [0, 1)``, ``> 0``, ``<= 10``, or "" when there are none."""
        low, high = self.low, self.high
        if low is not None and high is not None:
            return (f"in {'(' if self.low_open else '['}{_bound(low)}, {_bound(high)}"
                    f"{')' if self.high_open else ']'}")
        if low is not None:
            return f"{'>' if self.low_open else '>='} {_bound(low)}"
        if high is not None:
            return f"{'<' if self.high_open else '<='} {_bound(high)}"
        return ""

    def _within(self, value: numbers.Real) -> bool:
        """Whether ``value`` (an int compares exactly, however large) is within the bounds."""
        low, high = self.low, self.high  # the value on the left: a Real orders only by < and <=
        return ((low is None or not (value <= low if self.low_open else value < low))
                and (high is None or (value < high if self.high_open else value <= high)))

    def problem(self, value: object) -> str | None:
        """What is wrong with ``value`` as this number, or None when it is valid."""
        if self.integer:
            if isinstance(value, bool) or not isinstance(value, numbers.Integral) \
                    or not self._within(value):
                kind = " ".join(filter(None, ("an integer", self.bounds(), self.unit)))
                return f"must be {kind}, got {shown(value)}"
            return None
        # A rational number (an int of any size) is finite and never made a float here (a huge
        # one would overflow): only a float-like one can be NaN or infinite.
        if isinstance(value, bool) or not isinstance(value, numbers.Real) or not (
                isinstance(value, numbers.Rational) or math.isfinite(value)
                or (self.infinite and value == math.inf)):
            kind = "a finite number or inf" if self.infinite else "a finite number"
            unit = f" [{self.unit}]" if self.unit else ""
            return f"must be {kind}{unit}, got {shown(value)}"
        if not self._within(value):
            unit = f" {self.unit}" if self.unit else ""
            return f"must be {self.bounds()}{unit}, got {shown(value)}"
        cap = self.cap
        if cap is not None and (value < -cap or not value <= cap):
            bound = f"<= {_bound(cap)}" if self.low is not None and self.low >= 0 \
                else f"in [{_bound(-cap)}, {_bound(cap)}]"
            return f"must be {bound}, got {shown(value)}"
        return None

    def as_float(self, value: object, fail: Callable[[str], Exception]) -> float:
        """``value`` as a float; ``fail(problem)`` is raised unless it satisfies this rule."""
        problem = self.problem(value)
        if problem is None and isinstance(value, numbers.Real):  # the rule checked the type
            try:
                return float(value)
            except OverflowError:  # an int of hundreds of digits, which no bound stopped
                problem = f"must be a number within a float's range, got {shown(value)}"
        raise fail(str(problem))

    def as_int(self, value: object, fail: Callable[[str], Exception]) -> int:
        """``value`` (of this integer rule) as an int; ``fail(problem)`` is raised otherwise."""
        problem = self.problem(value)
        if problem is None and isinstance(value, numbers.Integral):  # the rule checked the type
            return int(value)
        raise fail(str(problem))


@dataclass(frozen=True)
class Flag:
    """The rule for a flag: ``true`` or ``false``, never a string or a number.

    Attributes:
        python: Whether the flag is a Python argument (a hyperparameter): then NumPy's bool is a
            flag too, and the message says ``True or False``; else it is a file's (TOML's or
            JSON's ``true`` or ``false``).
    """

    python: bool = False

    def problem(self, value: object) -> str | None:
        """What is wrong with ``value`` as a flag, or None when it is one."""
        if isinstance(value, bool) or (self.python and isinstance(value, np.bool_)):
            return None
        words = "True or False" if self.python else "true or false"
        return f"must be {words}, got {shown(value)}"


FLAG = Flag()
"""The flag rule of a file's field."""


class Fields:
    """Reads the fields of one parsed file, naming each problem by its field's path.

    A problem is worded ``<origin>: <field>: <problem>`` (``<field>: <problem>`` without an
    origin). Without ``report``, :meth:`check` raises it as ``error``; with ``report``, it is
    passed there and reading goes on. :meth:`number`, :meth:`integer` and :meth:`boolean`
    always raise: they return the checked value.

    Args:
        origin: The file, as messages name it (``paper-room.toml``), or "".
        error: The exception a problem raises (:class:`InvalidInputError` by default).
        report: Where each problem goes instead, when the file's problems are collected.
    """

    def __init__(self, origin: str = "", *, error: Callable[[str], AzgymError] = InvalidInputError,
                 report: Callable[[str], None] | None = None) -> None:
        self.origin = origin
        self.error = error
        self.report = report

    def message(self, field: str, problem: str) -> str:
        """A problem of ``field``, worded as this file's."""
        return ": ".join(part for part in (self.origin, field, problem) if part)

    def fail(self, field: str, problem: str) -> AzgymError:
        """The error for a problem of ``field`` (to raise)."""
        return self.error(self.message(field, problem))

    def check(self, value: object, field: str, rule: Rule) -> bool:
        """Whether ``value`` satisfies ``rule``: a problem is reported (raised without a report)."""
        problem = rule.problem(value)
        if problem is None:
            return True
        if self.report is None:
            raise self.fail(field, problem)
        self.report(self.message(field, problem))
        return False

    def keys(self, table: dict[str, object], known: Iterable[str], where: str = "") -> bool:
        """Whether every key of the table at ``where`` is ``known``.

        Each other key is a problem of ``where``, worded as every unknown name is
        (:func:`azgym.errors.unknown_name`: the valid keys and the closest, a long key cut);
        reported, or the first raised without a report.
        """
        valid = sorted(known)
        fine = True
        for key in table:
            if key not in valid:
                problem = str(unknown_name("key", key, valid))
                if self.report is None:
                    raise self.fail(where, problem)
                self.report(self.message(where, problem))
                fine = False
        return fine

    def number(self, value: object, field: str, rule: Number) -> float:
        """``value`` as a float, which must satisfy ``rule`` (raised otherwise)."""
        return rule.as_float(value, functools.partial(self.fail, field))

    def integer(self, value: object, field: str, low: int, high: int) -> int:
        """``value`` as an int in [``low``, ``high``] (raised otherwise)."""
        return Number(low, high, integer=True).as_int(value, functools.partial(self.fail, field))

    def boolean(self, value: object, field: str) -> bool:
        """``value`` as a flag (:data:`FLAG`; raised otherwise)."""
        if isinstance(value, bool):
            return value
        raise self.fail(field, str(FLAG.problem(value)))
