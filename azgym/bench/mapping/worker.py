"""A mapper's side of the mapping benchmark: its calls on one case, in a sealed process.

A mapper's calls on one case (the drive's prefixes at the case's checkpoints, in time order,
then the full drive) run in a process of its own, forked from the benchmark's fork server
(:func:`azgym.bench.run.processes.context`), which never held anything of the run. So the
process only ever holds the drive up to the call it is answering: nothing of a later frame, and
nothing of another case. It is sealed as the localizers' workers are
(:func:`azgym.bench.run.worker.seal`: standard streams to ``/dev/null``, every other descriptor
closed, death with its parent, capabilities dropped), then builds the mapper
(:func:`~azgym.mapping.registry.make_mapper`) and answers each problem it is sent.

What crosses: each problem as bytes (:func:`encode_problem`: arrays in NumPy's ``.npy``
format, read back with ``allow_pickle=False``, and a JSON header), never the truth; back,
framed messages: :data:`BUILDING`, :data:`READY`, then per call :data:`SURVEYING` and the
answer as JSON (ids, xy, covariances, moved; or an error's text). The parent reads them with a
byte cap (:func:`messages`, :data:`ANSWER_CAP`) and checks each answer (:func:`read_answer`):
nothing a mapper sends is unpickled or trusted.
"""

from __future__ import annotations

import io
import json
import os
import signal
from typing import Any

import numpy as np

from azgym.bench.run.wire import framed, pack, unframed, unpack, write_all
from azgym.bench.run.worker import describe, seal
from azgym.core import BeaconMap
from azgym.errors import AzgymError, InvalidInputError, ProtocolError
from azgym.mapping.base import MapAnswer, map_answer
from azgym.mapping.problem import Drive, Prior, SurveyFrame
from azgym.mapping.registry import make_mapper
from azgym.profile import Profile

__all__ = ["ANSWER_CAP", "BUILDING", "READY", "SURVEYING", "decode_problem", "encode_problem",
           "messages", "read_answer", "serve"]

ANSWER_CAP = 32 << 20
"""The most bytes a mapper's answer may take (JSON of the most beacons an answer may place,
:data:`~azgym.mapping.base.MAX_BEACONS`, with room to spare) [bytes]."""
BUILDING = b"B"
"""Sent once the process is sealed, before the mapper is built."""
READY = b"R"
"""Sent once the mapper is built."""
SURVEYING = b"S"
"""Sent as a call into the mapper begins (the time limit counts from it)."""
_ANSWER_KEYS = {"ids", "xy", "covariances", "moved"}


def encode_problem(drive: Drive, prior: Prior) -> bytes:
    """A drive and a prior as bytes (``.npy`` arrays in an ``.npz`` archive, no pickle)."""
    packed = [pack("", f.measurements, motion=f.motion) for f in drive.frames]
    header = {"name": drive.name, "start": None if drive.start is None else list(drive.start),
              "anchors": list(prior.anchors), "map": prior.beacons is not None,
              "quality": [list(p[6]) for p in packed]}
    parts: dict[str, np.ndarray] = {
        "header": np.frombuffer(json.dumps(header).encode(), np.uint8),
        "times": np.array([f.time for f in drive.frames], dtype=np.float64),
        "sizes": np.array([[len(p[3]), len(p[4]), len(p[5] or b""), len(p[7] or b"")]
                           for p in packed], dtype=np.int64).reshape(-1, 4),
        "blob": np.frombuffer(b"".join(p[3] + p[4] + (p[5] or b"") + (p[7] or b"")
                                       for p in packed), np.uint8)}
    if prior.beacons is not None:
        parts |= {"ids": prior.beacons.ids, "xyz": prior.beacons.xyz,
                  "width": prior.beacons.width}
    buffer = io.BytesIO()
    np.savez(buffer, allow_pickle=False, **parts)
    return buffer.getvalue()


def decode_problem(data: bytes) -> tuple[Drive, Prior]:
    """:func:`encode_problem`'s drive and prior; each frame's arrays read-only."""
    with np.load(io.BytesIO(data), allow_pickle=False) as archive:
        arrays = {name: archive[name] for name in archive.files}
    header = json.loads(arrays["header"].tobytes())
    blob = arrays["blob"].tobytes()
    frames, at = [], 0
    for time, sizes, shape in zip(arrays["times"].tolist(), arrays["sizes"].tolist(),
                                  header["quality"], strict=True):
        parts = []
        for size in sizes:
            parts.append(blob[at:at + size])
            at += size
        frame = unpack(("", "", None, parts[0], parts[1], parts[2] if sizes[2] else None,
                        tuple(shape), parts[3] if sizes[3] else None))
        assert frame.motion is not None, "every frame of a drive carries its motion"
        frames.append(SurveyFrame(time, frame.measurements, frame.motion))
    start = header["start"]
    drive = Drive(tuple(frames), None if start is None else (start[0], start[1], start[2]),
                  header["name"])
    beacons = BeaconMap(arrays["ids"], arrays["xyz"], arrays["width"]) if header["map"] \
        else None
    return drive, Prior(beacons, tuple(header["anchors"]))


def serve(conn: Any, spec: str, profile: Profile | None, folder: str) -> None:
    """The process's job: build the mapper, then answer each problem sent, until told to stop.

    Messages are framed as :func:`azgym.bench.run.wire.framed` frames them. It sends
    :data:`BUILDING` once sealed and :data:`READY` once built (or, for a mapper that cannot be
    built, the error as its answer, and ends); then, per problem received
    (:func:`encode_problem`'s bytes), :data:`SURVEYING` as the call begins and the answer's
    JSON. An empty message, or the parent gone, ends it.

    Args:
        conn: The pipe to the parent (the one descriptor kept).
        spec: The mapper's spec.
        profile: Its defaults (None: its own).
        folder: The runner's working folder (a plug-in's relative path means what it meant
            there).
    """
    fd = conn.fileno()
    seal(fd)
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the parent's to handle
    os.chdir(folder)
    write_all(fd, framed(BUILDING))
    try:
        mapper = make_mapper(spec, profile)
    except BaseException as exc:  # noqa: BLE001 - reported: the parent charges the call
        write_all(fd, framed(_error(exc)))
        return
    write_all(fd, framed(READY))
    while problem := _receive(conn):
        write_all(fd, framed(SURVEYING))
        try:
            answer = mapper.survey(*decode_problem(problem))
            if not isinstance(answer, MapAnswer):
                raise InvalidInputError(
                    f"survey returned {type(answer).__name__}, not a MapAnswer")
            text = json.dumps({"ids": answer.ids.tolist(), "xy": answer.xy.tolist(),
                               "covariances": answer.covariances.tolist(),
                               "moved": list(answer.moved)}).encode()
        except BaseException as exc:  # noqa: BLE001 - reported: the parent charges the call
            text = _error(exc)
        del problem
        write_all(fd, framed(text))


def _error(exc: BaseException) -> bytes:
    """An exception as the answer that reports it."""
    return json.dumps({"error": str(exc) if isinstance(exc, AzgymError)
                       else describe(exc)}).encode()


def _receive(conn: Any) -> bytes:
    """The next message from the parent; empty when told to stop or when the parent is gone.

    The parent frames each one as ``Connection.send_bytes`` does (:func:`framed`), so the
    pipe's own reader takes it whole; a pipe that ends, even mid-message, is the parent gone.
    """
    try:
        return conn.recv_bytes()
    except (EOFError, OSError):
        return b""


def messages(inbox: bytearray) -> list[bytes]:
    """Take the complete messages out of what a mapper's process has sent so far.

    Raises:
        ProtocolError: A message longer than :data:`ANSWER_CAP`.
    """
    return unframed(inbox, ANSWER_CAP,
                    lambda _size: f"it answered more than {ANSWER_CAP >> 20} MiB")


def read_answer(data: bytes) -> MapAnswer:
    """A mapper's answer (:func:`serve`'s JSON), checked as any :class:`MapAnswer` is.

    Raises:
        ProtocolError: The bytes are no answer (not JSON, not the answer's keys, an error the
            mapper raised), said in words.
        InvalidInputError: An answer that fails :class:`MapAnswer`'s checks.
    """
    try:
        message = json.loads(data)
    except (ValueError, RecursionError):  # RecursionError: nested too deeply
        raise ProtocolError("its answer is not JSON") from None
    if isinstance(message, dict) and set(message) == {"error"}:
        raise ProtocolError(f"it raised {str(message['error'])[:500]}")
    if not isinstance(message, dict) or set(message) != _ANSWER_KEYS:
        raise ProtocolError(f"its answer is not an object of {sorted(_ANSWER_KEYS)}")
    moved = message["moved"]
    if not isinstance(moved, list) or not all(type(i) is int for i in moved):
        raise ProtocolError("its answer's moved is not a list of ids")
    try:
        return map_answer(np.asarray(message["ids"]), np.asarray(message["xy"], np.float64),
                          np.asarray(message["covariances"], np.float64), moved)
    except (TypeError, ValueError, OverflowError) as exc:
        if isinstance(exc, InvalidInputError):
            raise
        raise ProtocolError(f"its answer's arrays are not numbers of the right shapes: "
                            f"{describe(exc)[:200]}") from None
