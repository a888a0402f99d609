"""Fields of a parsed TOML or JSON file: one rule for a number, one reader naming the field.

Scenario files, sweep configurations, log manifests and profiles are all read the same way: a
parsed mapping whose values are checked one field at a time, each problem named by its field's
path (``racks[3].height``, ``sensor.field_of_view``) and worded here:

- a number (:class:`Number`): a finite int or float (never a boolean, NaN or infinity) within
  its bounds, each end open or closed, and within a magnitude cap; ``must be a finite number
  [rad], got nan``, ``must be > 0, got -0.01``, ``must be in [0, 1.5708) rad, got 2.0``;
- an integer (:class:`Number` with ``integer``): an int (never a boolean or a float, even an
  integer-valued one) within its bounds; its message always states them: ``must be an integer
  in [1, 4096], got 480.5``;
- a flag (:data:`FLAG`): ``true`` or ``false``, never a string or a number.

A :class:`Fields` reader either raises the first problem (a scenario, a sweep) or reports each
one to a collector and goes on (a log's manifest, a profile), so a file's problems are listed
together. A file may be hostile: a quoted value is shortened (:func:`shown`), and a number is
compared before it becomes a float (a 400-digit integer would overflow).
"""

from __future__ import annotations

import math
import reprlib
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Protocol

from azgym.errors import AzgymError, InvalidInputError, unknown_name

__all__ = ["FLAG", "Fields", "Flag", "Number", "Rule", "shown"]

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
        integer: Whether only an int is a value (else an int or a float).
    """

    low: float | None = None
    high: float | None = None
    low_open: bool = False
    high_open: bool = False
    cap: float | None = None
    unit: str = ""
    integer: bool = False

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

    def _within(self, value: float) -> bool:
        """Whether ``value`` (an int compares exactly, however large) is within the bounds."""
        low, high = self.low, self.high
        return not ((low is not None and (value <= low if self.low_open else value < low))
                    or (high is not None and (value >= high if self.high_open else value > high)))

    def problem(self, value: object) -> str | None:
        """What is wrong with ``value`` as this number, or None when it is valid."""
        if self.integer:
            if isinstance(value, bool) or not isinstance(value, int) or not self._within(value):
                kind = " ".join(filter(None, ("an integer", self.bounds(), self.unit)))
                return f"must be {kind}, got {shown(value)}"
            return None
        if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                (isinstance(value, float) and not math.isfinite(value)):
            unit = f" [{self.unit}]" if self.unit else ""
            return f"must be a finite number{unit}, got {shown(value)}"
        if not self._within(value):
            unit = f" {self.unit}" if self.unit else ""
            return f"must be {self.bounds()}{unit}, got {shown(value)}"
        cap = self.cap
        if cap is not None and abs(value) > cap:
            bound = f"<= {_bound(cap)}" if self.low is not None and self.low >= 0 \
                else f"in [{_bound(-cap)}, {_bound(cap)}]"
            return f"must be {bound}, got {shown(value)}"
        return None


@dataclass(frozen=True)
class Flag:
    """The rule for a flag: TOML's or JSON's ``true`` or ``false``, never a string or a number."""

    def problem(self, value: object) -> str | None:
        """What is wrong with ``value`` as a flag, or None when it is one."""
        return None if isinstance(value, bool) else f"must be true or false, got {shown(value)}"


FLAG = Flag()
"""The one flag rule."""


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
        problem = rule.problem(value)
        if problem is None and isinstance(value, (int, float)):  # the rule checked the type
            return float(value)
        raise self.fail(field, str(problem))

    def integer(self, value: object, field: str, low: int, high: int) -> int:
        """``value`` as an int in [``low``, ``high``] (raised otherwise)."""
        problem = Number(low, high, integer=True).problem(value)
        if problem is None and isinstance(value, int):  # the rule checked the type
            return value
        raise self.fail(field, str(problem))

    def boolean(self, value: object, field: str) -> bool:
        """``value`` as a flag (:data:`FLAG`; raised otherwise)."""
        if isinstance(value, bool):
            return value
        raise self.fail(field, str(FLAG.problem(value)))
