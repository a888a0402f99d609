"""The actor's side of the Ray backend: a Ray actor that feeds one worker process.

:mod:`azgym.bench.run.ray_backend` makes :class:`RayWorker` an actor and drives it; this module does
not import Ray.
"""

from __future__ import annotations

import multiprocessing
import os
import time
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

from azgym.bench.run import worker
from azgym.bench.run.answers import death
from azgym.bench.run.wire import MapData, Packed, ProtocolError, heard, step_message, write_all
from azgym.profile import Profile

__all__ = ["RayWorker", "STREAM_EVERY"]

STREAM_EVERY = 0.05
"""Seconds an actor gathers answers before it streams them back (one Ray item a frame costs
more than a fast frame); it streams what it has at once when its worker is slower."""

class RayWorker:
    """The contender's side on a Ray node: an actor that feeds one worker process frame by frame.

    The actor forks the worker (:func:`azgym.bench.run.worker.serve`, the process pool's) as it is
    built, before it holds any frame, and never runs the contender's code itself. It receives
    a batch's frames and hands the worker one step (one frame) at a time, the next only once
    the worker has answered, so the contender's process never holds a frame it has not
    reached. The actor is not dumpable (:func:`~azgym.bench.run.worker.hide_process`): the worker
    cannot read the frames ahead in its memory.
    """

    def __init__(self) -> None:
        self.process: Any = None
        self.conn: Any = None
        self.answers: Any = None
        self.inbox = bytearray()
        self.said: list[list[Any]] = []

    def build(self, spec: str, params: dict[str, Any], profile: Profile | None,
              maps: Mapping[str, MapData], folder: str, capacity: int
              ) -> Iterator[tuple[Any, ...]]:
        """Start the worker and relay how far its build got.

        Yields ("building",), ("warming",) while a built-in compiles, then ("ready",),
        ("unbuildable", why) or ("died", why). Relative paths mean what they meant in
        ``folder``, the runner's working folder, when this node has it.

        Args:
            spec: The contender's spec.
            params: Its hyperparameters.
            profile: The profile whose hyperparameters are its defaults (None: none).
            maps: Each scenario's packed beacon map.
            folder: The runner's working folder.
            capacity: The most frames one step will hold.
        """
        yield ("building",)
        worker.hide_process()
        ctx = multiprocessing.get_context("fork")  # before any frame is here
        self.conn, theirs = ctx.Pipe()
        progress = ctx.RawArray("q", [worker.IDLE, 0])
        self.answers = ctx.RawArray("d", max(capacity, 1) * worker.ANSWER_SIZE)
        self.process = ctx.Process(
            target=worker.serve, daemon=True, name=f"azgym {spec}",
            args=(theirs, progress, self.answers, spec, params, profile, maps,
                  folder if os.path.isdir(folder) else os.getcwd()))
        self.process.start()
        theirs.close()
        warming = False
        while not self.conn.poll(0.02):
            if not self.process.is_alive():
                yield ("died", death(self.process))
                return
            if not warming and progress[0] == worker.WARMING:
                warming = True
                yield ("warming",)
        said = self._receive()
        if said[0] not in ("ready", "unbuildable", "died"):
            self.process.kill()
            said = ("died", f"the localizer's process broke the worker's protocol: {said[0]!r} "
                            "out of turn")
        yield said

    def answer(self, *steps: Sequence[Packed]) -> Iterator[tuple[Any, ...]]:
        """Answer a batch given as its steps, streaming the answers as they come.

        Yields ("warmed",) after a plug-in's untimed first call; ("answers", [[[x, y, heading,
        state, micros], error], ...]) for the frames answered since the last such item, in
        order, at most every :data:`STREAM_EVERY` seconds, at once when the worker is slower,
        and at the batch's end; or ("died", why) when the worker is gone.
        """
        answered: list[list[Any]] = []
        flushed = time.monotonic()
        for step in steps:
            write_all(self.conn.fileno(), step_message(step))
            errors: dict[Any, str] = {}
            while True:
                if answered and not self.said and not self.conn.poll(STREAM_EVERY):
                    yield ("answers", answered)  # the worker is slow: what it has done so far
                    answered, flushed = [], time.monotonic()
                message = self._receive()
                if message[0] in ("died", "warmed"):
                    if answered:
                        yield ("answers", answered)
                        answered, flushed = [], time.monotonic()
                    yield message
                    if message[0] == "died":
                        return
                elif message[0] == "error" and len(message) == 3:
                    errors[message[1]] = str(message[2])
                elif message[0] == "done":
                    break
            rows = self.answers[:len(step) * worker.ANSWER_SIZE]  # final, before the next step
            answered += [[rows[k:k + worker.ANSWER_SIZE], errors.get(k // worker.ANSWER_SIZE, "")]
                         for k in range(0, len(rows), worker.ANSWER_SIZE)]
            if time.monotonic() - flushed >= STREAM_EVERY:
                yield ("answers", answered)
                answered, flushed = [], time.monotonic()
        if answered:
            yield ("answers", answered)

    def _receive(self) -> tuple[Any, ...]:
        """The worker's next message, or ("died", why) when it is gone or broke the protocol."""
        while not self.said:
            try:
                data = os.read(self.conn.fileno(), 1 << 16)
                self.inbox += data
                self.said.extend(heard(self.inbox))
            except (OSError, ProtocolError) as exc:
                self.process.kill()
                return ("died", f"the localizer's process broke the worker's protocol: {exc}")
            if not data:
                return ("died", death(self.process))
        return tuple(self.said.pop(0))
