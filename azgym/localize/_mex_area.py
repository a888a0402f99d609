"""Where mex searches, and whether a grid over that area can be searched (Sec. 3.1).

Without ``bounds``, :class:`~azgym.localize.mex.Mex` searches the measured beacons' bounding box
(:func:`seen_box`), then the map's extent: its beacons' box grown by a margin (:func:`grown`).
:func:`check_bounds` refuses given bounds that are not a box, and :func:`grid_shape` counts the
fine grid over a box, refusing one too large to search or finer than the floating-point
resolution of its coordinates, before any work.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from azgym.errors import InvalidInputError
from azgym.hyperparameters import check_range
from azgym.localize.base import Problem

Box = tuple[float, float, float, float]
"""An area (x_min, y_min, x_max, y_max) [m]."""

STEP_ROUNDING = 1e-9
"""A length divided by the grid step within this of an integer counts as that integer.

So a bound that lies on a grid line up to rounding is inside the grid, and a coarse step that is
a multiple of the step up to rounding is accepted.
"""
MAX_GRID_POINTS = 100_000_000
"""Most points mex evaluates exhaustively in one frame: the whole grid, or the coarse grid.

1e8 is the 1 cm grid of a 100 m × 100 m hall, minutes a frame; beyond it a run would not end in
useful time (and a tiny step or huge bounds would ask for more points than memory or an integer
holds), so it is refused with a named error before any work.
"""
MAX_AXIS_POINTS = 2**31
"""Most fine-grid points along one axis of a coarse-to-fine search (whose fine grid is never
evaluated whole): grid indices stay exact integers and exact in floating point."""
SEEN_BOX = "the measured beacons' bounding box"
"""How messages name the first area searched without ``bounds``."""
DEFAULT_MARGIN = 5.0
"""How far beyond the map's outermost beacons mex searches by default [m]: a camera sees beacons
from a few metres away (MRCLAM's robots drive up to 4.8 m outside its landmarks' box)."""
STEP_RESOLUTION = 2.0**-40
"""The step must be at least this times the grid's largest |coordinate| (about 1e-12): finer,
neighbouring grid points would round to the same coordinate."""


def seen_box(problem: Problem) -> Box:
    """The measured beacons' bounding box (x_min, y_min, x_max, y_max) [m]."""
    return (float(problem.bx.min()), float(problem.by.min()), float(problem.bx.max()),
            float(problem.by.max()))


def as_box(bounds: Sequence[float]) -> Box:
    """Checked ``bounds`` (:func:`check_bounds`) as a :data:`Box` of floats."""
    x_min, y_min, x_max, y_max = (float(v) for v in bounds)
    return x_min, y_min, x_max, y_max


def grown(box: Box, margin: float) -> Box:
    """``box`` grown by ``margin`` [m] on every side."""
    x_min, y_min, x_max, y_max = box
    m = float(margin)
    return x_min - m, y_min - m, x_max + m, y_max + m


def check_bounds(name: str, bounds: object) -> None:
    """Refuse ``bounds`` that are not four finite numbers (x_min, y_min, x_max, y_max), min ≤ max.

    Args:
        name: The localizer's class name, which the messages name the field by.
        bounds: The ``bounds`` hyperparameter as given.

    Raises:
        InvalidInputError: Not four numbers, a value that is not finite, or max < min.
    """
    if not isinstance(bounds, (tuple, list, np.ndarray)) or len(bounds) != 4:
        raise InvalidInputError(
            f"{name}.bounds must be (x_min, y_min, x_max, y_max) (in a spec: "
            f"bounds=x_min,y_min,x_max,y_max), got {bounds!r}"
        )
    for value in bounds:
        check_range(name, "bounds", value)
    if bounds[2] < bounds[0] or bounds[3] < bounds[1]:
        raise InvalidInputError(f"{name}.bounds has max < min: {bounds!r}")


def grid_shape(name: str, step: float, coarse_step: float | None, box: Box,
               where: str) -> tuple[int, int]:
    """(nx, ny) of the fine grid over ``box``, refusing a grid that cannot be searched.

    Counted in floating point before any integer or array is made, so huge coordinates or a
    tiny step give a named error instead of an overflow or an allocation failure.

    Args:
        name: The localizer's class name, which the messages name the fields by.
        step: The fine grid's spacing [m].
        coarse_step: The coarse pass's spacing [m], a multiple of ``step``; None: exhaustive.
        box: The area searched.
        where: How the messages name that area.

    Raises:
        InvalidInputError: More than MAX_GRID_POINTS points to evaluate exhaustively, a
            coarse-to-fine lattice beyond MAX_AXIS_POINTS a side, or a step below the
            floating-point resolution of the coordinates.
    """
    x_min, y_min, x_max, y_max = box
    spacing = float(step)
    shown = f"({x_min:g}, {y_min:g}, {x_max:g}, {y_max:g})"
    if spacing < STEP_RESOLUTION * max(abs(x_min), abs(y_min), abs(x_max), abs(y_max)):
        raise InvalidInputError(
            f"{name}.step={step} is below the floating-point resolution of the grid "
            f"over {where} {shown}")
    spans = [(high - low) / spacing for low, high in ((x_min, x_max), (y_min, y_max))]
    counts = [math.floor(span + STEP_ROUNDING) + 1 if math.isfinite(span) else math.inf
              for span in spans]
    evaluated = counts
    if coarse_step is not None:
        if max(counts) > MAX_AXIS_POINTS:
            raise InvalidInputError(
                f"{name}: the grid over {where} {shown} at step={step} has more than "
                f"{MAX_AXIS_POINTS} points a side; use a larger step or smaller bounds")
        ratio = round(coarse_step / step)
        evaluated = [(count - 1) // ratio + 1 for count in counts]
    if evaluated[0] * evaluated[1] > MAX_GRID_POINTS:
        raise InvalidInputError(
            f"{name}: the grid over {where} {shown} would have {evaluated[0] * evaluated[1]:.3g}"
            f" points to evaluate, more than {MAX_GRID_POINTS:.0e}; use a larger step, "
            "smaller bounds or coarse_step")
    return int(counts[0]), int(counts[1])
