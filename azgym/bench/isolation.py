"""The runner's side of an isolated run: worker processes that can hang, crash or cheat safely.

Each contender runs in processes of its own (:mod:`azgym.bench.worker`), started from a fork
server that imported azgym and loaded the built-in localizers' compiled code once, so a worker
starts in milliseconds and holds nothing of the run that started it: no true pose, no other
contender. A worker gets frames in batches (one round trip each) and answers into shared
memory.

Every call into the localizer gets a time limit. A call that overruns it, or a worker that dies
(a segfault, ``os._exit``, the kernel's out-of-memory killer), costs that frame only: it is
scored unavailable with the reason, a fresh worker takes over the rest of the batch, and the run
goes on. After ``GIVE_UP_AFTER`` such losses in a row the contender's remaining frames are not
run at all, so a localizer that hangs on every frame costs seconds, not hours.

What isolation does not do: it is not a security sandbox. A plug-in still runs as the user, with
the user's files and network; run code you do not trust in a container.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import multiprocessing.connection
import os
import signal
import sys
import time
import types
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from azgym.bench import worker
from azgym.bench.wire import MapData, Packed
from azgym.bench.worker import ANSWER_SIZE

DEFAULT_TIME_LIMIT = 10.0
"""Seconds a localizer may take on one frame (or to be built) before it is stopped: 60 times the
slowest built-in (the exhaustive 1 cm MEX, ~0.15 s a frame)."""
STARTUP_LIMIT = 300.0
"""Seconds a new worker may take to come up, not counting the build. The first run on a machine
compiles azgym's kernels in the fork server (tens of seconds); later runs take milliseconds."""
GIVE_UP_AFTER = 3
"""Frames lost in a row (time-outs or dead workers) after which a contender's other frames are
skipped."""
PRELOAD = "azgym.bench.preload"
BACKENDS = ("local", "ray")
"""Where the contenders run: worker processes forked here, or Ray actors on a cluster
(:mod:`azgym.bench.ray_backend`, imported only when asked for)."""

Report = Callable[[int], None]
"""Called with the number of frames finished so far."""


@dataclass
class Answers:
    """A contender's answers to every frame of a run, in the frames' order.

    Attributes:
        pose: (x, y, heading) of each usable estimate, NaN elsewhere, shape (F, 3).
        posed: Whether the frame got a usable pose, shape (F,).
        micros: Time of the call [µs], NaN when it raised, timed out or was not run, shape (F,).
        errors: Why a frame got no answer ("" when it got one), one per frame.
    """

    pose: np.ndarray
    posed: np.ndarray
    micros: np.ndarray
    errors: list[str]

    @classmethod
    def unanswered(cls, count: int) -> Answers:
        """No answer yet to any of ``count`` frames."""
        return cls(np.full((count, 3), np.nan), np.zeros(count, dtype=bool),
                   np.full(count, np.nan), [""] * count)


def overrun_reason(phase: str, time_limit: float, starter: str) -> str:
    """Why ``starter`` (the worker, the Ray actor) was stopped at its deadline in ``phase``."""
    if phase == "building":
        return f"building the localizer took longer than the {time_limit:g} s limit"
    if phase == "warming":
        return f"compiling the built-in took longer than {STARTUP_LIMIT:g} s"
    if phase == "starting":
        return f"{starter} did not start within {STARTUP_LIMIT:g} s"
    return f"timed out: took longer than the {time_limit:g} s limit"


def give_up_note(reason: str) -> str:
    """The error of the frames skipped after :data:`GIVE_UP_AFTER` losses in a row."""
    return f"not run: {GIVE_UP_AFTER} frames in a row were lost (last: {reason})"


def record_answers(answers: Answers, start: int, table: np.ndarray) -> None:
    """Decode answer rows (``worker.ANSWER_*`` columns) into frames ``start``, ``start + 1``..."""
    rows = slice(start, start + len(table))
    posed = table[:, worker.ANSWER_STATE] == worker.POSED
    answered = np.isin(table[:, worker.ANSWER_STATE], (worker.POSED, worker.NO_POSE))
    answers.posed[rows] = posed
    pose = table[:, [worker.ANSWER_X, worker.ANSWER_Y, worker.ANSWER_HEADING]]
    answers.pose[rows] = np.where(posed[:, None], pose, np.nan)
    answers.micros[rows] = np.where(answered, table[:, worker.ANSWER_MICROS], np.nan)


def context() -> Any:
    """The fork-server context the workers start from (the server starts on first use)."""
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload([PRELOAD])
    return ctx


def start_fork_server() -> None:
    """Start the fork server now, so its warm-up overlaps whatever the caller does next."""
    context()
    from multiprocessing import forkserver

    forkserver.ensure_running()


@dataclass
class _Batch:
    """Frames [start, stop) of the run, given to one worker."""

    start: int
    stop: int
    sent: float = 0.0


@dataclass
class _Worker:
    """One worker process and its shared memory."""

    process: Any
    conn: Any
    progress: Any
    answers: Any
    ready: bool = False
    batch: _Batch | None = None
    started: float = 0.0


class IsolatedRun:
    """One contender on a run's frames, in up to ``workers`` worker processes at a time.

    ``batches`` are the (start, stop) ranges of frames each sent in one round trip; the runner
    keeps a sequence (a route) within one, so a tracker sees it whole and in order.
    """

    def __init__(self, spec: str, params: dict[str, Any], frames: Sequence[Packed],
                 maps: Mapping[str, MapData], *, workers: int, time_limit: float,
                 batches: Sequence[tuple[int, int]]) -> None:
        self.spec, self.params, self.frames, self.maps = spec, params, frames, maps
        self.workers, self.time_limit = workers, time_limit
        self.answers = Answers.unanswered(len(frames))
        self.queue = [_Batch(start, stop) for start, stop in batches]
        self.capacity = max((stop - start for start, stop in batches), default=1)
        self.running: list[_Worker] = []
        self.lost_in_a_row = 0
        self.finished = 0
        self.unbuildable = ""

    def run(self, report: Report) -> Answers:
        """Run every frame; ``report`` hears how many are finished after each batch."""
        try:
            while self.queue or any(w.batch is not None for w in self.running):
                self._fill()
                self._wait()
                report(self.finished)
        finally:
            for w in self.running:
                _stop(w)
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

    def _start(self) -> _Worker:
        """A fresh worker process (its batch is sent once it reports ready)."""
        ctx = context()
        mine, theirs = ctx.Pipe()
        progress = ctx.RawArray("q", [worker.IDLE, 0])
        answers = ctx.RawArray("d", self.capacity * ANSWER_SIZE)
        process = ctx.Process(target=worker.serve, daemon=True, name=f"azgym {self.spec}",
                              args=(theirs, progress, answers, self.spec, self.params,
                                    self.maps, os.getcwd()))
        started = time.monotonic()  # before start(): the worker may begin building at once
        with _caller_main_hidden():
            process.start()
        theirs.close()
        w = _Worker(process, mine, progress, answers, started=started)
        self.running.append(w)
        return w

    def _send(self, w: _Worker) -> None:
        assert w.batch is not None
        w.batch.sent = time.monotonic()
        w.conn.send(list(self.frames[w.batch.start:w.batch.stop]))

    def _wait(self) -> None:
        """Wait for messages, deaths or a deadline, and deal with whatever happened."""
        busy = [w for w in self.running if w.batch is not None]
        waitables = [w.conn for w in busy] + [w.process.sentinel for w in busy]
        multiprocessing.connection.wait(waitables, timeout=self._next_deadline(busy))
        for w in busy:
            self._drain(w)
            if w.batch is not None and not w.process.is_alive():
                self._lose(w, _death(w.process))
            elif w.batch is not None and self._overran(w):
                self._lose(w, self._overrun_reason(w))

    def _next_deadline(self, busy: list[_Worker]) -> float:
        """Seconds until the earliest deadline among busy workers (at least 1 ms)."""
        now = time.monotonic()
        soonest = min((self._deadline(w) for w in busy), default=now + 0.1)
        return min(max(soonest - now, 0.001), 0.5)

    def _deadline(self, w: _Worker) -> float:
        """When the worker's current step must be over (monotonic seconds)."""
        if not w.ready:
            if w.progress[0] == worker.BUILDING:  # the worker set it: the build has begun
                return w.progress[1] / 1e9 + self.time_limit
            if w.progress[0] == worker.WARMING:  # a built-in compiling its kernels
                return w.progress[1] / 1e9 + STARTUP_LIMIT
            return w.started + STARTUP_LIMIT
        if w.batch is None:
            return time.monotonic() + 1.0
        # The whole batch's bound holds even if the localizer scribbles on the shared progress.
        bound = w.batch.sent + (w.batch.stop - w.batch.start + 1) * self.time_limit
        if w.progress[0] >= 0:
            return min(w.progress[1] / 1e9 + self.time_limit, bound)
        return bound

    def _overran(self, w: _Worker) -> bool:
        return time.monotonic() > self._deadline(w)

    def _overrun_reason(self, w: _Worker) -> str:
        phase = "answering" if w.ready else {worker.BUILDING: "building",
                                              worker.WARMING: "warming"}.get(w.progress[0],
                                                                             "starting")
        return overrun_reason(phase, self.time_limit, "the worker")

    def _drain(self, w: _Worker) -> None:
        """Read every message the worker has sent."""
        while w.batch is not None and _poll(w.conn):
            try:
                message = w.conn.recv()
            except (EOFError, OSError):
                return
            if message[0] == "ready":
                w.ready = True
                self._send(w)
            elif message[0] == "unbuildable":
                self.unbuildable = f"cannot build {self.spec!r}: {message[1]}"
                self._skip(w.batch, self.unbuildable)
                w.batch = None
                _stop(w)
                self.running.remove(w)
            elif message[0] == "error":
                self.answers.errors[w.batch.start + message[1]] = message[2]
            elif message[0] == "done":
                self._collect(w, w.batch.stop - w.batch.start)
                self.lost_in_a_row = 0
                w.batch = None

    def _collect(self, w: _Worker, count: int) -> None:
        """Copy the answers to the batch's first ``count`` frames out of shared memory."""
        assert w.batch is not None
        table = np.frombuffer(w.answers, np.float64)[:count * ANSWER_SIZE].reshape(
            count, ANSWER_SIZE).copy()
        record_answers(self.answers, w.batch.start, table)
        self.finished += count

    def _lose(self, w: _Worker, reason: str) -> None:
        """The worker overran or died: score its current frame, requeue the rest, replace it."""
        batch = w.batch
        assert batch is not None
        _stop(w)
        self.running.remove(w)
        if not w.ready:
            if w.progress[0] == worker.BUILDING:
                self.unbuildable = reason
            self._skip(batch, reason)
            return
        done = min(max(int(w.progress[0]), 0), batch.stop - batch.start - 1)
        self._collect(w, done)
        self.answers.errors[batch.start + done] = reason
        self.finished += 1
        self.lost_in_a_row += 1
        rest = _Batch(batch.start + done + 1, batch.stop)
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
                if _poll(w.conn):
                    message = w.conn.recv()
                    w.ready = message[0] == "ready"
                    return "" if w.ready else message[1]
                if not w.process.is_alive():
                    return _death(w.process)
                if self._overran(w):
                    return self._overrun_reason(w)
                multiprocessing.connection.wait([w.conn, w.process.sentinel],
                                                timeout=self._next_deadline([w]))
        finally:
            _stop(w)

    def _skip(self, batch: _Batch, reason: str) -> None:
        """Score frames that will not run as unavailable, with the reason."""
        for k in range(batch.start, batch.stop):
            self.answers.errors[k] = self.answers.errors[k] or reason
        self.finished += batch.stop - batch.start


@contextlib.contextmanager
def _caller_main_hidden() -> Iterator[None]:
    """Start workers without the caller's main script.

    multiprocessing re-runs the parent's ``__main__`` in a new process so that functions defined
    there can be found. A worker needs none of it (it runs azgym's worker and a localizer given
    by an importable spec), and re-running a user's script there would repeat its work, fail for
    a script read from standard input, and put whatever that script computes (true poses
    included) into the localizer's process. While a worker starts, ``__main__`` is a bare
    stand-in module.
    """
    main = sys.modules["__main__"]
    sys.modules["__main__"] = types.ModuleType("__main__")
    try:
        yield
    finally:
        sys.modules["__main__"] = main


def build_problem(spec: str, params: dict[str, Any], time_limit: float) -> str:
    """Why the localizer cannot be built in a worker ("" when it can), within the time limit.

    The check runs where a benchmark runs the localizer, so a plug-in whose module or
    constructor hangs, crashes or exits is caught without harm to the caller.
    """
    return IsolatedRun(spec, params, [], {}, workers=1, time_limit=time_limit,
                       batches=[]).build_problem()


def _poll(conn: Any) -> bool:
    try:
        return bool(conn.poll())
    except (EOFError, OSError):
        return False


def _death(process: Any) -> str:
    """Why a worker process ended, in words."""
    process.join(timeout=1.0)
    code = process.exitcode
    if code is not None and code < 0:
        try:
            name = signal.Signals(-code).name
        except ValueError:
            name = f"signal {-code}"
        return f"the localizer's process was killed by {name}"
    return f"the localizer's process exited (exit code {code})"


def _stop(w: _Worker) -> None:
    """End a worker: ask politely when idle, kill it otherwise."""
    if w.process.is_alive():
        if w.batch is None and w.ready:
            try:
                w.conn.send(None)
            except (BrokenPipeError, OSError):
                pass
            w.process.join(timeout=1.0)
        if w.process.is_alive():
            w.process.kill()
    w.process.join(timeout=5.0)
    w.conn.close()
