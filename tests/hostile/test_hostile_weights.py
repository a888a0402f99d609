"""Weight and policy files that would read without end, wait for input or inflate without bound.

A weight path is anyone's to give (``ng-ransac:weights=PATH`` on the command line, in a sweep or
in a navigation board file), and so is a policy zip. Each attack runs in a child process with a
time limit and an address-space limit, so a regression fails here quickly instead of hanging
the tests or exhausting the machine's memory.
"""

from __future__ import annotations

import os
import struct
import sys
import zipfile
import zlib
from pathlib import Path

import pytest
from helpers import bounded_outcome

pytestmark = pytest.mark.skipif(sys.platform == "win32", reason="devices and FIFOs are POSIX")

MEMORY_LIMIT = 1536 * 2**20
"""The child's address space [bytes]: room for azgym and numba, not for a runaway read."""
CONTINUOUS = ("__import__('types').SimpleNamespace("
              "action_space=__import__('gymnasium').spaces.Box(-1, 1, (2,)))")
"""What a continuous-action environment shows the policy check before anything is driven."""
TIME_LIMIT = 60.0
"""The child's time [s]: importing azgym takes a few seconds, a refusal none."""


def refusal(code: str, stdin: int | None = None) -> str:
    """What the child prints: the type and message of the error ``code`` raises."""
    return bounded_outcome(code, memory_bytes=MEMORY_LIMIT, seconds=TIME_LIMIT, stdin=stdin)


def ng_ransac_with(weights: str, stdin: int | None = None) -> str:
    """The refusal of ``make_localizer("ng-ransac", weights=weights)``."""
    return refusal(f"""
        from azgym import make_localizer
        make_localizer("ng-ransac", weights={weights!r})
        """, stdin)


def test_a_device_is_no_weight_file():
    # It read /dev/zero without end (19 GB in 20 s), or to a MemoryError under a limit.
    assert ng_ransac_with("/dev/zero") == (
        "ModelFileError /dev/zero: cannot read the model file: it is a device, not a regular "
        "file")


def test_standard_input_is_not_waited_for():
    # A pipe nobody writes to: reading it waited for ever.
    read, write = os.pipe()
    try:
        answer = ng_ransac_with("/dev/stdin", stdin=read)
    finally:
        os.close(read)
        os.close(write)
    assert answer == ("ModelFileError /dev/stdin: cannot read the model file: it is a FIFO "
                      "(a pipe), not a regular file")


def test_a_fifo_is_not_waited_for(tmp_path):
    # Opening a FIFO for reading blocks until a writer comes: it hung azgym sweep.
    fifo = tmp_path / "weights.npz"
    os.mkfifo(fifo)
    assert ng_ransac_with(str(fifo)) == (
        f"ModelFileError {fifo}: cannot read the model file: it is a FIFO (a pipe), not a "
        "regular file")


def test_a_navigation_board_file_naming_a_device_is_refused():
    # What a navigation board file's localizer is checked with: it took leaderboard build down.
    assert refusal("""
        from azgym.nav.estimator import resolve_estimator
        resolve_estimator("ng-ransac:weights=/dev/zero")
        """) == ("ModelFileError /dev/zero: cannot read the model file: it is a device, not a "
                 "regular file")


def test_a_policy_path_that_is_a_fifo_is_not_waited_for(tmp_path):
    fifo = tmp_path / "policy.zip"
    os.mkfifo(fifo)
    assert refusal(f"""
        from azgym.nav.policy_file import load_policy
        load_policy({str(fifo)!r}, {CONTINUOUS})
        """) == (f"ModelFileError {fifo}: cannot read the policy file: it is a FIFO (a pipe), "
                 "not a regular file")


def bomb(path: Path, inflated: int, declared: int, method: int = zipfile.ZIP_DEFLATED) -> Path:
    """A policy zip whose ``data`` member inflates to ``inflated`` zero bytes.

    Written in a moment: one deflate block of 1 MiB of zeros (about 1 kB, flushed so that it
    stands alone) repeated, then the final block. The headers declare ``declared`` bytes.
    """
    chunk = 2**20
    block = zlib.compressobj(9, zlib.DEFLATED, -15)
    one = block.compress(bytes(chunk)) + block.flush(zlib.Z_FULL_FLUSH)
    stream = one * (inflated // chunk) + zlib.compressobj(9, zlib.DEFLATED, -15).flush()
    with zipfile.ZipFile(path, "w", zipfile.ZIP_STORED) as archive:
        archive.writestr("data", stream)
    data = bytearray(path.read_bytes())
    local, central = 0, data.rindex(b"PK\x01\x02")
    struct.pack_into("<H", data, local + 8, method)
    struct.pack_into("<I", data, local + 22, declared)
    struct.pack_into("<H", data, central + 10, method)
    struct.pack_into("<I", data, central + 24, declared)
    path.write_bytes(bytes(data))
    return path


def policy_refusal(path: Path) -> str:
    """The refusal of the policy file's check before anything is unpickled."""
    return refusal(f"""
        from azgym.nav.policy_file import load_policy
        load_policy({str(path)!r}, {CONTINUOUS})
        """)


def test_a_zip_bomb_policy_is_refused_by_its_declared_size(tmp_path):
    # 3 MB that inflate to 3 GiB: the pre-check ended in a raw MemoryError.
    path = bomb(tmp_path / "bomb.zip", 3 * 2**30, 3 * 2**30)
    assert path.stat().st_size < 4 * 2**20
    assert policy_refusal(path) == (
        f"ModelFileError {path}: member 'data' inflates to more than 512 MiB, more than a "
        "policy file's member may")


def test_a_zip_bomb_whose_header_lies_is_refused_while_inflating(tmp_path):
    # The header says 1 kB: the member is inflated in chunks, no further than it declares.
    path = bomb(tmp_path / "liar.zip", 256 * 2**20, 1024)
    assert policy_refusal(path) == (
        f"ModelFileError {path}: not a readable zip (Bad CRC-32 for file 'data'); give a "
        "stable-baselines3 .zip saved by model.save()")


def test_a_member_in_an_unbounded_compression_is_refused(tmp_path):
    # bzip2 and lzma members inflate a read's whole input at once, whatever it yields.
    path = bomb(tmp_path / "bzip2.zip", 2**20, 2**20, method=zipfile.ZIP_BZIP2)
    assert policy_refusal(path) == (
        f"ModelFileError {path}: member 'data' is compressed with bzip2; a policy file's "
        "members are stored or deflated")
