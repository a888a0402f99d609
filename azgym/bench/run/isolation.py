"""The runner's side of an isolated run: worker processes that can hang, crash or cheat safely.

Each contender runs in processes of its own (:mod:`azgym.bench.run.worker`), started from a fork
server that imported azgym and loaded the built-in localizers' compiled code once, so a worker
starts in milliseconds and holds nothing of the run that started it: no true pose, no other
contender. A worker gets a batch of frames in steps and answers each step into shared memory:
a route's frames one at a time, the next only once the runner has taken this one's answer as
final (a tracker cannot see its route's future), frames on their own several at a time.

Every call into the localizer gets a time limit. A call that overruns it, or a worker that dies
(a segfault, ``os._exit``, the kernel's out-of-memory killer), costs that frame only: it is
scored unavailable with the reason, a fresh worker takes over the rest of the batch, and the run
goes on. After ``GIVE_UP_AFTER`` such losses in a row the contender's remaining frames are not
run at all, so a localizer that hangs on every frame costs seconds, not hours.

What isolation does not do: it is not a security sandbox. A plug-in still runs as the user, with
the user's files, network and processes (docs/leaderboard.md lists what it can still read);
run code you do not trust in a container.
"""

from __future__ import annotations

import contextlib
import multiprocessing.connection
import os
import selectors
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from azgym.bench.run import worker
from azgym.bench.run.answers import (
    GIVE_UP_AFTER,
    STARTUP_LIMIT,
    Answers,
    Report,
    build_allowance,
    death,
    give_up_note,
    overrun_reason,
    record_answers,
)
from azgym.bench.run.processes import (
    Worker,
    build_verdict,
    poll,
    start_worker,
    stop,
)
from azgym.bench.run.wire import (
    DONE,
    MapData,
    Packed,
    ProtocolError,
    heard,
    step_message,
    write_all,
)
from azgym.bench.run.worker import ANSWER_SIZE
from azgym.profile import Profile

__all__ = ["DEFAULT_TIME_LIMIT", "IsolatedRun", "build_problem"]

DEFAULT_TIME_LIMIT = 10.0
"""Seconds a localizer may take on one frame (or to be built) before it is stopped: 60 times the
slowest built-in (the exhaustive 1 cm MEX, ~0.15 s a frame)."""
CHECK_EVERY = 0.01
"""Seconds between the runner's looks at its workers' deadlines while messages keep coming."""


@dataclass
class _Batch:
    """Frames [start, stop) of the run, given to one worker, and the step it is answering.

    The step is frames [step_start, step_stop), sent at ``sent`` (``step_stop`` is where the
    next step starts; before the first, ``start``).
    """

    start: int
    stop: int
    step_start: int = -1
    step_stop: int = -1
    sent: float = 0.0

    def __post_init__(self) -> None:
        self.step_start = self.step_stop = self.start


class IsolatedRun:
    """One contender on a run's frames, in up to ``workers`` worker processes at a time.

    ``batches`` are the (start, stop) ranges of frames each sent in one round trip; the runner
    keeps a sequence (a route) within one, so a tracker sees it whole and in order. Each worker
    builds the contender with ``params`` and ``profile``'s defaults under them
    (:func:`~azgym.bench.run.profiles.contender_params`).
    """

    def __init__(self, spec: str, params: dict[str, Any], frames: Sequence[Packed],
                 maps: Mapping[str, MapData], *, workers: int, time_limit: float,
                 batches: Sequence[tuple[int, int]], profile: Profile | None = None) -> None:
        self.spec, self.params, self.frames, self.maps = spec, params, frames, maps
        self.profile = profile
        self.workers, self.time_limit = workers, time_limit
        self.answers = Answers.unanswered(len(frames))
        self.messages: list[bytes | None] = [None] * len(frames)
        self.queue = [_Batch(start, stop) for start, stop in batches]
        self.capacity = max((stop - start for start, stop in batches), default=1)
        self.running: list[Worker] = []
        self.lost_in_a_row = 0
        self.finished = 0
        self.unbuildable = ""
        self.selector: selectors.BaseSelector | None = None
        self.check_at = 0.0

    def run(self, report: Report) -> Answers:
        """Run every frame; ``report`` hears how many are finished after each batch."""
        self.selector = selector = selectors.DefaultSelector()
        try:
            while self.queue or any(w.batch is not None for w in self.running):
                self._fill()
                self._wait(selector)
                report(self.finished)
        finally:
            for w in list(self.running):
                self._retire(w)
            selector.close()
        return self.answers

    def _fill(self) -> None:
        """Give each idle worker a batch, starting workers up to the limit."""
        idle = [w for w in self.running if w.batch is None]
        while self.queue and not self.unbuildable:
            if not idle and len(self.running) >= self.workers:
                return
            w = idle.pop() if idle else self._start()
            w.batch = self.queue.pop(0)
            if w.ready:
                self._send(w)
        if self.unbuildable:
            for batch in self.queue:
                self._skip(batch, self.unbuildable)
            self.queue.clear()

    def _start(self) -> Worker:
        """A fresh worker process (its batch is sent once it reports ready)."""
        w = start_worker(self.spec, self.params, self.profile, self.maps, self.capacity)
        self.running.append(w)
        if self.selector is not None:
            self.selector.register(w.conn, selectors.EVENT_READ, w)
            self.selector.register(w.process.sentinel, selectors.EVENT_READ, w)
        self.check_at = 0.0
        return w

    def _retire(self, w: Worker) -> None:
        """Stop a worker and forget it."""
        self._forget(w.conn)
        self._forget(w.process.sentinel)
        stop(w)
        self.running.remove(w)

    def _forget(self, waitable: Any) -> None:
        """Stop waiting on a worker's pipe or sentinel."""
        if self.selector is not None:
            with contextlib.suppress(KeyError, ValueError):
                self.selector.unregister(waitable)

    def _send(self, w: Worker) -> None:
        """Send the worker its batch's next step."""
        batch = w.batch
        assert batch is not None
        batch.step_start, batch.step_stop = batch.step_stop, self._step_end(batch.step_stop,
                                                                            batch.stop)
        batch.sent = time.monotonic()
        if batch.step_stop - batch.step_start == 1:
            message = self.messages[batch.step_start]
            if message is None:  # a route's frame: made once a run
                message = self.messages[batch.step_start] = step_message(
                    self.frames[batch.step_start:batch.step_stop])
        else:
            message = step_message(self.frames[batch.step_start:batch.step_stop])
        write_all(w.conn.fileno(), message)

    def _step_end(self, first: int, stop: int) -> int:
        """Where the step from frame ``first`` ends (frames up to ``stop`` are the batch's).

        A frame of a sequence is a step of its own: the worker gets the next one only once it
        has answered this one, so a tracker cannot see its route's future. Frames on their own
        go together up to the next sequence's.
        """
        if self.frames[first][1]:  # its sequence
            return first + 1
        end = first + 1
        while end < stop and not self.frames[end][1]:
            end += 1
        return end

    def _wait(self, selector: selectors.BaseSelector) -> None:
        """Wait for a message, a death or a deadline, and deal with whatever happened.

        A route's frames come and go one at a time, so this is the runner's inner loop: it
        reads what is ready (one message a worker), and looks at the deadlines only when the
        next may have passed (:data:`CHECK_EVERY`). ``selector`` is the one :meth:`run` opened.
        """
        now = time.monotonic()
        for key, _ in selector.select(max(self.check_at - now, 0.0)):
            w = key.data
            if w not in self.running:
                continue
            if key.fileobj is w.conn:
                self._read(w)
            elif w.batch is None:  # died idle: nothing lost
                self._retire(w)
            else:
                self._drain(w)
                if w.batch is not None:
                    self._lose(w, death(w.process))
        now = time.monotonic()
        if now >= self.check_at:
            busy = [w for w in self.running if w.batch is not None]
            for w in busy:
                if self._overran(w):
                    self._lose(w, self._overrun_reason(w))
            self.check_at = now + min(self._next_deadline(busy), CHECK_EVERY)

    def _next_deadline(self, busy: list[Worker]) -> float:
        """Seconds until the earliest deadline among busy workers (at least 1 ms)."""
        now = time.monotonic()
        soonest = min((self._deadline(w) for w in busy), default=now + 0.1)
        return min(max(soonest - now, 0.001), 0.5)

    def _deadline(self, w: Worker) -> float:
        """When the worker's current step must be over (monotonic seconds)."""
        if not w.ready:
            # The phase and its start are the worker's word, which a plug-in can overwrite: they
            # may shorten the wait, never lengthen it past the runner's own bound. Only a
            # built-in is given the compile allowance.
            bound = w.started + STARTUP_LIMIT + build_allowance(self.spec, True, self.time_limit)
            if w.progress[0] in (worker.BUILDING, worker.WARMING):  # the build has begun
                allowance = build_allowance(self.spec, w.progress[0] == worker.WARMING,
                                            self.time_limit)
                return min(w.progress[1] / 1e9 + allowance, bound)
            return min(w.started + STARTUP_LIMIT, bound)
        if w.batch is None:
            return time.monotonic() + 1.0
        # The whole step's bound holds even if the localizer scribbles on the shared progress.
        bound = w.batch.sent + (w.batch.step_stop - w.batch.step_start + 1) * self.time_limit
        if w.progress[0] >= 0:
            return min(w.progress[1] / 1e9 + self.time_limit, bound)
        return bound

    def _overran(self, w: Worker) -> bool:
        return time.monotonic() > self._deadline(w)

    def _overrun_reason(self, w: Worker) -> str:
        phase = "answering" if w.ready else {worker.BUILDING: "building",
                                              worker.WARMING: "warming"}.get(w.progress[0],
                                                                             "starting")
        return overrun_reason(phase, self.time_limit, "the worker")

    def _drain(self, w: Worker) -> None:
        """Read every message the worker has sent."""
        while w.batch is not None and poll(w.conn):
            if not self._read(w):
                return

    def _read(self, w: Worker) -> bool:
        """Read what the worker has sent and act on it; False when it is gone."""
        try:
            data = os.read(w.conn.fileno(), 1 << 16)
        except OSError:
            data = b""
        if not data:  # it is gone, or going: its sentinel says so
            if w.batch is None:
                self._retire(w)
            else:
                self._forget(w.conn)
            return False
        if data == DONE and not w.inbox:  # most of a route: a frame answered, nothing more
            self._hear(w, ["done"])
            return True
        w.inbox += data
        try:
            messages = heard(w.inbox)
        except ProtocolError as exc:
            return self._broke_protocol(w, str(exc))
        for message in messages:
            if w.batch is None or w not in self.running:
                break
            self._hear(w, message)
        return True

    def _hear(self, w: Worker, message: list[Any]) -> None:
        """Act on one message of the worker's (:func:`azgym.bench.run.worker.serve` lists them)."""
        batch = w.batch
        assert batch is not None
        match message:
            case ["done"] if w.ready:
                self._commit(w)
                if batch.step_stop < batch.stop:
                    self._send(w)
                else:
                    self.lost_in_a_row = 0
                    w.batch = None
            case ["error", int(k), str(text)] if 0 <= k < batch.step_stop - batch.step_start:
                self.answers.errors[batch.step_start + k] = text
            case ["warmed"]:
                pass
            case ["ready"] if not w.ready:
                w.ready = True
                self._send(w)
            case ["unbuildable", str(why)] if not w.ready:
                self.unbuildable = f"cannot build {self.spec!r}: {why}"
                self._skip(batch, self.unbuildable)
                w.batch = None
                self._retire(w)
            case _:
                self._broke_protocol(w, f"{str(message)[:80]} out of turn")

    def _broke_protocol(self, w: Worker, what: str) -> bool:
        """A worker that sent something the protocol does not allow: it is stopped."""
        self._lose(w, f"the localizer's process broke the worker's protocol: {what}")
        return False

    def _commit(self, w: Worker, stop: int | None = None) -> None:
        """Take the answers of the worker's step (of its frames before ``stop``) as final.

        Only now does the worker get its next step: an answer cannot change once the worker
        has seen a later frame.
        """
        batch = w.batch
        assert batch is not None
        first, stop = batch.step_start, batch.step_stop if stop is None else stop
        values = w.answers[:(stop - first) * ANSWER_SIZE]
        record_answers(self.answers, first, [values[k:k + ANSWER_SIZE]
                                             for k in range(0, len(values), ANSWER_SIZE)])
        self.finished += stop - first

    def _lose(self, w: Worker, reason: str) -> None:
        """The worker overran or died: score its current frame, requeue the rest, replace it."""
        batch = w.batch
        assert batch is not None
        self._retire(w)
        if not w.ready:
            if w.progress[0] == worker.BUILDING:
                self.unbuildable = reason
            self._skip(batch, reason)
            return
        # The steps before this one were committed; the worker says which frame it was on.
        lost = batch.step_start + min(max(int(w.progress[0]), 0),
                                      batch.step_stop - batch.step_start - 1)
        self._commit(w, lost)
        self.answers.errors[lost] = reason
        self.finished += 1
        self.lost_in_a_row += 1
        rest = _Batch(lost + 1, batch.stop)
        if self.lost_in_a_row >= GIVE_UP_AFTER:
            note = give_up_note(reason)
            for pending in [rest, *self.queue]:
                self._skip(pending, note)
            self.queue.clear()
        elif rest.stop > rest.start:
            self.queue.insert(0, rest)

    def build_problem(self) -> str:
        """Start one worker and wait for it to build the contender: "" or why it cannot."""
        w = self._start()
        try:
            while True:
                if poll(w.conn) and (verdict := build_verdict(w)) is not None:
                    return verdict
                if not w.process.is_alive():
                    return death(w.process)
                if self._overran(w):
                    return self._overrun_reason(w)
                multiprocessing.connection.wait([w.conn, w.process.sentinel],
                                                timeout=self._next_deadline([w]))
        finally:
            stop(w)

    def _skip(self, batch: _Batch, reason: str) -> None:
        """Score frames that will not run as unavailable, with the reason."""
        for k in range(batch.start, batch.stop):
            self.answers.errors[k] = self.answers.errors[k] or reason
        self.finished += batch.stop - batch.start


def build_problem(spec: str, params: dict[str, Any], time_limit: float,
                  profile: Profile | None = None) -> str:
    """Why the localizer cannot be built in a worker ("" when it can), within the time limit.

    The check runs where a benchmark runs the localizer, with the same hyperparameters (the
    profile's defaults under ``params``), so a plug-in whose module or constructor hangs,
    crashes or exits is caught without harm to the caller.
    """
    return IsolatedRun(spec, params, [], {}, workers=1, time_limit=time_limit,
                       batches=[], profile=profile).build_problem()
