"""Scenario data as TOML text: the writer for the flat schema of ``envs/*.toml``.

:mod:`tomllib` only reads, so a generated scenario is written here. The schema is flat: top-level
keys, tables of scalars and arrays (``[room]``, ``[camera]``, ...), and arrays of such tables
(``[[beacons]]``, ``[[racks]]``, ...). Values are strings, booleans, integers, finite floats and
arrays of them (nested one level, for waypoints); floats are written by :func:`repr`, which reads
back to the same float, so ``tomllib.loads(to_toml(data)) == data`` holds bit for bit.
"""

from __future__ import annotations

import json
import math
from typing import Any

from azgym.errors import InvalidInputError

__all__ = ["to_toml"]


def to_toml(data: dict[str, Any], comment: str = "") -> str:
    """``data`` (parsed-TOML form of a scenario) as TOML text, ``comment`` lines on top.

    Top-level scalars first, then each table, then each array of tables, in ``data``'s order.

    Raises:
        InvalidInputError: A value TOML (or this writer) cannot hold, naming its key.
    """
    lines = [f"# {line}" if line else "#" for line in comment.splitlines()]
    if lines:
        lines.append("")
    scalars = {k: v for k, v in data.items() if not _is_table(v) and not _is_table_array(v)}
    lines += [f"{_key(k)} = {_value(v, k)}" for k, v in scalars.items()]
    for key, value in data.items():
        if _is_table(value):
            lines += ["", f"[{_key(key)}]", *_pairs(value, key)]
        elif _is_table_array(value):
            for k, table in enumerate(value):
                lines += ["", f"[[{_key(key)}]]", *_pairs(table, f"{key}[{k}]")]
    return "\n".join(lines) + "\n"


def _is_table(value: Any) -> bool:
    return isinstance(value, dict)


def _is_table_array(value: Any) -> bool:
    return isinstance(value, list) and bool(value) and all(isinstance(v, dict) for v in value)


def _pairs(table: dict[str, Any], where: str) -> list[str]:
    """``key = value`` lines of a table whose values are scalars or arrays."""
    return [f"{_key(k)} = {_value(v, f'{where}.{k}')}" for k, v in table.items()]


def _key(key: str) -> str:
    """A bare key if it is one (letters, digits, ``_``, ``-``), else a quoted one."""
    if key and all(c.isascii() and (c.isalnum() or c in "_-") for c in key):
        return key
    return _value(key, "key")


def _value(value: Any, where: str) -> str:
    """One TOML value: a string, boolean, integer, finite float or an array of them."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if not math.isfinite(value):
            raise InvalidInputError(f"{where}: must be finite to be written, got {value!r}")
        return repr(value)
    if isinstance(value, str):
        # A JSON string is a TOML basic string, but for DEL, which TOML wants escaped.
        return json.dumps(value, ensure_ascii=False).replace("\x7f", "\\u007f")
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_value(v, f"{where}[{k}]") for k, v in enumerate(value)) + "]"
    raise InvalidInputError(f"{where}: cannot be written as TOML: {type(value).__name__}")
