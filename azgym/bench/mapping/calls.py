"""The parent's side of the mapping benchmark's calls: processes started, fed, heard, stopped.

Each job is a mapper's calls on one case (:data:`Job`, :func:`azgym.bench.mapping.benchmark`'s
rule of which calls): it runs in a process of its own (:mod:`azgym.bench.mapping.worker`),
forked from the benchmark's fork server, which gets the job's problems one at a time and in
order; up to ``workers`` jobs run at once. The runner waits on every process at once (a
selector), sends each problem without blocking, and holds each phase to its limit: the process
coming up (:data:`~azgym.bench.run.answers.STARTUP_LIMIT`), the mapper's build, a problem's
delivery and a call (the time limit each). A call overrunning its limit, a process that dies, a
message over :data:`~azgym.bench.mapping.worker.ANSWER_CAP` bytes, a malformed answer: each a
failure, named; the process is killed and the job's next call gets a fresh one.
"""

from __future__ import annotations

import contextlib
import os
import selectors
import time
from collections.abc import Generator
from dataclasses import dataclass, field
from typing import Any

from azgym.bench.mapping import worker
from azgym.bench.mapping.suites import MappingCase
from azgym.bench.run.answers import STARTUP_LIMIT
from azgym.bench.run.processes import caller_main_hidden, context
from azgym.bench.run.wire import framed
from azgym.errors import InvalidInputError, ProtocolError
from azgym.mapping.base import MapAnswer
from azgym.mapping.problem import Drive

__all__ = ["BUILD_ONLY", "Job", "Outcome", "Record", "build_problems", "run_calls"]

BUILD_ONLY = -1
"""The frames a job asks for when it asks only that its mapper be built (with the case's
profile): the outcome is heard once the mapper is ready (:func:`build_problems`)."""


@dataclass(frozen=True)
class Outcome:
    """What one call got.

    Attributes:
        answer: The checked answer, or None on a failure.
        failure: Why the call failed, or None.
        seconds: The call's duration as the runner saw it [s]; None on a failure.
    """

    answer: MapAnswer | None
    failure: str | None
    seconds: float | None


Record = tuple[Outcome, list[tuple[float, Outcome]]]
"""A job's outcomes: its full drive's, and each checkpoint's (time, outcome)."""
Job = Generator[tuple[int, int], Outcome, Record]
"""A mapper's calls on one case: it yields (case, frames) problems, hears each one's outcome,
and returns the full drive's outcome and each checkpoint's (time, outcome)."""


def run_calls(jobs: list[Job], specs: list[str], cases: list[MappingCase], workers: int,
              time_limit: float, count: Any) -> list[Record]:
    """Run every job's calls (job ``n`` a mapper ``specs[n]``'s); each job's record, in order.

    ``count`` is told how many jobs are done.
    """
    return _Runner(jobs, specs, cases, time_limit, count).run(workers)


def build_problems(specs: list[str], cases: list[MappingCase], workers: int,
                   time_limit: float) -> dict[str, str]:
    """Why each mapper cannot be built where the run builds it ("" when it can).

    Each is built in a worker as a call's would be, with each profile the cases give (a
    plug-in whose module or constructor raises, hangs or ends its process is named here, before
    any case is run, as :func:`azgym.bench.run.contenders.check_buildable` names a localizer).
    """
    firsts: dict[Any, int] = {}  # each profile's first case
    for k, case in enumerate(cases):
        firsts.setdefault(case.profile, k)
    pairs = [(spec, k) for spec in specs for k in firsts.values()]
    records = run_calls([_build_only(k) for _, k in pairs], [spec for spec, _ in pairs], cases,
                        workers, time_limit, lambda done: None)
    problems = dict.fromkeys(specs, "")
    for (spec, _), (outcome, _) in zip(pairs, records, strict=True):
        problems[spec] = problems[spec] or outcome.failure or ""
    return problems


def _build_only(k: int) -> Job:
    """A job that asks only that its mapper be built, with case ``k``'s profile."""
    built = yield k, BUILD_ONLY
    return built, []


@dataclass
class _Slot:
    """A job being run: its process (None: none alive) and the call it is on.

    ``phase`` is what the process is doing: ``starting``, ``building``, ``sending`` (the problem
    on its way, until the call begins), ``surveying``; ``since`` when it began.
    """

    ask: tuple[int, int]
    process: Any = None
    conn: Any = None
    phase: str = "starting"
    since: float = field(default_factory=time.monotonic)
    inbox: bytearray = field(default_factory=bytearray)
    outbox: memoryview | None = None


class _Runner:
    """Runs the jobs' calls, a process per job and up to ``workers`` jobs at a time."""

    def __init__(self, jobs: list[Job], specs: list[str], cases: list[MappingCase],
                 time_limit: float, count: Any) -> None:
        self.jobs, self.specs, self.cases = jobs, specs, cases
        self.time_limit, self.count = time_limit, count
        self.records: list[Any] = [None] * len(jobs)
        self.slots: dict[int, _Slot] = {}
        self.selector = selectors.DefaultSelector()
        self.done = 0

    def run(self, workers: int) -> list[Record]:
        """Every job's record, in order."""
        waiting = list(range(len(self.jobs)))[::-1]
        try:
            while waiting or self.slots:
                while len(self.slots) < workers and waiting:
                    n = waiting.pop()
                    self.slots[n] = _Slot(next(self.jobs[n]))
                    self._call(n)
                for key, events in self.selector.select(self._timeout()):
                    n = key.data
                    if n in self.slots and events & selectors.EVENT_WRITE:
                        self._write(n)
                    if n in self.slots and events & selectors.EVENT_READ:
                        self._read(n)
                for n in list(self.slots):
                    slot = self.slots[n]
                    if time.monotonic() > slot.since + _allowance(slot.phase, self.time_limit):
                        self._fail(n, _overrun(slot.phase, self.time_limit))
        finally:
            for slot in self.slots.values():
                self._end(slot)
            self.selector.close()
        return self.records

    def _call(self, n: int) -> None:
        """Start job ``n``'s asked call: its process if it has none, else send the problem."""
        slot = self.slots[n]
        if slot.process is None:
            ctx = context()
            mine, theirs = ctx.Pipe()
            slot.process = ctx.Process(
                target=worker.serve, daemon=True, name=f"azgym mapper {self.specs[n]}",
                args=(theirs, self.specs[n], self.cases[slot.ask[0]].profile, os.getcwd()))
            with caller_main_hidden():
                slot.process.start()
            theirs.close()
            os.set_blocking(mine.fileno(), False)
            slot.conn, slot.phase, slot.since = mine, "starting", time.monotonic()
            slot.inbox.clear()
            self.selector.register(mine.fileno(), selectors.EVENT_READ, n)
            return
        k, frames = slot.ask
        slot.outbox = memoryview(framed(worker.encode_problem(
            _prefix(self.cases[k].drive, frames), self.cases[k].prior)))
        slot.phase, slot.since = "sending", time.monotonic()
        self.selector.modify(slot.conn.fileno(), selectors.EVENT_READ | selectors.EVENT_WRITE, n)

    def _write(self, n: int) -> None:
        """Send what is left of the problem, as much as the pipe takes."""
        slot = self.slots[n]
        if slot.outbox is None:
            return
        try:
            sent = os.write(slot.conn.fileno(), slot.outbox)
        except BlockingIOError:
            return
        except OSError:
            self._fail(n, _death(slot.process))
            return
        slot.outbox = slot.outbox[sent:] if sent < len(slot.outbox) else None
        if slot.outbox is None:
            self.selector.modify(slot.conn.fileno(), selectors.EVENT_READ, n)

    def _read(self, n: int) -> None:
        """Take what the process sent, and act on each whole message."""
        slot = self.slots[n]
        try:
            chunk = os.read(slot.conn.fileno(), 1 << 20)
        except BlockingIOError:
            return
        except OSError:
            chunk = b""
        if not chunk:
            self._fail(n, _death(slot.process))
            return
        slot.inbox += chunk
        try:
            heard = worker.messages(slot.inbox)
        except ProtocolError as exc:
            self._fail(n, str(exc))
            return
        process = slot.process
        for message in heard:
            if self.slots.get(n) is not slot or slot.process is not process:
                return  # the job moved on: the rest was its ended process's
            self._hear(n, slot, message)

    def _hear(self, n: int, slot: _Slot, message: bytes) -> None:
        """Act on one message of job ``n``'s process."""
        step = {("starting", worker.BUILDING): "building", ("building", worker.READY): "ready",
                ("sending", worker.SURVEYING): "surveying"}.get((slot.phase, message))
        if step == "ready" and slot.ask[1] == BUILD_ONLY:
            self._advance(n, Outcome(None, None, time.monotonic() - slot.since))
        elif step == "ready":
            self._call(n)
        elif step is not None:
            slot.phase, slot.since = step, time.monotonic()
        elif slot.phase in ("building", "surveying") and slot.outbox is None:
            seconds = time.monotonic() - slot.since
            try:
                answer = worker.read_answer(message)
            except (ProtocolError, InvalidInputError) as exc:
                rebuilding = slot.phase == "building" and slot.ask[1] != BUILD_ONLY
                self._fail(n, f"{'building it: ' if rebuilding else ''}{exc}"[:600])
                return
            if slot.phase == "building":
                self._fail(n, "it answered before its call began")
                return
            self._advance(n, Outcome(answer, None, seconds))
        else:
            self._fail(n, f"it broke the protocol ({len(message)} bytes while {slot.phase})")

    def _fail(self, n: int, why: str) -> None:
        """Job ``n``'s call failed: its process ended, the job told."""
        slot = self.slots[n]
        self._end(slot)
        slot.process, slot.conn, slot.outbox = None, None, None
        self._advance(n, Outcome(None, why, None))

    def _advance(self, n: int, outcome: Outcome) -> None:
        """Tell job ``n`` its call's outcome; start its next call or finish it."""
        slot = self.slots[n]
        try:
            slot.ask = self.jobs[n].send(outcome)
        except StopIteration as stop:
            self.records[n] = stop.value
            self._end(slot)
            del self.slots[n]
            self.done += 1
            self.count(self.done)
            return
        self._call(n)

    def _end(self, slot: _Slot) -> None:
        """Kill a slot's process if it has one, and let go of it."""
        if slot.process is None:
            return
        with contextlib.suppress(KeyError, ValueError):
            self.selector.unregister(slot.conn.fileno())
        if slot.process.is_alive():
            slot.process.kill()
        slot.process.join(timeout=5.0)
        slot.conn.close()

    def _timeout(self) -> float:
        """Seconds until the first running call's deadline (at least 1 ms)."""
        now = time.monotonic()
        return max(0.001, min((s.since + _allowance(s.phase, self.time_limit) - now
                               for s in self.slots.values()), default=1.0))


def _prefix(drive: Drive, frames: int) -> Drive:
    """The drive's first ``frames`` frames (the whole drive when that is all of them)."""
    return drive if frames == len(drive.frames) else Drive(drive.frames[:frames], drive.start,
                                                           drive.name)


def _allowance(phase: str, time_limit: float) -> float:
    """Seconds a phase may take.

    Starting, :data:`STARTUP_LIMIT` (the fork server compiles on a machine's first run); else
    the time limit (the mapper's build, a problem's delivery, a call).
    """
    return STARTUP_LIMIT if phase == "starting" else time_limit


def _overrun(phase: str, time_limit: float) -> str:
    """Why a call was stopped at its deadline."""
    if phase == "starting":
        return f"its process did not start within {STARTUP_LIMIT:g} s"
    what = {"building": "building the mapper", "sending": "taking the drive"}.get(phase)
    return f"timed out: {what or 'the call'} took longer than the {time_limit:g} s limit"


def _death(process: Any) -> str:
    """Why a mapper's process ended without answering."""
    process.join(timeout=1.0)
    code = process.exitcode
    if code is not None and code < 0:
        return f"its process was killed by signal {-code} without answering"
    return f"its process exited (exit code {code}) without answering"


