"""A Parquet table's cells as text, its size checked from its metadata before it is read.

A Parquet file compresses well (30 million equal rows fit in 400 kB), so its size on disk says
nothing about the memory it takes: its row count and uncompressed size (the footer's metadata)
are checked against :mod:`azgym.logs.files`' limits first, and only columns of numbers or text
are read. Each value becomes the CSV cell that says the same (floats by ``repr``, so they parse
back exactly; NaN as ``nan``, refused as a CSV ``nan`` is; null as an empty cell).
"""

from __future__ import annotations

import math
from typing import Any

from azgym.errors import require
from azgym.logs.files import MAX_TABLE_BYTES, MAX_TABLE_CELLS
from azgym.logs.problems import Problems, cut

__all__ = ["parquet_cells"]


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
    try:
        table = parquet.read()
    except Exception as exc:  # noqa: BLE001
        problems.add(file, f"cannot be read as Parquet: {cut(str(exc), 200)}")
        return None
    if table.num_rows * table.num_columns > MAX_TABLE_CELLS:  # the metadata understated it
        problems.add(file, f"too many cells: more than {MAX_TABLE_CELLS} (rows × columns)")
        return None
    columns = [[_text(value) for value in column.to_pylist()] for column in table.columns]
    return list(table.column_names), [list(row) for row in zip(*columns, strict=True)]


def _small_enough(metadata: Any, file: str, problems: Problems) -> bool:
    """Whether the footer's row count and uncompressed size are within the limits."""
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
                or pa.types.is_decimal(kind) or pa.types.is_string(kind)
                or pa.types.is_large_string(kind) or pa.types.is_null(kind))


def _text(value: object) -> str:
    """A Parquet value as the CSV cell that says the same."""
    if value is None:
        return ""
    if isinstance(value, float):
        return "nan" if math.isnan(value) else repr(value)
    return str(value)
