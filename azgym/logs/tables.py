"""A log's tables read safely: CSV (or Parquet), capped in size, UTF-8, cells checked one by one.

Every cell is read as text first and parsed here, so that a bad cell becomes a problem naming its
file, line and column (:mod:`azgym.logs.problems`) instead of an exception from deep inside a
parser. Numbers are plain decimals (``-1.5``, ``2e-3``); ``nan``, ``inf``, ``1_000`` or a
number with spaces around it are refused, since a log that holds them was not written by a
careful logger. A Parquet file is read through pyarrow (the ``parquet`` extra).
"""

from __future__ import annotations

import csv
import io
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from azgym.errors import require
from azgym.logs.problems import Problems

MAX_TABLE_BYTES = 64 * 1024 * 1024
"""The largest table file read [bytes]: about a million detections."""
_NUMBER = re.compile(r"[+-]?(?:\d+(?:\.\d*)?|\.\d+)(?:[eE][+-]?\d+)?")
_INTEGER = re.compile(r"[+-]?\d{1,18}")
_NOT_FINITE = re.compile(r"[+-]?(?:nan|inf|infinity)", re.IGNORECASE)


@dataclass
class Table:
    """One table of a log: its header and every row's cells, as text.

    Attributes:
        file: Its file name, for messages.
        header: The column names.
        rows: Each row's cells.
        lines: Each row's place, for messages (CSV: its line in the file; Parquet: its row).
        unit: "line" (CSV) or "row" (Parquet).
    """

    file: str
    header: list[str]
    rows: list[list[str]]
    lines: list[int]
    unit: str = "line"

    def __len__(self) -> int:
        return len(self.rows)

    def has(self, column: str) -> bool:
        """Whether the table has that column."""
        return column in self.header

    def report(self, problems: Problems, message: str, k: int, column: str | None = None
               ) -> None:
        """Record a problem of row ``k`` (at a column)."""
        problems.add(self.file, message, self.lines[k], column, self.unit)

    def cells(self, column: str) -> list[str]:
        """Every row's cell of a column."""
        k = self.header.index(column)
        return [row[k] for row in self.rows]


def find_table(folder: Path, name: str, problems: Problems) -> Path | None:
    """The file of table ``name`` (``name.csv`` or ``name.parquet``), or None if neither is."""
    found = [folder / f"{name}{suffix}" for suffix in (".csv", ".parquet")
             if (folder / f"{name}{suffix}").is_file()]
    if len(found) > 1:
        problems.add(found[1].name, f"both {name}.csv and {name}.parquet exist; keep one")
    return found[0] if found else None


def read_table(path: Path, problems: Problems) -> Table | None:
    """Read a table file; None (with the problem recorded) when it cannot be read at all."""
    size = path.stat().st_size
    if size > MAX_TABLE_BYTES:
        problems.add(path.name, f"too large: {size} bytes, a log's table has at most "
                                f"{MAX_TABLE_BYTES} (split the recording into several logs)")
        return None
    if path.suffix == ".parquet":
        return _read_parquet(path, problems)
    data = path.read_bytes()
    try:
        text = data.decode("utf-8-sig")  # a byte-order mark, as spreadsheets write, is fine
    except UnicodeDecodeError as exc:
        problems.add(path.name, f"not UTF-8 text: byte 0x{data[exc.start]:02x} at offset "
                                f"{exc.start} (save the file as UTF-8)")
        return None
    reader = csv.reader(io.StringIO(text, newline=""))
    rows: list[list[str]] = []
    lines: list[int] = []
    try:
        header = next(reader, None)
        for row in reader:
            rows.append(row)
            lines.append(reader.line_num)
    except csv.Error as exc:
        problems.add(path.name, f"not a CSV file: {exc}", reader.line_num + 1)
        return None
    if not header:
        problems.add(path.name, "empty: the first line names the columns")
        return None
    return _shaped(Table(path.name, [name.strip() for name in header], rows, lines), problems)


def _read_parquet(path: Path, problems: Problems) -> Table | None:
    """A Parquet file's columns as text cells (floats by repr, so they parse back exactly)."""
    require("pyarrow", "parquet")
    import pyarrow.parquet as pq

    try:
        data = pq.read_table(path).to_pydict()
    except Exception as exc:  # noqa: BLE001 - pyarrow raises many types on a bad file
        problems.add(path.name, f"not a Parquet file: {exc}")
        return None
    header = list(data)
    columns = [[_text(value) for value in data[name]] for name in header]
    rows = [list(row) for row in zip(*columns, strict=True)]
    return Table(path.name, header, rows, list(range(1, len(rows) + 1)), unit="row")


def _text(value: object) -> str:
    """A Parquet value as the CSV cell that says the same."""
    if value is None:
        return ""
    if isinstance(value, float):
        return "" if math.isnan(value) else repr(value)
    return str(value)


def _shaped(table: Table, problems: Problems) -> Table:
    """The table without blank lines, each row of the wrong length reported and dropped."""
    width = len(table.header)
    kept = []
    for row, line in zip(table.rows, table.lines, strict=True):
        if len(row) == width:
            kept.append((row, line))
        elif row:  # a blank line is no row
            problems.add(table.file, f"{len(row)} cells, the header names {width} columns",
                         line)
    table.rows = [row for row, _ in kept]
    table.lines = [line for _, line in kept]
    return table


def check_columns(table: Table, required: tuple[str, ...], optional: tuple[str, ...],
                  problems: Problems, prefix: str = "") -> bool:
    """Report missing, unknown and repeated columns; whether the required ones are all there.

    A column starting with ``prefix`` (when one is given) is allowed too: quality columns.
    """
    ok = True
    for name in required:
        if name not in table.header:
            problems.add(table.file, f"no column {name!r} (columns: {', '.join(table.header)})")
            ok = False
    for name in table.header:
        if table.header.count(name) > 1:
            problems.add(table.file, f"column {name!r} appears {table.header.count(name)} times")
            ok = False
        elif name not in required + optional and not (prefix and name.startswith(prefix)):
            known = ", ".join(required + optional) + (f", {prefix}*" if prefix else "")
            problems.add(table.file, f"unknown column {name!r} (known: {known})")
    return ok


def floats(table: Table, column: str, problems: Problems, empty_ok: bool = False
           ) -> np.ndarray:
    """A column as finite float64 (NaN where empty, if ``empty_ok``, or where bad)."""
    values = np.full(len(table), math.nan)
    for k, cell in enumerate(table.cells(column)):
        if cell == "" and empty_ok:
            continue
        if _NUMBER.fullmatch(cell):
            values[k] = float(cell)
            if math.isfinite(values[k]):
                continue
            values[k] = math.nan
            problem = f"{cell} is too large to be a float"
        elif _NOT_FINITE.fullmatch(cell):
            problem = f"{cell!r} is not finite (a finite number is required)"
        else:
            problem = "empty (a number is required)" if cell == "" else \
                f"{cell!r} is not a number"
        table.report(problems, problem, k, column)
    return values


def integers(table: Table, column: str, problems: Problems, empty_ok: bool = False
             ) -> tuple[np.ndarray, np.ndarray]:
    """A column as int64, and which cells held a whole number (False where empty or bad)."""
    values = np.zeros(len(table), dtype=np.int64)
    good = np.zeros(len(table), dtype=bool)
    for k, cell in enumerate(table.cells(column)):
        if _INTEGER.fullmatch(cell):
            values[k], good[k] = int(cell), True
        elif not (cell == "" and empty_ok):
            problem = "empty (a whole number is required)" if cell == "" else \
                f"{cell!r} is not a whole number"
            table.report(problems, problem, k, column)
    return values, good
