"""Reading the files azgym did not write: a model, a policy, a plug-in's file, anyone's.

Such a file may be hostile, so it is read by one rule (:func:`read_regular_file`): a regular file
(not a device, FIFO, socket or folder, which could read without end or wait for ever), opened
without blocking, its kind checked on the opened descriptor, and read up to a byte cap. A zip
archive in such bytes is opened once its entries are counted (:func:`open_archive`), and each
member is inflated in chunks up to a cap whatever its header declares (:func:`read_member`).
Each problem names the file (and the member) and is raised as the caller's error class.
"""

from __future__ import annotations

import io
import os
import stat
import zipfile
from collections.abc import Callable
from pathlib import Path

from azgym.errors import AzgymError, InvalidInputError

__all__ = ["CHUNK_BYTES", "COMPRESSIONS", "MAX_ENTRIES", "check_member", "open_archive",
           "read_member", "read_regular_file"]

CENTRAL_HEADER = b"PK\x01\x02"
"""The first bytes of each member's entry in a zip archive's central directory."""
MAX_ENTRIES = 4096
"""A file holding more central-directory entries than this is refused before it is opened
(:func:`open_archive`); a policy zip's PyTorch members are archives too, an entry a tensor."""
CHUNK_BYTES = 2**20
"""A member is inflated this much at a time, and counted (:func:`read_member`)."""
COMPRESSIONS = {zipfile.ZIP_STORED: "stored", zipfile.ZIP_DEFLATED: "deflated"}
"""The compressions of the members read (what numpy and stable-baselines3 write): Python's
bzip2 and lzma readers inflate a read's whole input at once, however much that yields."""
_KINDS = ((stat.S_ISDIR, "a folder"), (stat.S_ISFIFO, "a FIFO (a pipe)"),
          (stat.S_ISSOCK, "a socket"), (stat.S_ISCHR, "a device"), (stat.S_ISBLK, "a device"))
"""The kinds of file that are no regular file, as messages name them."""


def read_regular_file(path: Path, limit: int, what: str,
                      error: Callable[[str], AzgymError] = InvalidInputError) -> bytes:
    """A file's bytes: a regular file, read without blocking and up to ``limit`` bytes.

    The file is opened with ``O_NONBLOCK`` (a FIFO opens at once instead of waiting for a
    writer) and its kind is checked on the opened descriptor, so nothing can swap the path
    for a device between the check and the read.

    Args:
        path: The file.
        limit: The most bytes it may hold (the largest plausible model).
        what: What the file is, for the messages (``"model file"``, ``"policy file"``).
        error: The exception a problem raises.

    Raises:
        InvalidInputError: (or ``error``) The file is missing, not a regular file, unreadable
            or larger than ``limit``.
    """
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0)
    try:
        descriptor = os.open(path, flags)
    except FileNotFoundError:
        raise error(f"{path}: no such {what}") from None
    except OSError as exc:  # a socket cannot be opened (ENXIO): say what it is
        raise error(f"{path}: cannot read the {what}: "
                             f"{_not_regular(path) or exc.strerror or exc}") from None
    status = os.fstat(descriptor)
    if not stat.S_ISREG(status.st_mode):
        os.close(descriptor)
        kind = next((name for test, name in _KINDS if test(status.st_mode)), "not a file")
        raise error(f"{path}: cannot read the {what}: it is {kind}, not a "
                             "regular file")
    with os.fdopen(descriptor, "rb") as handle:
        try:
            data = handle.read(limit + 1) if status.st_size <= limit else b""
        except OSError as exc:
            raise error(f"{path}: cannot read the {what}: {exc.strerror or exc}"
                                 ) from None
    if status.st_size > limit or len(data) > limit:
        size = status.st_size if status.st_size > limit else f"more than {limit}"
        raise error(f"{path}: {size} bytes, larger than a {what} may be "
                             f"({limit // 2**20} MiB)")
    return data


def _not_regular(path: Path) -> str:
    """What ``path`` is when it is no regular file ("it is a socket, ..."), else ""."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return ""
    kind = next((name for test, name in _KINDS if test(mode)), "")
    return f"it is {kind}, not a regular file" if kind else ""


def open_archive(path: Path, data: bytes, what: str,
                 error: Callable[[str], AzgymError] = InvalidInputError) -> zipfile.ZipFile:
    """The zip archive in a file's bytes, once they hold at most :data:`MAX_ENTRIES` entries.

    Opening an archive builds an object for each entry its central directory lists, however
    many a forged one lists; so the entries' signatures are counted in the bytes first (a
    count that also finds the archives a member holds: a PyTorch file is one).

    Raises:
        InvalidInputError: (or ``error``) Too many entries.
        zipfile.BadZipFile: Not a zip archive (the caller words it).
    """
    if data.count(CENTRAL_HEADER) > MAX_ENTRIES:
        raise error(f"{path}: more than {MAX_ENTRIES} zip entries, more than a {what} "
                             "holds")
    return zipfile.ZipFile(io.BytesIO(data))


def check_member(path: Path, info: zipfile.ZipInfo, limit: int, what: str,
                 error: Callable[[str], AzgymError] = InvalidInputError) -> None:
    """Refuse a member compressed otherwise than :data:`COMPRESSIONS` or declared over ``limit``.

    Python's zip reader stops a member at its declared size, so a member that passes reads no
    more than ``limit`` bytes (:func:`read_member` counts them all the same).

    Raises:
        InvalidInputError: (or ``error``) Naming the file and the member.
    """
    if info.compress_type not in COMPRESSIONS:
        method = {zipfile.ZIP_BZIP2: "bzip2", zipfile.ZIP_LZMA: "lzma"}.get(
            info.compress_type, f"method {info.compress_type}")
        raise error(f"{path}: member {info.filename!r} is compressed with {method}; "
                             f"a {what}'s members are {' or '.join(COMPRESSIONS.values())}")
    if info.file_size > limit:
        raise error(f"{path}: member {info.filename!r} inflates to more than "
                             f"{_size(limit)}, more than a {what}'s member may")


def read_member(path: Path, archive: zipfile.ZipFile, info: zipfile.ZipInfo, limit: int,
                what: str, error: Callable[[str], AzgymError] = InvalidInputError) -> bytes:
    """A member's bytes, inflated in chunks and refused past ``limit`` whatever it declares.

    Raises:
        InvalidInputError: (or ``error``) Naming the file and the member
            (:func:`check_member`, or a member that inflates past ``limit``).
        zipfile.BadZipFile, EOFError, zlib.error: A damaged member (the caller words it).
    """
    check_member(path, info, limit, what, error)
    chunks: list[bytes] = []
    size = 0
    with archive.open(info) as stream:
        while chunk := stream.read(CHUNK_BYTES):
            size += len(chunk)
            if size > limit:
                raise error(f"{path}: member {info.filename!r} inflates to more "
                                     f"than {_size(limit)}, more than a {what}'s member may")
            chunks.append(chunk)
    return b"".join(chunks)


def _size(limit: int) -> str:
    """A byte limit as the messages give it: whole MiB, or bytes."""
    return f"{limit // 2**20} MiB" if limit % 2**20 == 0 else f"{limit} bytes"
