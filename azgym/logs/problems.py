"""What is wrong with a log: every problem found, each naming its file, line and column.

A log is checked whole before it is refused, so that one run of ``azgym import`` lists what to
fix (up to :data:`MAX_PROBLEMS`), not the first problem only.
"""

from __future__ import annotations

from azgym.errors import InvalidInputError

MAX_PROBLEMS = 50
"""Problems listed before the rest are only counted."""
MAX_SHOWN = 40
"""The most characters of a cell a message quotes (a longer one is cut, with "…")."""


def cut(text: str, limit: int = MAX_SHOWN) -> str:
    """Text for a message, cut after ``limit`` characters (with "…")."""
    return text if len(text) <= limit else text[:limit] + "…"


def shown(value: object, limit: int = MAX_SHOWN) -> str:
    """A cell (or any value from the log) quoted for a message: its repr, cut to ``limit``."""
    return cut(repr(value), limit)


class LogError(InvalidInputError):
    """A log folder is missing, malformed or cannot be used for what was asked.

    Attributes:
        problems: Each problem, as ``"file, line N, column C: what"``.
    """

    def __init__(self, folder: str, problems: list[str], total: int | None = None) -> None:
        self.problems = list(problems)
        total = len(problems) if total is None else total
        more = f"\n  … and {total - len(problems)} more" if total > len(problems) else ""
        noun = "problem" if total == 1 else "problems"
        super().__init__(f"{folder}: {total} {noun} in the log:\n  " + "\n  ".join(problems)
                         + more)


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
