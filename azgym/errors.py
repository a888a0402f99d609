"""Exceptions raised by azgym.

Every error a user can cause derives from :class:`AzgymError`, and the ones caused by a bad
value also derive from :class:`ValueError`, so ``except ValueError`` keeps working. Messages
name the offending field, the problem and, where there is one, the fix.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable, Mapping
from typing import Any

__all__ = ["AzgymError", "DatasetUnavailable", "DependencyNotInstalled", "InvalidInputError",
           "LeaderboardError", "LocalizerCheckError", "LogError", "MapperCheckError",
           "ModelFileError", "ProtocolError", "ScenarioError", "TrackerCheckError",
           "UnknownNameError", "require", "unknown_name"]


MAX_SHOWN_NAME = 40
"""An unknown name longer than this is cut in its message (a hostile file's 1 MB key makes a
short message, and only its start is compared with the valid names)."""

class AzgymError(Exception):
    """Base class of every exception raised by azgym."""


class InvalidInputError(AzgymError, ValueError):
    """An argument has the wrong shape, dtype, value or is not finite."""


class UnknownNameError(AzgymError, KeyError):
    """A name (localizer, scenario) is not registered."""

    def __str__(self) -> str:  # KeyError would otherwise quote the whole message.
        return str(self.args[0]) if self.args else ""


class ScenarioError(AzgymError, ValueError):
    """A scenario file is malformed."""


class ModelFileError(InvalidInputError):
    """A learned model's weight file is missing, malformed, or made for another model or azgym."""


class DependencyNotInstalled(AzgymError, ImportError):
    """An optional dependency is missing; the message says which extra to install."""


class LocalizerCheckError(AzgymError, AssertionError):
    """A localizer failed one of the conformance checks (:mod:`azgym.localize.checks`)."""


class TrackerCheckError(AzgymError, AssertionError):
    """A tracker failed one of the conformance checks (:mod:`azgym.track.checks`)."""


class MapperCheckError(AzgymError, AssertionError):
    """A mapper failed one of the conformance checks (:mod:`azgym.mapping.checks`)."""


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


class LeaderboardError(AzgymError, ValueError):
    """An entry is malformed, tampered with, or does not match what it claims."""


class DatasetUnavailable(LeaderboardError):
    """A dataset entry's log is neither in the datasets folder nor shipped: it cannot be checked.

    Attributes:
        entry: The entry (schema, identity and per-frame file already checked).
    """

    def __init__(self, message: str, entry: Mapping[str, Any]) -> None:
        super().__init__(message)
        self.entry = entry


class ProtocolError(Exception):
    """A worker sent something that is not a message of the runner's protocol.

    Never shown to a user as theirs: the runner charges the worker's frame and starts a fresh one.
    """


def unknown_name(kind: str, name: str, known: Iterable[str]) -> UnknownNameError:
    """Build an :class:`UnknownNameError` that lists the valid names and suggests the closest.

    Args:
        kind: What was looked up, e.g. ``"localizer"``.
        name: The name that was not found.
        known: Every valid name.
    """
    known = sorted(known)
    close = difflib.get_close_matches(name[:MAX_SHOWN_NAME * 2], known, n=1)
    hint = f" Did you mean {close[0]!r}?" if close else ""
    shown = name if len(name) <= MAX_SHOWN_NAME else f"{name[:MAX_SHOWN_NAME - 3]}..."
    return UnknownNameError(
        f"unknown {kind} {shown!r}.{hint} Valid {_plural(kind)}: {', '.join(known) or '(none)'}."
    )


def _plural(kind: str) -> str:
    """"localizer" -> "localizers"; a kind already plural ("ids") stays as it is."""
    return kind if kind.endswith("s") else kind + "s"


def require(module: str, extra: str) -> None:
    """Raise :class:`DependencyNotInstalled` unless ``module`` can be imported.

    Args:
        module: The importable module name, e.g. ``"matplotlib"``.
        extra: The azgym extra that installs it, e.g. ``"plot"``.
    """
    import importlib.util

    if importlib.util.find_spec(module) is None:
        raise DependencyNotInstalled(
            f"{module} is not installed; run: pip install \"azgym[{extra}]\""
        )
