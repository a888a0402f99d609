"""Field-level checks for scenario files: :class:`Reader` and :func:`parse_tables`.

Every value a scenario file gives passes through here, and every problem found in one is
worded here, as ``<file>: <field>: <problem>`` (e.g.
``paper-room.toml: beacons[3].width: must be > 0, got -0.01``). The table parsers
(:mod:`azgym.site.parse`, :mod:`azgym.site.parse_layout`, :mod:`azgym.site.parse_sensor`) say
which field must be what; this module alone says how a number, a list, a table or a key is
checked and what the message is, so a rule and its wording live in one place.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Callable
from typing import Any, TypeVar

from azgym.errors import ScenarioError

_Element = TypeVar("_Element")


class Reader:
    """Reads fields of one file, raising :class:`ScenarioError` that names file and field."""

    def __init__(self, origin: str) -> None:
        self.origin = origin

    def fail(self, field: str, problem: str) -> ScenarioError:
        """The error for a problem with ``field``, prefixed with the file's name."""
        return ScenarioError(f"{self.origin}: {field}: {problem}")

    def keys(self, table: dict[str, Any], allowed: set[str], where: str) -> None:
        """Reject a key not in ``allowed``, suggesting the closest valid one (typos)."""
        for key in table:
            if key not in allowed:
                close = difflib.get_close_matches(key, sorted(allowed), n=1)
                hint = f" Did you mean {close[0]!r}?" if close else ""
                raise self.fail(f"{where}{key}", f"unknown key.{hint} "
                                f"Valid keys: {', '.join(sorted(allowed))}")

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
               non_negative: bool = False, below: float | None = None) -> float:
        """``value`` as a finite float, optionally > 0, >= 0 and/or < ``below``."""
        if isinstance(value, bool) or not isinstance(value, (int, float)) or \
                not math.isfinite(value):
            raise self.fail(field, f"must be a finite number, got {value!r}")
        if positive and not value > 0:
            raise self.fail(field, f"must be > 0, got {value!r}")
        if non_negative and value < 0:
            raise self.fail(field, f"must be >= 0, got {value!r}")
        if below is not None and value >= below:
            raise self.fail(field, f"must be < {below:g}, got {float(value)}")
        return float(value)

    def fraction(self, value: Any, field: str) -> float:
        """``value`` as a number in [0, 1]: a share, a rate or a reflectivity."""
        share = self.number(value, field, non_negative=True)
        if share > 1.0:
            raise self.fail(field, f"must be in [0, 1], got {share}")
        return share

    def integer(self, value: Any, field: str, minimum: int | None = None) -> int:
        """``value`` as an integer (booleans are not), optionally >= ``minimum``."""
        if isinstance(value, bool) or not isinstance(value, int) or \
                (minimum is not None and value < minimum):
            bound = "" if minimum is None else f" >= {minimum}"
            raise self.fail(field, f"must be an integer{bound}, got {value!r}")
        return value

    def vector(self, value: Any, field: str, length: int) -> list[float]:
        """``value`` as a list of ``length`` finite numbers."""
        if not isinstance(value, list) or len(value) != length:
            raise self.fail(field, f"must be a list of {length} numbers, got {value!r}")
        return [self.number(v, f"{field}[{k}]") for k, v in enumerate(value)]

    def text(self, value: Any, field: str) -> str:
        """``value`` as a string that is not blank."""
        if not isinstance(value, str) or not value.strip():
            raise self.fail(field, f"must be a non-empty string, got {value!r}")
        return value


def parse_tables(read: Reader, data: dict[str, Any], key: str,
                 parse: Callable[[Reader, dict[str, Any], int], _Element]
                 ) -> tuple[_Element, ...]:
    """Each table of the optional array ``[[key]]``, read by ``parse(read, table, index)``."""
    entries = data.get(key, [])
    if not isinstance(entries, list) or not all(isinstance(e, dict) for e in entries):
        raise read.fail(key, f"must be an array of [[{key}]] tables")
    return tuple(parse(read, entry, k) for k, entry in enumerate(entries))
