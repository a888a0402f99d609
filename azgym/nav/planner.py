"""The global planner: the cheapest path from anywhere on the floor to each pick or drop spot.

For every spot, a Dijkstra search over the free cells of the :mod:`~azgym.nav.grid` (16
neighbours, :data:`~azgym.nav._descent.MOVES`) gives the cost of the cheapest path from each cell:
a *cost-to-go field*. That is A* run once for every start at the same time, so the path from any
point, including an estimated pose far off the last plan, is a descent of the field, found in
microseconds: replanning from wherever the forklift turns out to be costs nothing.

A step's cost is its length times the mean *clearance weight* of its two cells, 1 where a cell is
at least :data:`PREFERRED_CLEARANCE` from every rack and wall and rising to
1 + :data:`CLEARANCE_COST` at the inflation limit (a costmap's inflation layer), so paths keep to
the middle of the aisles and round rack ends wide. A path's length is still measured in metres.

The fields depend only on the scenario's floor and spots, and are cached per floor in a process.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from azgym.core import FloatArray
from azgym.errors import InvalidInputError
from azgym.nav._descent import MOVES, descend
from azgym.nav.grid import INFLATION, RESOLUTION, Grid, build_grid
from azgym.site import Scenario

__all__ = ["Planner", "clearance_weight", "planner_for"]

PREFERRED_CLEARANCE = 1.4
"""Clearance from which a cell costs no more than its length [m]: the middle of a 2.8 m aisle."""
CLEARANCE_COST = 4.0
"""Extra cost per metre at the inflation limit, falling quadratically to 0 at the preferred
clearance."""


class Planner:
    """Cost-to-go fields to every spot of a floor, and the paths they give.

    Build one with :func:`planner_for` (cached). ``spots[k]`` is goal k.

    Raises:
        InvalidInputError: A spot the forklift cannot reach from another one.
    """

    def __init__(self, scenario: Scenario, spots: FloatArray) -> None:
        self.grid: Grid = build_grid(scenario)
        self.spots = np.asarray(spots, dtype=np.float64)
        free = self.grid.free
        self._free = free
        self._weight = clearance_weight(self.grid.clearance)
        ny, nx = free.shape
        goal_cells = [self.snapped_cell(x, y) for x, y in self.spots]
        costs = dijkstra(_graph(self.grid), directed=False,
                         indices=[row * nx + column for row, column in goal_cells])
        self.fields = costs.reshape(len(self.spots), ny, nx)
        for k in range(len(goal_cells)):
            unreachable = [j for j, (r, c) in enumerate(goal_cells)
                           if not math.isfinite(self.fields[k, r, c])]
            if unreachable:
                raise InvalidInputError(
                    f"scenario {scenario.name!r}: spot {_spot(self.spots[k])} cannot be "
                    f"reached from spot {_spot(self.spots[unreachable[0]])}: no path keeps "
                    f"{INFLATION:.2f} m from the racks and walls")
        self._rows = np.empty(8 * (ny + nx), dtype=np.int64)
        self._columns = np.empty_like(self._rows)

    def snapped_cell(self, x: float, y: float) -> tuple[int, int]:
        """The free cell nearest to (x, y): its own cell, or the nearest one the forklift fits."""
        row, column = self.grid.cell(x, y)
        flat = int(self.grid.nearest_free[row, column])
        return divmod(flat, self._free.shape[1])

    def cost_to_go(self, goal: int, x: float, y: float) -> float:
        """The cost of the cheapest path from (x, y) to spot ``goal`` [m, clearance-weighted].

        From the nearest free cell, plus the straight distance to it; a potential for reward
        shaping (it never rises along a descent).
        """
        row, column = self.snapped_cell(x, y)
        cx, cy = self.grid.centre(row, column)
        return float(self.fields[goal, row, column]) + math.hypot(x - cx, y - cy)

    def path(self, goal: int, x: float, y: float) -> FloatArray:
        """The whole path from (x, y) to spot ``goal``: the points it passes, shape (P, 2) [m]."""
        row, column = self.snapped_cell(x, y)
        count, _ = descend(self.fields[goal], self._weight, self._free, MOVES, row, column,
                           RESOLUTION, math.inf, self._rows, self._columns)
        ox, oy = self.grid.origin
        cells = np.column_stack((ox + RESOLUTION * self._columns[:count],
                                 oy + RESOLUTION * self._rows[:count]))
        return np.vstack(([x, y], cells[:-1], self.spots[goal]))

    def plan(self, goal: int, x: float, y: float) -> tuple[FloatArray, FloatArray]:
        """The path from (x, y) to spot ``goal`` and the arc length at each of its points [m]."""
        points = self.path(goal, x, y)
        along = np.concatenate(([0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))))
        return points, along


def _spot(point: FloatArray) -> str:
    return f"({point[0]:g}, {point[1]:g})"


def clearance_weight(clearance: FloatArray) -> FloatArray:
    """The cost per metre of crossing cells of this clearance (module docstring)."""
    closeness = np.clip((PREFERRED_CLEARANCE - clearance)
                        / (PREFERRED_CLEARANCE - INFLATION), 0.0, 1.0)
    return 1.0 + CLEARANCE_COST * closeness ** 2


def _graph(grid: Grid) -> coo_matrix:
    """The free cells and the allowed moves between them, weighted by length and clearance.

    Each move is added in one direction (the graph is undirected), so half of :data:`MOVES`.
    """
    free = grid.free
    ny, nx = free.shape
    weight = clearance_weight(grid.clearance)  # the same weights the descent uses
    index = np.arange(ny * nx).reshape(ny, nx)
    sources, targets, costs = [], [], []
    for move_row, move_column in MOVES[[0, 1, 4, 5, 8, 9, 10, 11]].tolist():
        allowed = _shifted(free, 0, 0, move_row, move_column) & _shifted(
            free, move_row, move_column, move_row, move_column)
        if abs(move_row) + abs(move_column) == 3:  # a knight's move: the two cells it cuts
            half_row = move_row // 2 if abs(move_row) == 2 else 0
            half_column = move_column // 2 if abs(move_column) == 2 else 0
            allowed &= _shifted(free, half_row, half_column, move_row, move_column)
            allowed &= _shifted(free, move_row - half_row, move_column - half_column,
                                move_row, move_column)
        source = _shifted(index, 0, 0, move_row, move_column)[allowed]
        target = _shifted(index, move_row, move_column, move_row, move_column)[allowed]
        sources.append(source)
        targets.append(target)
        costs.append(RESOLUTION * math.hypot(move_row, move_column)
                     * 0.5 * (weight.flat[source] + weight.flat[target]))
    return coo_matrix((np.concatenate(costs), (np.concatenate(sources), np.concatenate(targets))),
                      shape=(ny * nx, ny * nx)).tocsr()


def _shifted(values: np.ndarray, row: int, column: int, move_row: int,
             move_column: int) -> np.ndarray:
    """``values`` at (r + row, c + column) for the cells (r, c) a move stays on the grid from.

    The move is (move_row, move_column); the cells are the same, in the same order, for any
    ``row`` and ``column``, so shifted views of different arrays line up.
    """
    ny, nx = values.shape
    r0, r1 = max(0, -move_row), ny - max(0, move_row)
    c0, c1 = max(0, -move_column), nx - max(0, move_column)
    return values[r0 + row:r1 + row, c0 + column:c1 + column]


_PLANNERS: dict[tuple, Planner] = {}
_MAX_CACHED = 16


def planner_for(scenario: Scenario, spots: FloatArray) -> Planner:
    """The planner of a scenario's floor and spots, built once per process (16 kept)."""
    spots = np.asarray(spots, dtype=np.float64)
    key = (scenario.bounds, scenario.racks, scenario.walls, spots.tobytes())
    if key not in _PLANNERS:
        if len(_PLANNERS) >= _MAX_CACHED:
            _PLANNERS.pop(next(iter(_PLANNERS)))
        _PLANNERS[key] = Planner(scenario, spots)
    return _PLANNERS[key]
