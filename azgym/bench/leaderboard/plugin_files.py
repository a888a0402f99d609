"""The files a localizer is made of, in results and entries: where each is, and what was in it.

A spec ``path/file.py:Class`` names a plug-in file, and a ``weights`` hyperparameter
(``ng-ransac:weights=path/model.npz``) a weight file, each relative to where it was typed.
``azgym bench`` records each file's absolute path and SHA-256 in ``results.json``
(:func:`plugin_record`); a leaderboard entry stores the spec and the weight path relative to the
entry's own folder, with those SHA-256s, so that ``verify`` finds the files from any working
folder and can tell a changed file from a changed result.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
from collections.abc import Mapping
from pathlib import Path, PurePosixPath
from typing import Any, TypedDict

from azgym.errors import ModelFileError
from azgym.localize.learned.weights import MAX_FILE_BYTES
from azgym.untrusted import read_regular_file

__all__ = ["WEIGHTS", "PluginRecord", "file_sha256", "is_portable", "is_relative", "plugin_path",
           "plugin_record", "relative_path", "relative_spec", "resolve_spec", "weights_path",
           "weights_sha256"]

WEIGHTS = "weights"
"""The hyperparameter that names a learned localizer's weight file."""


class PluginRecord(TypedDict, total=False):
    """A run's files as ``results.json`` records them: each one's absolute path and SHA-256.

    Attributes:
        file: A plug-in's file.
        file_sha256: Its SHA-256.
        weights_file: The weight file the ``weights`` hyperparameter names.
        weights_sha256: Its SHA-256.
    """

    file: str
    file_sha256: str
    weights_file: str
    weights_sha256: str


def plugin_path(spec: str) -> Path | None:
    """The file a ``path/file.py:Class`` spec names, resolved; None for a name or a module.

    The same reading as :func:`azgym.localize.registry.resolve`: a target ending in ``.py``
    is a file.
    """
    target, _, _ = spec.rpartition(":")
    return Path(target).expanduser().resolve() if target.endswith(".py") else None


def weights_path(params: Mapping[str, Any]) -> Path | None:
    """The weight file a localizer's hyperparameters name, resolved; None for the shipped one."""
    value = params.get(WEIGHTS)
    return Path(value).expanduser().resolve() if isinstance(value, str) else None


def file_sha256(path: Path) -> str:
    """The SHA-256 of a plug-in file, read as every file azgym did not write is (capped).

    Raises:
        InvalidInputError: The file is missing, no regular file, or larger than a model file.
    """
    return hashlib.sha256(read_regular_file(path, MAX_FILE_BYTES, "plug-in file")).hexdigest()


def weights_sha256(path: Path) -> str:
    """The SHA-256 of a weight file, read as every model file is read (a regular file, capped).

    Raises:
        ModelFileError: The file is missing, no regular file, or too large for a model file.
    """
    return hashlib.sha256(read_regular_file(path, MAX_FILE_BYTES, "model file",
                                            ModelFileError)).hexdigest()


def plugin_record(spec: str, params: Mapping[str, Any] | None = None) -> PluginRecord:
    """What ``results.json`` keeps of a contender's files: their absolute paths and SHA-256s.

    The plug-in file of ``spec`` and the weight file of ``params``; a file that cannot be
    read is left out: the run scored its localizer as unable to build.
    """
    record: PluginRecord = {}
    path = plugin_path(spec)
    if path is not None and path.is_file():
        record["file"], record["file_sha256"] = str(path), file_sha256(path)
    weights = weights_path(params or {})
    if weights is not None:
        with contextlib.suppress(ModelFileError):
            record["weights_sha256"] = weights_sha256(weights)
            record["weights_file"] = str(weights)
    return record


def relative_path(path: Path, folder: Path) -> str:
    """A file's path relative to ``folder``, with ``/`` separators.

    Raises:
        ValueError: The file and the folder share no root (another drive on Windows).
    """
    return str(PurePosixPath(Path(os.path.relpath(path, folder.resolve())).as_posix()))


def relative_spec(path: Path, spec: str, folder: Path) -> str:
    """The spec with its file given relative to ``folder`` (:func:`relative_path`).

    Raises:
        ValueError: The file and the folder share no root (another drive on Windows).
    """
    return f"{relative_path(path, folder)}:{spec.rpartition(':')[2]}"


def is_relative(target: str) -> bool:
    """Whether a path is relative (an absolute one only works on the machine it names)."""
    return not (target.startswith(("/", "\\", "~")) or (len(target) > 1 and target[1] == ":"))


def is_portable(spec: str) -> bool:
    """Whether a file spec names its file relative to where it is read (:func:`is_relative`)."""
    return is_relative(spec.rpartition(":")[0])


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
