"""Field-level checks for scenario files: :class:`Reader` and :func:`parse_tables`.

Every value a scenario file gives passes through here, and every problem found in one is
worded here, as ``<file>: <field>: <problem>`` (e.g.
``paper-room.toml: beacons[3].width: must be > 0, got -0.01``). The table parsers
(:mod:`azgym.site.parse`, :mod:`azgym.site.parse_layout`, :mod:`azgym.site.parse_sensor`) say
which field must be what; this module says how a list, a table, a key or a text is checked and
what the message is, and takes the rule for a number and a flag (and their wording) from
:mod:`azgym.fields`, which every config file is read with.

A file may be hostile, so every value is bounded: no number's magnitude exceeds
:data:`MAX_MAGNITUDE` (a 400-digit integer or 1e300 is refused before it becomes a float), and a
value quoted in a message is shortened (:func:`shown`), so a huge or deeply nested value makes a
short message.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from typing import Any, TypeVar

from azgym.errors import ScenarioError
from azgym.fields import Fields, Number, shown

__all__ = ["MAX_ENTRIES", "MAX_INTEGER", "MAX_NAME", "NAME_CHARACTERS", "Reader", "name_problem",
           "parse_tables", "shown"]

_Element = TypeVar("_Element")

MAX_MAGNITUDE = 1e5
"""No number in a scenario file is larger in magnitude: 100 km, 100 000 px, 10⁵ times a beacon's
light. Far beyond any site, and small enough that squares and sums of coordinates stay exact to
far below a millimetre."""
MAX_TEXT = 1000
"""The longest text a scenario file may give (a name, a description) [characters]."""
MAX_ENTRIES = 10_000
"""The most tables an array of them (``[[beacons]]``, ``[[racks]]``, ...) or points a route may
have: far more than any site, and a bound on the checks that relate tables pairwise."""
MAX_INTEGER = 2**31 - 1
"""The largest integer a scenario file may give (a version, a beacon id): a signed 32-bit one."""

MAX_NAME = 100
"""The longest name a scenario may have [characters]."""
NAME_CHARACTERS = "A-Za-z0-9._-"
"""The characters of a plain file name, as a regular expression's character class."""
_NAME = re.compile(rf"[A-Za-z0-9][{NAME_CHARACTERS}]*")
"""A plain file name (output files and folders are named after a scenario, a log)."""


def name_problem(name: str, max_length: int = MAX_NAME) -> str | None:
    """Why ``name`` cannot name a scenario (or a log: ``max_length`` 64), or None when it can.

    A scenario's name becomes file and folder names (``results/layout/NAME``,
    ``NAME-plus-4.toml``), a log's a folder (``leaderboard/datasets/NAME``), so it is a plain
    file name: letters, digits, ``-``, ``_`` and ``.``, starting with a letter or a digit (no
    separator, no ``..``, not hidden, not an option), at most ``max_length`` characters.
    """
    if len(name) > max_length or not _NAME.fullmatch(name):
        return (f"must be a plain file name (ASCII letters, digits, '-', '_' and '.', starting "
                f"with a letter or a digit, at most {max_length} characters), got {shown(name)}")
    return None


class Reader:
    """Reads fields of one file, raising :class:`ScenarioError` that names file and field."""

    def __init__(self, origin: str) -> None:
        self.origin = origin
        self._fields = Fields(origin, error=ScenarioError)

    def fail(self, field: str, problem: str) -> ScenarioError:
        """The error for a problem with ``field``, prefixed with the file's name."""
        return ScenarioError(self._fields.message(field, problem))

    def keys(self, table: dict[str, Any], allowed: set[str], where: str) -> None:
        """Reject a key not in ``allowed`` (:meth:`azgym.fields.Fields.keys`).

        ``where`` is the table's path with its trailing dot (``"beacons[3]."``, ``""`` at the top).
        """
        self._fields.keys(table, allowed, where.rstrip("."))

    def table(self, value: Any, field: str, allowed: set[str]) -> dict[str, Any]:
        """``value``, checked to be a table whose keys are all in ``allowed``."""
        if not isinstance(value, dict):
            raise self.fail(field, "must be a table")
        self.keys(value, allowed, f"{field}.")
        return value

    def require(self, table: dict[str, Any], key: str, where: str = "") -> Any:
        """``table[key]``, which must be given."""
        if key not in table:
            raise self.fail(f"{where}{key}", "missing")
        return table[key]

    def number(self, value: Any, field: str, *, positive: bool = False,
               non_negative: bool = False, below: float | None = None,
               maximum: float = MAX_MAGNITUDE) -> float:
        """``value`` as a finite float, optionally > 0, >= 0 and/or < ``below``.

        Its magnitude must be at most ``maximum`` (:data:`MAX_MAGNITUDE` unless the field has a
        tighter bound).
        """
        low = 0.0 if positive or non_negative else None
        return self._fields.number(value, field, Number(low, below, low_open=positive,
                                                        high_open=True, cap=maximum))

    def fraction(self, value: Any, field: str) -> float:
        """``value`` as a number in [0, 1]: a share, a rate or a reflectivity."""
        return self._fields.number(value, field, Number(0.0, 1.0, cap=MAX_MAGNITUDE))

    def integer(self, value: Any, field: str, minimum: int = -MAX_INTEGER,
                maximum: int = MAX_INTEGER) -> int:
        """``value`` as an integer (booleans are not) in [``minimum``, ``maximum``]."""
        return self._fields.integer(value, field, minimum, maximum)

    def boolean(self, value: Any, field: str) -> bool:
        """``value`` as a boolean: TOML's ``true`` or ``false``, never a string or a number."""
        return self._fields.boolean(value, field)

    def count(self, entries: list[Any], field: str, most: int = MAX_ENTRIES) -> None:
        """Reject an array of more than ``most`` (:data:`MAX_ENTRIES`) entries."""
        if len(entries) > most:
            raise self.fail(field, f"must have at most {most} entries, got {len(entries)}")

    def vector(self, value: Any, field: str, length: int) -> list[float]:
        """``value`` as a list of ``length`` finite numbers."""
        if not isinstance(value, list) or len(value) != length:
            raise self.fail(field, f"must be a list of {length} numbers, got {shown(value)}")
        return [self.number(v, f"{field}[{k}]") for k, v in enumerate(value)]

    def text(self, value: Any, field: str) -> str:
        """``value`` as one printable line that is not blank, at most :data:`MAX_TEXT` long.

        Printable: a name or description is printed in listings, where a control character (an
        escape sequence) would act on the terminal.
        """
        if not isinstance(value, str) or not value.strip():
            raise self.fail(field, f"must be a non-empty string, got {shown(value)}")
        if len(value) > MAX_TEXT:
            raise self.fail(field, f"must be at most {MAX_TEXT} characters, got {len(value)}")
        if not value.isprintable():
            raise self.fail(field, f"must be one line of printable characters, got "
                            f"{shown(value)}")
        return value

    def name(self, value: Any, field: str) -> str:
        """``value`` as a scenario's name: text (:meth:`text`) that is a plain file name."""
        value = self.text(value, field)
        problem = name_problem(value)
        if problem:
            raise self.fail(field, problem)
        return value


def parse_tables(read: Reader, data: dict[str, Any], key: str,
                 parse: Callable[[Reader, dict[str, Any], int], _Element]
                 ) -> tuple[_Element, ...]:
    """Each table of the optional array ``[[key]]``, read by ``parse(read, table, index)``."""
    entries = data.get(key, [])
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise read.fail(key, f"must be an array of [[{key}]] tables")
    read.count(entries, key)
    return tuple(parse(read, entry, k) for k, entry in enumerate(entries))
