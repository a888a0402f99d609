"""The runner's Ray backend: each contender's batches of frames run as Ray actors.

The same run as :mod:`azgym.bench.run.isolation`, with Ray actors in place of the fork server.
Each contender gets up to ``workers`` actors at a time, each a process of its own on some node,
killed when the contender is done (never reused by another contender). An actor forks one worker
process (:func:`azgym.bench.run.worker.serve`, the pool's own) before it gets any frame; it gets the
packed beacon maps once and then batches of packed frames (:mod:`azgym.bench.run.wire`), the
measurements only: the true poses never leave the runner, which scores the answers. The actor
hands its worker one frame at a time, the next once this one is answered (a tracker cannot see
its route's future), and streams the answers back as they come (a Ray generator; gathered for
up to ``ray_actor.STREAM_EVERY``, at once when a frame is slower), so the runner keeps each
frame's time limit by its own clock:

- a localizer that raises costs its frame, scored with the exception, as in the pool;
- a frame that takes longer than the time limit costs that frame: the actor is killed
  (``ray.kill``; its worker dies with it), a fresh one takes over the rest of the batch; so
  does a worker or an actor that dies (a segfault, ``os._exit``, a node lost), and after
  ``GIVE_UP_AFTER`` losses in a row the contender's other frames are not run.

The actor's side is :mod:`azgym.bench.run.ray_actor`. What differs from the process pool is in
docs/scaling.md: an actor starts as a fresh
interpreter (about a second, not milliseconds); a plug-in runs on a Ray node, with the
cluster's API within reach; runtimes are measured on whichever node ran the frame.

Ray is imported here only, and this module only when ``backend="ray"`` is asked for.
"""

from __future__ import annotations

import os
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from functools import cache
from typing import Any

from azgym.bench.run.answers import (
    GIVE_UP_AFTER,
    STARTUP_LIMIT,
    Answers,
    Report,
    build_allowance,
    give_up_note,
    overrun_reason,
    record_answers,
)
from azgym.bench.run.wire import MapData, Packed
from azgym.profile import Profile

__all__ = ["RayRun"]

@cache
def _actor_class() -> Any:
    """:class:`RayWorker` as a Ray actor: one CPU, never restarted or retried.

    A lost frame is the runner's to score, not Ray's to run again.
    """
    import ray

    from azgym.bench.run.ray_actor import RayWorker

    return ray.remote(num_cpus=1, max_restarts=0, max_task_retries=0)(RayWorker)


@dataclass
class _Slot:
    """One actor, what it is streaming back, and by when its next item is due."""

    actor: Any
    stream: Any
    deadline: float
    phase: str = "starting"
    batch: tuple[int, int] | None = None
    done: int = 0
    warmed: bool = False


class RayRun:
    """One contender on a run's frames, in up to ``workers`` Ray actors at a time.

    The same arguments and answers as :class:`~azgym.bench.run.isolation.IsolatedRun`.
    """

    def __init__(self, spec: str, params: dict[str, Any], frames: Sequence[Packed],
                 maps: Mapping[str, MapData], *, workers: int, time_limit: float,
                 batches: Sequence[tuple[int, int]], profile: Profile | None = None) -> None:
        import ray

        self.ray = ray
        self.spec, self.params, self.frames = spec, params, frames
        self.profile = profile
        self.maps = ray.put(dict(maps))
        self.workers, self.time_limit = workers, time_limit
        self.answers = Answers.unanswered(len(frames))
        self.queue = list(batches)
        self.capacity = max((self._step_end(start, stop) - start for start, stop in batches),
                            default=1)
        self.slots: list[_Slot] = []
        self.lost_in_a_row = 0
        self.finished = 0
        self.unbuildable = ""

    def run(self, report: Report) -> Answers:
        """Run every frame; ``report`` hears how many are finished as they finish."""
        try:
            while self.queue or any(s.stream is not None for s in self.slots):
                self._fill()
                self._wait()
                report(self.finished)
        finally:
            for slot in self.slots:
                self.ray.kill(slot.actor, no_restart=True)
        return self.answers

    def _fill(self) -> None:
        """Give each idle actor a batch, starting actors up to the limit."""
        while self.queue and not self.unbuildable:
            idle = [s for s in self.slots if s.phase == "idle"]
            if idle:
                self._send(idle[0], self.queue.pop(0))
            elif len(self.slots) < self.workers:
                actor = _actor_class().remote()
                stream = actor.build.remote(self.spec, self.params, self.profile, self.maps,
                                            os.getcwd(), self.capacity)
                self.slots.append(_Slot(actor, stream, time.monotonic() + STARTUP_LIMIT,
                                        batch=self.queue.pop(0)))
            else:
                return
        if self.unbuildable:
            for start, stop in self.queue:
                self._skip(start, stop, self.unbuildable)
            self.queue.clear()

    def _send(self, slot: _Slot, batch: tuple[int, int]) -> None:
        """Give the actor a batch, in steps.

        Each step is an argument of the call (a small one, which Ray sends inline with the
        call, not through its object store, where a plug-in that joins the cluster could read
        ahead).
        """
        slot.batch, slot.done, slot.phase = batch, 0, "answering"
        steps, first = [], batch[0]
        while first < batch[1]:
            end = self._step_end(first, batch[1])
            steps.append(list(self.frames[first:end]))
            first = end
        slot.stream = slot.actor.answer.remote(*steps)
        slot.deadline = time.monotonic() + self.time_limit

    def _step_end(self, first: int, stop: int) -> int:
        """Where the step from frame ``first`` ends: after it.

        The actor hands its worker one frame at a time, so a tracker never holds its route's
        next frame.
        """
        return first + 1

    def _wait(self) -> None:
        """Wait for an item, a death or a deadline, and deal with whatever happened."""
        busy = [s for s in self.slots if s.stream is not None]
        if not busy:
            return
        soonest = min(s.deadline for s in busy) - time.monotonic()
        self.ray.wait([s.stream for s in busy], num_returns=1,
                      timeout=min(max(soonest, 0.001), 0.5))
        for slot in busy:
            self._drain(slot)
            if slot.stream is not None and time.monotonic() > slot.deadline:
                self._lose(slot, overrun_reason(slot.phase, self.time_limit, "the Ray actor"))

    def _drain(self, slot: _Slot) -> None:
        """Read every item the actor has streamed back so far."""
        while slot.stream is not None and self.ray.wait([slot.stream], timeout=0)[0]:
            try:
                item = self.ray.get(next(slot.stream))
            except StopIteration:
                self._end_of_stream(slot)
                return
            except self.ray.exceptions.RayError as exc:
                self._lose(slot, _death(exc))
                return
            self._take(slot, item)

    def _take(self, slot: _Slot, item: tuple[Any, ...]) -> None:
        """One item from an actor: a phase of its build, or a frame's answer."""
        now = time.monotonic()
        if item[0] == "unbuildable":
            self.unbuildable = f"cannot build {self.spec!r}: {item[1]}"
            self._retire(slot, self.unbuildable)
            return
        if item[0] == "died":
            self._lose(slot, item[1])
            return
        if item[0] in ("building", "warming"):
            slot.phase = item[0]
            slot.deadline = now + build_allowance(self.spec, item[0] == "warming",
                                                  self.time_limit)
        elif item[0] == "ready":
            assert slot.batch is not None
            self._send(slot, slot.batch)
        elif item[0] == "warmed" and not slot.warmed:  # once: it must not extend the deadline
            slot.warmed = True
            slot.deadline = now + self.time_limit
        elif item[0] == "answers":
            assert slot.batch is not None
            for answer, error in item[1]:
                self._record(slot.batch[0] + slot.done, answer, error)
                slot.done += 1
            slot.deadline = now + self.time_limit

    def _end_of_stream(self, slot: _Slot) -> None:
        """A batch was answered: the actor is idle."""
        if slot.phase == "answering":
            self.lost_in_a_row = 0
        slot.batch, slot.stream, slot.phase = None, None, "idle"

    def _record(self, k: int, answer: list[float], error: str) -> None:
        record_answers(self.answers, k, [answer])
        self.answers.errors[k] = error
        self.finished += 1

    def _lose(self, slot: _Slot, reason: str) -> None:
        """The actor overran or died: score its current frame, requeue the rest, replace it."""
        if slot.phase != "answering":
            if slot.phase == "building":
                self.unbuildable = reason
            self._retire(slot, reason)
            return
        assert slot.batch is not None
        self._retire(slot, "")
        start, stop = slot.batch[0] + slot.done, slot.batch[1]
        self.answers.errors[start] = reason
        self.finished += 1
        self.lost_in_a_row += 1
        if self.lost_in_a_row >= GIVE_UP_AFTER:
            note = give_up_note(reason)
            for first, last in [(start + 1, stop), *self.queue]:
                self._skip(first, last, note)
            self.queue.clear()
        elif stop > start + 1:
            self.queue.insert(0, (start + 1, stop))

    def _retire(self, slot: _Slot, reason: str) -> None:
        """Kill the actor; with a reason, its batch will not run and is scored unavailable."""
        self.ray.kill(slot.actor, no_restart=True)
        self.slots.remove(slot)
        slot.stream = None
        if reason and slot.batch is not None:
            self._skip(slot.batch[0] + slot.done, slot.batch[1], reason)

    def _skip(self, start: int, stop: int, reason: str) -> None:
        """Score frames that will not run as unavailable, with the reason."""
        for k in range(start, stop):
            self.answers.errors[k] = self.answers.errors[k] or reason
        self.finished += max(stop - start, 0)


def _death(exc: Exception) -> str:
    """Why an actor is gone, in words (Ray's last line says how it ended)."""
    lines = [line.strip() for line in str(exc).splitlines() if line.strip()]
    return f"the localizer's process died ({lines[-1] if lines else type(exc).__name__})"
