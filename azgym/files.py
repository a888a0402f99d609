"""Writing azgym's output files: atomically, and never through a link or out of the folder.

Every file azgym writes (results, entries, the board, figures) goes through :func:`write_file`:
the bytes go to a temporary file beside the target, which then replaces it in one rename, so an
interrupted run leaves the old file or the new one, never half of one. A new file gets the mode
the user's umask gives any file (0644 under umask 022); a replaced file keeps its own. A target
that is a symbolic link, or whose folder is one, is refused: a planted link must not redirect a
write.

No command replaces what is already there unless told: :func:`claim_file` and
:func:`claim_folder` are the one rule, checked before any work starts, that an output file, or
the files a command writes into a folder, do not exist yet (or that ``--overwrite`` was given).
Only the files named are ever replaced; nothing else in the folder is touched or removed.
"""

from __future__ import annotations

import glob
import os
import secrets
import stat
import tempfile
from collections.abc import Iterable
from pathlib import Path

from azgym.errors import InvalidInputError

__all__ = ["claim_file", "claim_folder", "prepare_folder", "write_file"]


def prepare_folder(folder: Path) -> Path:
    """Create ``folder`` if needed and check it can be written, before any work is done.

    Raises:
        InvalidInputError: The folder is a symbolic link, or cannot be created or written.
    """
    if folder.is_symlink():
        raise InvalidInputError(f"{folder}: is a symbolic link; give a real folder")
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as exc:
        raise InvalidInputError(f"{folder}: cannot write there: {exc.strerror or exc}") from None
    return folder


def claim_file(path: Path, overwrite: bool, option: str) -> Path:
    """``path`` as an output file: refused when it is a folder, or exists without ``overwrite``.

    Args:
        path: The file to write.
        overwrite: Whether an existing file may be replaced.
        option: The option or argument that named it, for the message (``--out``).

    Raises:
        InvalidInputError: ``path`` is a folder, or exists and ``overwrite`` is false.
    """
    if path.is_dir():
        raise InvalidInputError(f"{option}: {path} is a folder; give a file name")
    return claim_folder(path.parent, [glob.escape(path.name)], overwrite, option) / path.name


def claim_folder(folder: Path, names: Iterable[str], overwrite: bool, option: str) -> Path:
    """``folder`` as an output folder: refused when it holds a file the command would write.

    Args:
        folder: The folder written into (it need not exist yet).
        names: The files the command writes there, as glob patterns (``error_map_k*.png``).
        overwrite: Whether those files may be replaced (nothing else is ever removed).
        option: The option or argument that named the folder, for the message (``--out``).

    Raises:
        InvalidInputError: Some of those files exist and ``overwrite`` is false.
    """
    if overwrite or not folder.is_dir():
        return folder
    taken = sorted({str(path) for name in names for path in folder.glob(name)})
    if taken:
        shown = ", ".join(taken[:5]) + (f" and {len(taken) - 5} more" if len(taken) > 5 else "")
        them = "it" if len(taken) == 1 else "them"
        raise InvalidInputError(f"{option}: {shown} already exist{'s' if len(taken) == 1 else ''}"
                                f"; nothing was written (--overwrite replaces {them}, and only "
                                "the files azgym writes)")
    return folder


def write_file(path: Path, data: bytes | str) -> Path:
    """Write ``data`` (text as UTF-8) to ``path`` atomically; refuse a link in the way.

    Raises:
        InvalidInputError: ``path`` or its folder is a symbolic link, or the write fails.
    """
    if path.is_symlink() or path.parent.is_symlink():
        raise InvalidInputError(f"{path}: is (or is in) a symbolic link; refusing to write "
                                "through it")
    content = data.encode("utf-8") if isinstance(data, str) else data
    temporary = path.parent / f".{path.name}.{secrets.token_hex(6)}.tmp"
    try:
        kept = stat.S_IMODE(path.stat().st_mode) if path.is_file() else None
        # O_EXCL: a fresh file, never one planted under the name; mode 0o666: the kernel takes
        # the user's umask off, as for any file an ordinary open creates.
        handle = os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW, 0o666)
    except OSError as exc:
        raise InvalidInputError(f"{path}: cannot write: {exc.strerror or exc}") from None
    try:
        with os.fdopen(handle, "wb") as stream:
            if kept is not None:
                os.fchmod(stream.fileno(), kept)  # a replaced file keeps its mode
            stream.write(content)
        os.replace(temporary, path)
    except BaseException as exc:  # an error or Ctrl-C: no temporary file is left behind
        temporary.unlink(missing_ok=True)
        if isinstance(exc, OSError):
            raise InvalidInputError(f"{path}: cannot write: {exc.strerror or exc}") from None
        raise
    return path
