"""What is wrong with a log: every problem found, each naming its file, line and column.

A log is checked whole before it is refused, so that one run of ``azgym import`` lists what to
fix (up to :data:`MAX_PROBLEMS`), not the first problem only.
"""

from __future__ import annotations

from azgym.errors import LogError

__all__ = ["MAX_PROBLEMS", "LogChanged", "LogError", "Problems", "cut", "places", "seconds",
           "shown"]

MAX_PROBLEMS = 50
"""Problems listed before the rest are only counted."""
MAX_SHOWN = 40
"""The most characters of a cell a message quotes (a longer one is cut, with "…")."""
MAX_PLACES = 5
"""The most runs of lines a message lists (then it counts the rest)."""


def cut(text: str, limit: int = MAX_SHOWN) -> str:
    """Text for a message, cut after ``limit`` characters (with "…")."""
    return text if len(text) <= limit else text[:limit] + "…"


def shown(value: object, limit: int = MAX_SHOWN) -> str:
    """A cell (or any value from the log) quoted for a message: its repr, cut to ``limit``."""
    return cut(repr(value), limit)


def seconds(time: float) -> str:
    """A time for a message, in full: ``1248440000.123 s``, never ``1.24844e+09 s``.

    The shortest text that reads back as the same float, so that a message locates the row
    even with epoch times.
    """
    return f"{float(time)!r} s"


def places(lines: list[int], unit: str = "line", limit: int = MAX_PLACES) -> str:
    """Lines (or rows) for a message, runs joined: ``lines 2-40, 57 and 3 more`` (lines)."""
    runs: list[list[int]] = []
    for line in lines:
        if runs and line == runs[-1][1] + 1:
            runs[-1][1] = line
        else:
            runs.append([line, line])
    parts = [f"{a}" if a == b else f"{a}-{b}" for a, b in runs[:limit]]
    rest = sum(b - a + 1 for a, b in runs[limit:])
    more = f" and {rest} more" if rest else ""
    plural = "s" if len(lines) > 1 else ""
    return f"{unit}{plural} {', '.join(parts)}{more}"


class Problems:
    """A collector of a log's problems; :meth:`check` raises them all at once."""

    def __init__(self, folder: str) -> None:
        self.folder = folder
        self.found: list[str] = []
        self.total = 0

    def add(self, file: str, message: str, line: int | None = None,
            column: str | None = None, unit: str = "line") -> None:
        """Record one problem of ``file`` (at a line or row, and column, where there is one)."""
        self.total += 1
        if len(self.found) < MAX_PROBLEMS:
            where = [file]
            if line is not None:
                where.append(f"{unit} {line}")
            if column is not None:
                where.append(f"column {column}")
            self.found.append(f"{', '.join(where)}: {message}")

    def __bool__(self) -> bool:
        return self.total > 0

    def check(self) -> None:
        """Raise :class:`LogError` listing every problem, if there is one."""
        if self.total:
            raise LogError(self.folder, self.found, self.total)


class LogChanged(LogError):
    """A log's files are not the ones expected: their SHA-256 differs (found before parsing).

    Attributes:
        sha256: The digest the files have.
    """

    def __init__(self, folder: str, sha256: str, expected: str) -> None:
        super().__init__(folder, [f"its files' SHA-256 is {sha256}, not the {expected} "
                                  "expected"])
        self.sha256 = sha256
