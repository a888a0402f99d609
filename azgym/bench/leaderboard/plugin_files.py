"""Plug-in localizer files in results and entries: where the file is, and what was in it.

A spec ``path/file.py:Class`` names a file relative to where it was typed. ``azgym bench``
records the file's absolute path and SHA-256 in ``results.json``; a leaderboard entry stores the
spec relative to the entry's own folder, with that SHA-256, so that ``verify`` finds the file
from any working folder and can tell a changed file from a changed result.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path, PurePosixPath
from typing import TypedDict

__all__ = ["PluginRecord", "file_sha256", "is_portable", "plugin_path", "plugin_record",
           "relative_spec", "resolve_spec"]


class PluginRecord(TypedDict, total=False):
    """A plug-in file as ``results.json`` records it: its absolute path and SHA-256."""

    file: str
    file_sha256: str


def plugin_path(spec: str) -> Path | None:
    """The file a ``path/file.py:Class`` spec names, resolved; None for a name or a module.

    The same reading as :func:`azgym.localize.registry.resolve`: a target ending in ``.py``
    is a file.
    """
    target, _, _ = spec.rpartition(":")
    return Path(target).expanduser().resolve() if target.endswith(".py") else None


def file_sha256(path: Path) -> str:
    """The SHA-256 of a file's bytes."""
    return hashlib.sha256(path.read_bytes()).hexdigest()


def plugin_record(spec: str) -> PluginRecord:
    """What ``results.json`` keeps of a spec's file: its absolute path and SHA-256 (or nothing).

    A file that does not exist is left out: the run scored it as unable to build.
    """
    path = plugin_path(spec)
    if path is None or not path.is_file():
        return {}
    return {"file": str(path), "file_sha256": file_sha256(path)}


def relative_spec(path: Path, spec: str, folder: Path) -> str:
    """The spec with its file given relative to ``folder``, with ``/`` separators.

    Raises:
        ValueError: The file and the folder share no root (another drive on Windows).
    """
    relative = os.path.relpath(path, folder.resolve())
    return f"{PurePosixPath(Path(relative).as_posix())}:{spec.rpartition(':')[2]}"


def is_portable(spec: str) -> bool:
    """Whether a file spec is relative (an absolute one only works on the machine it names)."""
    target = spec.rpartition(":")[0]
    return not (target.startswith(("/", "\\", "~")) or (len(target) > 1 and target[1] == ":"))


def resolve_spec(spec: str, folder: Path) -> tuple[str, Path | None]:
    """A stored spec made runnable: a file spec's path resolved against ``folder``.

    Returns:
        The spec to run and the file it names (None for a name or a module).
    """
    target, _, attribute = spec.rpartition(":")
    if not target.endswith(".py"):
        return spec, None
    path = (folder / target).resolve()
    return f"{path}:{attribute}", path
