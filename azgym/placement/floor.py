"""The drivable floor as a grid of cells: where the forklift's camera can stand.

A cell is a point of a regular grid over the room, ``step`` metres apart. It is *on the floor*
when a camera pose may be drawn there: by the rule of :mod:`azgym.site.sampling` (the one the
suites and studies draw random poses by), at least ``WALL_CLEARANCE`` inside the room's bounds
and ``RACK_CLEARANCE`` clear of every rack's footprint. The grid is centred in the room, so its
margins on opposite walls are equal.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from azgym.arguments import positive_number
from azgym.core import BoolArray, FloatArray
from azgym.errors import InvalidInputError, ScenarioError
from azgym.site import Scenario
from azgym.site.sampling import RACK_CLEARANCE, WALL_CLEARANCE, clear_of_racks

__all__ = ["DEFAULT_STEP", "MAX_CELLS", "Floor", "floor_grid"]

DEFAULT_STEP = 0.5
"""Default spacing of the grid [m]: finer than an aisle (2.8-4 m), coarse enough to be quick."""
MAX_CELLS = 250_000
"""The largest grid analysed (a 250 m × 250 m hall at 0.5 m): each cell costs a line-of-sight
test per beacon, and, in the optimizer, one per candidate place too."""


@dataclass(frozen=True)
class Floor:
    """The grid and which of its cells are on the floor.

    Attributes:
        xs: x of each grid column [m], shape (nx,).
        ys: y of each grid row [m], shape (ny,).
        free: Whether each cell is on the floor, shape (ny, nx); row i is y = ys[i].
        step: The spacing [m].
    """

    xs: FloatArray
    ys: FloatArray
    free: BoolArray
    step: float

    @property
    def points(self) -> FloatArray:
        """(x, y) of the cells on the floor, row by row, shape (P, 2) [m]."""
        rows, columns = np.nonzero(self.free)
        return np.c_[self.xs[columns], self.ys[rows]]

    def to_grid(self, values: FloatArray) -> FloatArray:
        """Per-cell ``values`` (P,) laid out on the grid, NaN off the floor, shape (ny, nx)."""
        grid = np.full(self.free.shape, np.nan)
        grid[self.free] = values
        return grid


def floor_grid(scenario: Scenario, step: float = DEFAULT_STEP) -> Floor:
    """The grid of ``scenario``'s floor, ``step`` metres apart (module docstring).

    Raises:
        InvalidInputError: ``step`` is not a number > 0, is larger than the room, or makes more
            than :data:`MAX_CELLS` cells.
        ScenarioError: No cell of the grid is on the floor.
    """
    step = positive_number("step", step, "m")
    x_min, y_min, x_max, y_max = scenario.bounds
    span_x, span_y = x_max - x_min - 2 * WALL_CLEARANCE, y_max - y_min - 2 * WALL_CLEARANCE
    if step > min(x_max - x_min, y_max - y_min):
        raise InvalidInputError(f"step {step:g} m is larger than the room "
                                f"({x_max - x_min:g} m x {y_max - y_min:g} m)")
    nx, ny = _count(span_x, step), _count(span_y, step)
    if nx * ny > MAX_CELLS:
        raise InvalidInputError(f"step {step:g} m makes a grid of {nx:.6g} x {ny:.6g} cells on "
                                f"{scenario.name!r}, more than {MAX_CELLS}; use a larger step")
    nx, ny = int(nx), int(ny)
    xs = _centred(x_min + WALL_CLEARANCE, span_x, nx, step)
    ys = _centred(y_min + WALL_CLEARANCE, span_y, ny, step)
    gx, gy = np.meshgrid(xs, ys)
    free = clear_of_racks(scenario, gx, gy)
    if not free.any():
        raise ScenarioError(f"{scenario.name}: no cell of a {step:g} m grid is on the floor "
                            f"({WALL_CLEARANCE} m inside the walls and {RACK_CLEARANCE} m clear "
                            "of the racks)")
    return Floor(xs, ys, free, step)


def _count(span: float, step: float) -> float:
    """How many points ``step`` apart fit in ``span`` (at least one), as a float.

    A float, so that a tiny step makes a huge (or infinite) count to compare with the cap rather
    than an overflow or a 600-digit integer.
    """
    ratio = span / step + 1e-9  # Python floats: inf, not an error, for a subnormal step
    return max(1.0, (math.floor(ratio) if math.isfinite(ratio) else math.inf) + 1.0)


def _centred(start: float, span: float, count: int, step: float) -> FloatArray:
    """``count`` points ``step`` apart, centred in [start, start + span]."""
    return start + 0.5 * (span - (count - 1) * step) + step * np.arange(count, dtype=np.float64)
