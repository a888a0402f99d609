"""A per-frame results file screened at once, column by column: the fast path of a sound file.

:func:`~azgym.bench.leaderboard.entry_files.parse_frames` checks a file row by row, so that it
can name the first row at fault. Building a board reads every entry's file, millions of rows, and
nearly every one is sound: :func:`screened_columns` applies the same checks to whole columns at
once and hands back the columns only when every row passes every check. Whenever it is not sure
(any check fails, or a row is not what it can judge), it answers None and the row-by-row reading
decides, and says what is wrong. The screen therefore never lets through a file the row-by-row
reading refuses, and what it lets through reads to the same values (tests pin both).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from azgym.bench.report.results import frame_number

if TYPE_CHECKING:
    from azgym.bench.suites import Case

__all__ = ["HEADING_LIMIT", "ScreenedColumns", "screened_columns"]

HEADING_LIMIT = math.pi + 1e-9
"""A heading error is wrapped to [0, π] [rad]."""


class ScreenedColumns(NamedTuple):
    """A sound file's columns.

    Attributes:
        label: The localizer's label (every row's).
        scenario: Each frame's scenario.
        group: Each frame's group.
        cause: Each frame's cause.
        errors: Each frame's exception ("" for none).
        numbers: One row per frame: ok (0 or 1), the position and heading errors, the runtime,
            then the estimate's columns if the file has them.
    """

    label: str
    scenario: list[str]
    group: list[str]
    cause: list[str]
    errors: list[str]
    numbers: np.ndarray


def screened_columns(rows: list[list[str]], width: int, cases: Sequence[Case] | None
                     ) -> ScreenedColumns | None:
    """The columns of ``rows`` if every row passes every check of the row-by-row reading.

    Args:
        rows: The file's rows after its header (a header of ``width`` columns, already known
            to be one of the two the reading accepts).
        width: How many columns a row must have.
        cases: The frames the rows must be, in order (None: numbered from 0, with a heading).

    Returns:
        The columns, or None when any row may be at fault (the row-by-row reading then says
        which and why).
    """
    if not rows or {len(row) for row in rows} != {width}:
        return None
    columns = list(zip(*rows, strict=True))
    label, frame, scenario, group, cause, ok, *_ = columns
    error = columns[9]
    known = list(cases or ())[:len(rows)]
    expected = [str(frame_number(case, k)) for k, case in enumerate(known)]
    expected += map(str, range(len(known), len(rows)))
    if len(set(label)) != 1 or list(frame) != expected or not set(ok) <= {"0", "1"}:
        return None
    try:
        numbers = np.array([[ok_text == "1" for ok_text in ok],
                            *(list(map(float, columns[k])) for k in (6, 7, 8)),
                            *(list(map(float, column)) for column in columns[10:])], dtype=float)
    except ValueError:
        return None
    has_heading = np.ones(len(rows), dtype=bool)
    has_heading[:len(known)] = [not math.isnan(case.pose[2]) for case in known]
    raised = np.array([bool(text) for text in error])
    if not _sound(numbers, has_heading, raised):
        return None
    return ScreenedColumns(label[0], list(scenario), list(group), list(cause), list(error),
                           numbers.T.copy())


def _sound(numbers: np.ndarray, has_heading: np.ndarray, raised: np.ndarray) -> bool:
    """Whether every row's numbers are what the row-by-row reading accepts.

    An estimate (ok) has a finite non-negative position error, a heading error in [0, π] (NaN
    where the truth has no heading) and a finite pose; a frame without one has NaN errors and
    pose. A runtime is finite and non-negative, or NaN where the call raised; a frame that
    raised has no estimate.
    """
    answered = numbers[0] == 1.0
    position, heading, micros, estimate = numbers[1], numbers[2], numbers[3], numbers[4:]
    with np.errstate(invalid="ignore"):
        errors_sound = np.where(
            answered,
            (position >= 0.0) & (position < math.inf)
            & np.where(has_heading, (heading >= 0.0) & (heading <= HEADING_LIMIT),
                       np.isnan(heading)),
            np.isnan(position) & np.isnan(heading))
        micros_sound = ((micros >= 0.0) & (micros < math.inf)) | (raised & np.isnan(micros))
    estimate_sound = np.where(answered, np.isfinite(estimate), np.isnan(estimate)).all(axis=0)
    return bool((errors_sound & micros_sound & estimate_sound & ~(raised & answered)).all())
