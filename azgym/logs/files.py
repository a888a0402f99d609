"""A log's files opened safely: plain files in the log's own folder, read up to a byte limit.

A log comes from someone else. Its tables and map file must be regular files directly in its
folder: a symlink (to ``/etc/passwd``, say) or a name that resolves elsewhere is refused, and a
file is read with a byte limit rather than trusting its size on disk (``/proc`` files say 0).
The limits on a table's bytes, cells and columns keep a hostile or mistaken table from exhausting
memory or time.
"""

from __future__ import annotations

import stat
from pathlib import Path

from azgym.logs.problems import Problems

__all__ = ["MAX_TABLE_BYTES", "MAX_TABLE_CELLS", "MAX_TABLE_COLUMNS", "log_file", "read_limited",
           "wide_header"]

MAX_TABLE_BYTES = 64 * 1024 * 1024
"""The largest table file read [bytes] (a Parquet table: also its uncompressed size)."""
MAX_TABLE_CELLS = 4_000_000
"""The most cells (rows × columns) a table holds: a million rows of four columns, e.g. a
million frames (28 h at 10 Hz) or a 200 Hz IMU over 5.5 h. Reading a table keeps each cell as
text (tens of bytes each), so this bounds a table's memory at a few hundred MB. The header's
cells count too."""
MAX_TABLE_COLUMNS = 100
"""The most columns a table has: a log's widest table names seven columns, or four and its quality
columns (a handful), so a header wider than this is no log's."""


def log_file(folder: Path, name: str, problems: Problems, report_as: str | None = None
             ) -> Path | None:
    """``folder/name`` if it is a regular file in the folder itself (no symlink), else None.

    Records a problem (of ``report_as``, default the name) when it exists but is no such file;
    nothing when it does not exist at all.
    """
    path = folder / name
    if not (path.is_symlink() or path.exists()):
        return None
    where = report_as or name
    if Path(name).name != name or path.is_symlink() or \
            path.resolve().parent != folder.resolve():
        problems.add(where, f"{name!r} is not a file in the log's folder (a symlink or a path "
                            "elsewhere: copy the file into the folder)")
        return None
    if not stat.S_ISREG(path.stat().st_mode):
        kind = "a folder" if path.is_dir() else "not a regular file"
        problems.add(where, f"{name!r} is not a file in the log's folder ({kind})")
        return None
    return path


def read_limited(path: Path, problems: Problems, limit: int = MAX_TABLE_BYTES
                 ) -> bytes | None:
    """A file's bytes, or None (a problem recorded) when it holds more than ``limit``."""
    size = path.stat().st_size
    shown = str(size)
    if size <= limit:
        with path.open("rb") as file:
            data = file.read(limit + 1)
        if len(data) <= limit:
            return data
        shown = f"more than {limit}"  # the size on disk was wrong (a /proc file says 0)
    problems.add(path.name, f"too large: {shown} bytes, a log's table has at most {limit} "
                            "(split the recording into several logs)")
    return None


def wide_header(width: int, file: str, problems: Problems) -> bool:
    """Whether a table's header names more than :data:`MAX_TABLE_COLUMNS` (a problem recorded)."""
    if width <= MAX_TABLE_COLUMNS:
        return False
    problems.add(file, f"too many columns: the header names {width}, a log's table has at most "
                       f"{MAX_TABLE_COLUMNS} (is the file a log's table? a missing line break?)")
    return True
