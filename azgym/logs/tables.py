"""A log's tables read safely: CSV (or Parquet), capped in size, UTF-8, cells checked one by one.

Every cell is read as text first and parsed here, so that a bad cell becomes a problem naming its
file, line and column (:mod:`azgym.logs.problems`) instead of an exception from deep inside a
parser. Numbers are plain decimals (``-1.5``, ``2e-3``); ``nan``, ``inf``, ``1_000`` or a
number with spaces around it are refused, since a log that holds them was not written by a
careful logger. A Parquet file is read through pyarrow (the ``parquet`` extra,
:mod:`azgym.logs.parquet`). Table files are plain files in the log's folder, read with byte and
cell limits (:mod:`azgym.logs.files`).
"""

from __future__ import annotations

import csv
import io
import math
import re
from collections import Counter
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from azgym.logs.files import MAX_TABLE_CELLS, log_file, read_limited, wide_header
from azgym.logs.parquet import parquet_cells
from azgym.logs.problems import Problems, cut, shown

__all__ = ["Columns", "Table", "check_columns", "find_table", "floats", "integers",
           "parse_table", "read_table"]

_NUMBER = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_INTEGER = re.compile(r"[+-]?[0-9]{1,18}")
_NOT_FINITE = re.compile(r"[+-]?(?:nan|inf|infinity)", re.IGNORECASE)


@dataclass(frozen=True, eq=False)
class Columns:
    """A checked table's columns, by name (float64 or int64 arrays, or text lists)."""

    values: dict[str, Any]

    def __getitem__(self, key: str) -> Any:
        return self.values[key]


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
    """The file of table ``name`` (``name.csv`` or ``name.parquet``), or None if neither is.

    A folder, symlink or special file of that name is reported (:func:`~azgym.logs.files.log_file`).
    """
    found = [path for suffix in (".csv", ".parquet")
             if (path := log_file(folder, f"{name}{suffix}", problems)) is not None]
    if len(found) > 1:
        problems.add(found[1].name, f"both {name}.csv and {name}.parquet exist; keep one")
    return found[0] if found else None


def read_table(path: Path, problems: Problems) -> Table | None:
    """Read a table file; None (with the problem recorded) when it cannot be read at all."""
    data = read_limited(path, problems)
    return None if data is None else parse_table(path.name, data, problems)


def parse_table(file: str, data: bytes, problems: Problems) -> Table | None:
    """A table file's bytes as a table; None (with the problem recorded) if they cannot be.

    The bytes are Parquet if ``file`` ends with ``.parquet``, else CSV.
    """
    if file.endswith(".parquet"):
        cells = parquet_cells(data, file, problems)
        if cells is None:
            return None
        header, rows = cells
        return Table(file, header, rows, list(range(1, len(rows) + 1)), unit="row")
    try:
        text = data.decode("utf-8-sig")  # a byte-order mark, as spreadsheets write, is fine
    except UnicodeDecodeError as exc:
        problems.add(file, f"not UTF-8 text: byte 0x{data[exc.start]:02x} at offset "
                           f"{exc.start} (save the file as UTF-8)")
        return None
    return _csv_table(file, text, problems)


def _csv_table(file: str, text: str, problems: Problems) -> Table | None:
    """A CSV text's rows, stopping as soon as it holds more than :data:`MAX_TABLE_CELLS`.

    The header's cells count too, and a header too wide (:func:`wide_header`) stops it at once.
    """
    reader = csv.reader(io.StringIO(text, newline=""))
    rows: list[list[str]] = []
    lines: list[int] = []
    try:
        header = next(reader, None)
        cells = len(header or ())
        if wide_header(cells, file, problems):
            return None
        for row in reader:
            cells += len(row)
            if cells > MAX_TABLE_CELLS:
                problems.add(file, f"too many cells: more than {MAX_TABLE_CELLS} (rows × "
                                   "columns) by this line (split the recording into several "
                                   "logs)", reader.line_num)
                return None
            rows.append(row)
            lines.append(reader.line_num)
    except csv.Error as exc:
        problems.add(file, f"not a CSV file: {exc}", reader.line_num + 1)
        return None
    if not header:
        problems.add(file, "empty: the first line names the columns")
        return None
    return _shaped(Table(file, [name.strip() for name in header], rows, lines), problems)


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
    counts = Counter(table.header)
    for name in required:
        if name not in table.header:
            problems.add(table.file, f"no column {name!r} (columns: "
                                     f"{cut(', '.join(table.header), 200)})")
            ok = False
    for name, count in counts.items():
        if count > 1:
            problems.add(table.file, f"column {shown(name)} appears {count} times")
            ok = False
        elif name not in required + optional and not (prefix and name.startswith(prefix)):
            known = ", ".join(required + optional) + (f", {prefix}*" if prefix else "")
            problems.add(table.file, f"unknown column {shown(name)} (known: {known})")
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
            problem = f"{shown(cell)} is too large to be a float"
        elif _NOT_FINITE.fullmatch(cell):
            problem = f"{shown(cell)} is not finite (a finite number is required)"
        else:
            problem = "empty (a number is required)" if cell == "" else \
                f"{shown(cell)} is not a number"
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
                f"{shown(cell)} is not a whole number"
            table.report(problems, problem, k, column)
    return values, good
