"""The known map as an occupancy grid, and each free cell's clearance: what the planner searches.

A cell is occupied when its centre lies in a rack's footprint, within half a wall's thickness
(plus half a cell) of a wall, or outside the room. The *clearance* of a cell is the distance from
its centre to the nearest occupied cell's centre (scipy's exact Euclidean distance transform).
The forklift fits where the clearance is at least :data:`INFLATION`, half its width plus a
margin, the grid's form of "racks inflated by the forklift's size": the planner then treats the
forklift's reference point as a point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from azgym.core import FloatArray
from azgym.errors import InvalidInputError
from azgym.site import Scenario
from azgym.world.forklift import ForkliftSpec
from azgym.world.world import WALL_THICKNESS

__all__ = ["Grid", "INFLATION", "MAX_CELLS", "RESOLUTION", "build_grid"]

RESOLUTION = 0.1
"""Side of a grid cell [m]."""
INFLATION = 0.5 * ForkliftSpec().width + 0.2
"""Least clearance of a cell the forklift's reference point may cross [m]: half its width and
20 cm to spare (a rear-steered forklift's tail swings out in turns)."""
MAX_CELLS = 4_000_000
"""Largest grid the planner builds (a 200 m × 200 m floor at 10 cm)."""


@dataclass(frozen=True)
class Grid:
    """The floor as cells of :data:`RESOLUTION`.

    Attributes:
        origin: (x, y) of the centre of cell (0, 0) [m].
        clearance: Distance from each cell's centre to the nearest occupied one, shape (ny, nx)
            [m]; 0 on occupied cells. Row i is y = origin[1] + i · RESOLUTION.
        nearest_free: For every cell, the flat index of the nearest cell the forklift may cross
            (itself when it may), shape (ny, nx) int.
    """

    origin: tuple[float, float]
    clearance: FloatArray
    nearest_free: np.ndarray

    @property
    def free(self) -> np.ndarray:
        """Cells the forklift's reference point may cross, shape (ny, nx) bool."""
        return self.clearance >= INFLATION

    def cell(self, x: float, y: float) -> tuple[int, int]:
        """(row, column) of the cell holding (x, y), clipped to the grid."""
        ny, nx = self.clearance.shape
        column = int(round((x - self.origin[0]) / RESOLUTION))
        row = int(round((y - self.origin[1]) / RESOLUTION))
        return min(max(row, 0), ny - 1), min(max(column, 0), nx - 1)

    def centre(self, row: int, column: int) -> tuple[float, float]:
        """(x, y) of a cell's centre [m]."""
        return (self.origin[0] + column * RESOLUTION, self.origin[1] + row * RESOLUTION)


def build_grid(scenario: Scenario) -> Grid:
    """The occupancy grid and clearance of a scenario's floor (module docstring).

    Raises:
        InvalidInputError: The floor needs more than :data:`MAX_CELLS` cells, or no cell of it
            leaves the forklift room to pass.
    """
    x0, y0, x1, y1 = scenario.bounds
    # One ring of cells beyond the room on every side: outside the walls is occupied.
    nx = int(math.ceil((x1 - x0) / RESOLUTION)) + 3
    ny = int(math.ceil((y1 - y0) / RESOLUTION)) + 3
    if nx * ny > MAX_CELLS:
        raise InvalidInputError(
            f"scenario {scenario.name!r}: its floor needs {nx * ny} planner cells of "
            f"{RESOLUTION} m, more than {MAX_CELLS}")
    origin = (x0 - RESOLUTION, y0 - RESOLUTION)
    xs = origin[0] + RESOLUTION * np.arange(nx)
    ys = origin[1] + RESOLUTION * np.arange(ny)
    x, y = np.meshgrid(xs, ys)
    occupied = (x < x0) | (x > x1) | (y < y0) | (y > y1)
    for rack in scenario.racks:
        occupied |= rack.contains(x, y, margin=-0.5 * RESOLUTION)
    reach = 0.5 * WALL_THICKNESS + 0.5 * RESOLUTION
    for wall in scenario.walls:
        occupied |= _distance_to_segment(x, y, wall.start, wall.end) <= reach
    clearance = RESOLUTION * ndimage.distance_transform_edt(~occupied)
    free = clearance >= INFLATION
    if not free.any():
        raise InvalidInputError(
            f"scenario {scenario.name!r}: no place on its floor leaves the forklift "
            f"{INFLATION:.2f} m from every rack and wall")
    _, (rows, columns) = ndimage.distance_transform_edt(~free, return_indices=True)
    return Grid(origin, clearance, (rows * nx + columns).astype(np.int64))


def _distance_to_segment(x: FloatArray, y: FloatArray, start: tuple[float, float],
                         end: tuple[float, float]) -> FloatArray:
    """Distance from each point (x, y) to the segment start-end [m]."""
    ax, ay = start
    dx, dy = end[0] - ax, end[1] - ay
    length2 = dx * dx + dy * dy
    t = np.clip(((x - ax) * dx + (y - ay) * dy) / length2, 0.0, 1.0) if length2 > 0 else 0.0
    return np.hypot(x - ax - t * dx, y - ay - t * dy)
