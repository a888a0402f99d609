"""What a contender answered, and the rules both backends share (the pool's and Ray's).

The runner's backends (:mod:`azgym.bench.run.isolation`, :mod:`azgym.bench.run.ray_backend`) record
a contender's answers, word the reasons of lost frames and decide when to give up the same way.
"""

from __future__ import annotations

import signal
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from azgym.bench.run import worker
from azgym.localize.registry import is_builtin

__all__ = ["Answers", "GIVE_UP_AFTER", "Report", "STARTUP_LIMIT", "build_allowance", "death",
           "give_up_note", "overrun_reason", "record_answers"]

STARTUP_LIMIT = 300.0
"""Seconds a new worker may take to come up, not counting the build. The first run on a machine
compiles azgym's kernels in the fork server (tens of seconds); later runs take milliseconds."""
GIVE_UP_AFTER = 3
"""Frames lost in a row (time-outs or dead workers) after which a contender's other frames are
skipped."""
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


def build_allowance(spec: str, warming: bool, time_limit: float) -> float:
    """Seconds a contender's build phase may take, the one rule of both backends.

    The compile allowance while a built-in warms up (azgym's own code compiling its kernels),
    the time limit otherwise: a plug-in that says it is warming, through the messages or the
    shared progress it can reach, gets no more.
    """
    return STARTUP_LIMIT if warming and is_builtin(spec) else time_limit


def give_up_note(reason: str) -> str:
    """The error of the frames skipped after :data:`GIVE_UP_AFTER` losses in a row."""
    return f"not run: {GIVE_UP_AFTER} frames in a row were lost (last: {reason})"


def record_answers(answers: Answers, start: int, rows: Sequence[Sequence[float]]) -> None:
    """Decode answer rows (``worker.ANSWER_*`` columns) into frames ``start``, ``start + 1``...

    Plain Python: a route's frames are committed one at a time, where numpy costs more than
    the arithmetic.
    """
    for k, row in enumerate(rows, start):
        state = row[worker.ANSWER_STATE]
        answers.posed[k] = state == worker.POSED
        if state == worker.POSED:
            answers.pose[k] = row[worker.ANSWER_X], row[worker.ANSWER_Y], \
                row[worker.ANSWER_HEADING]
        if state in (worker.POSED, worker.NO_POSE):
            answers.micros[k] = row[worker.ANSWER_MICROS]


def death(process: Any) -> str:
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
