"""Writing azgym's output files: atomically, and never through a link or out of the folder.

Every file azgym writes (results, entries, the board, figures) goes through :func:`write_file`:
the bytes go to a temporary file beside the target, which then replaces it in one rename, so an
interrupted run leaves the old file or the new one, never half of one. A target that is a
symbolic link, or whose folder is one, is refused: a planted link must not redirect a write.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from azgym.errors import InvalidInputError

__all__ = ["prepare_folder", "write_file"]


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


def write_file(path: Path, data: bytes | str) -> Path:
    """Write ``data`` (text as UTF-8) to ``path`` atomically; refuse a link in the way.

    Raises:
        InvalidInputError: ``path`` or its folder is a symbolic link, or the write fails.
    """
    if path.is_symlink() or path.parent.is_symlink():
        raise InvalidInputError(f"{path}: is (or is in) a symbolic link; refusing to write "
                                "through it")
    content = data.encode("utf-8") if isinstance(data, str) else data
    handle, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(handle, "wb") as stream:
            stream.write(content)
        os.replace(temporary, path)
    except OSError as exc:
        Path(temporary).unlink(missing_ok=True)
        raise InvalidInputError(f"{path}: cannot write: {exc.strerror or exc}") from None
    return path
