"""An entry's localizer and its files: pinned when the entry is made, checked when it is rerun.

A plug-in file (named in the spec) and a weight file (the ``weights`` hyperparameter) are part
of what was scored. When an entry is made (:func:`portable_localizer`) each must be the file the
run used (its SHA-256 in the results), and is stored relative to the entries folder with its
SHA-256; when it is verified (:func:`runnable_localizer`) each is found relative to the entry
and must still have that SHA-256.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from azgym.bench.leaderboard.entry_files import Entry, EntryLocalizer, LeaderboardError
from azgym.bench.leaderboard.plugin_files import (
    WEIGHTS,
    file_sha256,
    plugin_path,
    relative_path,
    relative_spec,
    resolve_spec,
    weights_path,
    weights_sha256,
)
from azgym.errors import InvalidInputError

__all__ = ["portable_localizer", "runnable_localizer"]


def portable_localizer(row: dict[str, Any], entries_dir: Path) -> EntryLocalizer:
    """The localizer as an entry stores it: its files relative to the entries folder, pinned.

    A plug-in file (in the spec) and a weight file (the ``weights`` hyperparameter) must be
    the files the run used; each is stored relative to ``entries_dir`` with its SHA-256.
    """
    spec, params = row["spec"], row["params"]
    localizer: EntryLocalizer = {"spec": spec, "params": params}
    file = plugin_path(spec) if isinstance(spec, str) else None
    if file is not None:
        path = Path(row["file"]) if "file" in row else file
        localizer["sha256"] = _as_run(path, row.get("file_sha256"), "localizer/spec",
                                      "plug-in file", file_sha256)
        localizer["spec"] = _relative(path, entries_dir, "localizer/spec",
                                      lambda: relative_spec(path, spec, entries_dir))
    weights = weights_path(params) if isinstance(params, dict) else None
    if weights is not None:
        where, path = f"localizer/params/{WEIGHTS}", Path(row.get("weights_file", weights))
        localizer["weights_sha256"] = _as_run(path, row.get("weights_sha256"), where,
                                              "weight file", weights_sha256)
        localizer["params"] = {**params, WEIGHTS: _relative(
            path, entries_dir, where, lambda: relative_path(path, entries_dir))}
    return localizer


def _as_run(path: Path, recorded: str | None, where: str, kind: str,
            digest_of: Callable[[Path], str]) -> str:
    """A localizer's file's SHA-256, once it is there and is the file the run used."""
    if not path.is_file():
        raise LeaderboardError(f"{where}: the {kind} {path} the results were made with is "
                               "missing")
    digest = _digest(path, where, digest_of)
    if recorded is not None and digest != recorded:
        raise LeaderboardError(f"{where}: {kind} changed since the run: {path} has sha256 "
                               f"{digest}, the run used {recorded}")
    return digest


def _digest(path: Path, where: str, digest_of: Callable[[Path], str]) -> str:
    """``digest_of(path)``; a weight file that cannot be read as one is refused by name."""
    try:
        return digest_of(path)
    except InvalidInputError as exc:  # a file that cannot be read as one (a model's too)
        raise LeaderboardError(f"{where}: {exc}") from None


def _relative(path: Path, entries_dir: Path, where: str, relative: Callable[[], str]) -> str:
    """``relative()``: a file named relative to the entries folder, or the reason it cannot."""
    try:
        return relative()
    except ValueError as exc:
        raise LeaderboardError(f"{where}: {path} cannot be named relative to "
                               f"{entries_dir}: {exc}") from None


def runnable_localizer(path: Path, entry: Entry) -> tuple[str, dict[str, Any]]:
    """The entry's localizer spec and hyperparameters, its files found and unchanged.

    A plug-in file and a weight file are found relative to the entry's folder, and must have
    the SHA-256 the entry was scored with.

    Raises:
        LeaderboardError: A file is missing, or changed since the entry was made.
    """
    localizer = entry["localizer"]
    spec, file = resolve_spec(localizer["spec"], path.parent)
    if file is not None:
        _unchanged(path, file, localizer["sha256"], ("localizer/spec", "localizer/sha256"),
                   ("plug-in file", "a plug-in"), file_sha256)
    params = localizer["params"]
    if isinstance(params.get(WEIGHTS), str):
        file = (path.parent / params[WEIGHTS]).resolve()
        _unchanged(path, file, localizer["weights_sha256"],
                   (f"localizer/params/{WEIGHTS}", "localizer/weights_sha256"),
                   ("weight file", "a weight file"), weights_sha256)
        params = {**params, WEIGHTS: str(file)}
    return spec, params


def _unchanged(path: Path, file: Path, stored: str, where: tuple[str, str],
               kind: tuple[str, str], digest_of: Callable[[Path], str]) -> None:
    """Refuse an entry's file that is missing or has another SHA-256 than ``stored``.

    ``where`` names the field that names the file, then the field of its SHA-256; ``kind`` the
    file's kind, then one such thing ("plug-in file", "a plug-in").
    """
    if not file.is_file():
        raise LeaderboardError(f"{path}: {where[0]}: the {kind[0]} {file} does not exist "
                               f"({kind[1]} is named relative to the entry's folder); put the "
                               "file there to verify the entry")
    digest = _digest(file, f"{path}: {where[0]}", digest_of)
    if digest != stored:
        raise LeaderboardError(f"{path}: {where[1]}: {kind[0]} changed since the entry was made: "
                               f"sha256 {digest}, the entry was scored with {stored}")
