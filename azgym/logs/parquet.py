"""A Parquet table's cells as text, its size checked before and while it is read.

A Parquet file compresses well (30 million equal rows fit in 400 kB), so its size on disk says
nothing about the memory it takes: its width, row count and uncompressed size (the footer's
metadata) are checked against :mod:`azgym.logs.files`' limits first, and only columns of numbers
or text are read. The footer may lie, and a dictionary-encoded text column decodes one value per
row (a 10 kB file can hold a million rows of one 8 kB string: 8 GB decoded), so the file is then
read :data:`BATCH_ROWS` rows at a time with its text columns kept dictionary-encoded, and the
rows and the text decoded so far are counted against the same limits (the text against
:data:`~azgym.logs.files.MAX_TABLE_BYTES`, the most a CSV table may hold) before a batch becomes
cells. Each value becomes the CSV cell that says the same (floats by ``repr``, so they parse back
exactly; NaN as ``nan``, refused as a CSV ``nan`` is; null as an empty cell).
"""

from __future__ import annotations

import math
from typing import Any

from azgym.errors import require
from azgym.logs.files import MAX_TABLE_BYTES, MAX_TABLE_CELLS, wide_header
from azgym.logs.problems import Problems, cut

__all__ = ["BATCH_ROWS", "parquet_cells"]

BATCH_ROWS = 4096
"""Rows decoded at a time: the memory a batch takes before its text is counted is this many
rows' values (a text column's as indices into its dictionary)."""


def parquet_cells(data: bytes, file: str, problems: Problems
                  ) -> tuple[list[str], list[list[str]]] | None:
    """The header and rows (as text) of a Parquet file's bytes; None if it cannot be used."""
    require("pyarrow", "parquet")
    import pyarrow as pa
    import pyarrow.parquet as pq

    try:
        parquet = pq.ParquetFile(pa.BufferReader(data))
    except Exception as exc:  # noqa: BLE001 - pyarrow raises many types on a bad file
        problems.add(file, f"not a Parquet file: {cut(str(exc), 200)}")
        return None
    if not _small_enough(parquet.metadata, file, problems):
        return None
    bad = [field for field in parquet.schema_arrow if not _plain(pa, field.type)]
    for field in bad:
        problems.add(file, f"type {field.type} is neither numbers nor text (a table's columns "
                           "are numbers, or text for labels, sequences and events)",
                     column=field.name)
    if bad:
        return None
    text = [field.name for field in parquet.schema_arrow if _is_text(pa, field.type)]
    try:
        parquet = pq.ParquetFile(pa.BufferReader(data), read_dictionary=text)
        columns = _decoded(parquet, file, problems)
    except Exception as exc:  # noqa: BLE001
        problems.add(file, f"cannot be read as Parquet: {cut(str(exc), 200)}")
        return None
    if columns is None:
        return None
    return list(parquet.schema_arrow.names), [list(row) for row in zip(*columns, strict=True)]


def _decoded(parquet: Any, file: str, problems: Problems) -> list[list[str]] | None:
    """Each column's cells, read batch by batch; None once the rows or the text pass a limit."""
    import pyarrow as pa
    import pyarrow.compute as pc

    width = parquet.metadata.num_columns
    columns: list[list[str]] = [[] for _ in range(width)]
    rows = text = 0
    for batch in parquet.iter_batches(batch_size=BATCH_ROWS):
        rows += batch.num_rows
        if rows * width > MAX_TABLE_CELLS:  # the metadata understated it
            problems.add(file, f"too many cells: more than {MAX_TABLE_CELLS} (rows × columns) "
                               f"by row {rows} (the footer said {parquet.metadata.num_rows} "
                               "rows)")
            return None
        for array in batch.columns:
            if pa.types.is_dictionary(array.type):  # each row's text is its dictionary value's
                text += pc.sum(pc.binary_length(array.dictionary).take(array.indices)
                               ).as_py() or 0
            elif _is_text(pa, array.type):
                text += pc.sum(pc.binary_length(array)).as_py() or 0
        if text > MAX_TABLE_BYTES:
            problems.add(file, f"too large: its text decodes to more than {MAX_TABLE_BYTES} "
                               f"bytes by row {rows}, a log's table has at most "
                               f"{MAX_TABLE_BYTES} (a dictionary-encoded text column whose "
                               "values are long, or a footer that understates the size?)")
            return None
        for cells, array in zip(columns, batch.columns, strict=True):
            cells += [_text(value) for value in array.to_pylist()]
    return columns


def _small_enough(metadata: Any, file: str, problems: Problems) -> bool:
    """Whether the footer's row count and uncompressed size are within the limits."""
    if wide_header(metadata.num_columns, file, problems):
        return False
    cells = metadata.num_rows * metadata.num_columns
    if cells > MAX_TABLE_CELLS:
        problems.add(file, f"too many cells: {metadata.num_rows} rows × {metadata.num_columns} "
                           f"columns, a log's table has at most {MAX_TABLE_CELLS} (split the "
                           "recording into several logs)")
        return False
    size = sum(metadata.row_group(k).total_byte_size for k in range(metadata.num_row_groups))
    if size > MAX_TABLE_BYTES:
        problems.add(file, f"too large: {size} bytes uncompressed, a log's table has at most "
                           f"{MAX_TABLE_BYTES} (split the recording into several logs)")
        return False
    return True


def _plain(pa: Any, kind: Any) -> bool:
    """Whether a column type is numbers or text (or all null)."""
    return bool(pa.types.is_integer(kind) or pa.types.is_floating(kind)
                or pa.types.is_decimal(kind) or _is_text(pa, kind) or pa.types.is_null(kind))


def _is_text(pa: Any, kind: Any) -> bool:
    """Whether a column type is text."""
    return bool(pa.types.is_string(kind) or pa.types.is_large_string(kind))


def _text(value: object) -> str:
    """A Parquet value as the CSV cell that says the same."""
    if value is None:
        return ""
    if isinstance(value, float):
        return "nan" if math.isnan(value) else repr(value)
    return str(value)
