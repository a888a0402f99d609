"""The method of exhaustion (MEX): the brute-force minimum of eq. 34 on a grid (Sec. 3.1)."""

from __future__ import annotations

import math

import numpy as np

from azgym.core import BeaconMap, Estimate, FloatArray, Measurements
from azgym.errors import InvalidInputError
from azgym.hyperparameters import check_range
from azgym.jit import jit
from azgym.localize import _kernels as K
from azgym.localize._angles import azimuth_spread, fast_atan2
from azgym.localize._levenberg_marquardt import singular_at
from azgym.localize._mex_area import (
    DEFAULT_MARGIN,
    SEEN_BOX,
    STEP_ROUNDING,
    Box,
    as_box,
    check_bounds,
    grid_shape,
    grown,
    seen_box,
)
from azgym.localize.base import MIN_MEASUREMENTS, Localizer, Problem

__all__ = ["Mex", "grid_search"]

CANCELLED = 1e-18
"""|Σ unit vectors|² below this times n² leaves a grid point's heading (and E_ref) undefined.

The n unit vectors along β_b − α_b then cancel to within 1e-9 of their count: their mean
direction is rounding noise.
"""
SEED_MOVES = 64
"""Most moves of a coarse minimum's window on the fine grid: a cap on the descent's run time (a
descent normally stops after a few moves of one coarse step)."""
BEACON_SEED_MOVES = 1
"""Moves of a beacon's window: one. It is there for a basin at the beacon, and a descent that
leaves the window is heading for a minimum that a coarse seed covers."""
MAX_COARSE_RATIO = 1000
"""Largest coarse_step / step: each descent window has (2·ratio + 1)² fine points (4e6 here)."""


@jit(fastmath=K.VECTOR_MATH)
def _row_costs(bx, by, ca, sa, y, x0, step, nx, ux, uy, mean, cost):
    """E_ref (eq. 34) at the grid points (x0 + i·step, y), i < nx, written into ``cost``.

    For a candidate position, the world direction of beacon b rotated back by α_b, v_b, points
    along β_b − α_b = φ + ε_b. The heading φ' of eq. 29 is the mean of these angles; they are
    unwrapped around their circular mean u (so a point far from the truth, whose angles spread
    round the circle, still gets a well-defined mean), and E_ref is their variance.
    ``ux, uy, mean`` are scratch rows of length nx.
    """
    n = bx.size
    for i in range(nx):
        ux[i] = 0.0
        uy[i] = 0.0
        mean[i] = 0.0
        cost[i] = 0.0
    for b in range(n):
        dy = by[b] - y
        for i in range(nx):
            dx = bx[b] - (x0 + i * step)
            vx = dx * ca[b] + dy * sa[b]
            vy = dy * ca[b] - dx * sa[b]
            inv = 1.0 / math.sqrt(vx * vx + vy * vy)
            ux[i] += vx * inv
            uy[i] += vy * inv
    for b in range(n):
        dy = by[b] - y
        for i in range(nx):
            dx = bx[b] - (x0 + i * step)
            vx = dx * ca[b] + dy * sa[b]
            vy = dy * ca[b] - dx * sa[b]
            d = fast_atan2(ux[i] * vy - uy[i] * vx, ux[i] * vx + uy[i] * vy)
            mean[i] += d
            cost[i] += d * d
    inv_n = 1.0 / n
    for i in range(nx):
        m = mean[i] * inv_n
        spread = cost[i] * inv_n - m * m
        # Directions that cancel (|u| ≈ 0) leave the heading, and so E_ref, undefined.
        cost[i] = spread if ux[i] * ux[i] + uy[i] * uy[i] > CANCELLED * n * n else np.inf


@jit
def grid_search(bx, by, ca, sa, x0, y0, step, nx, ny, costs_out):
    """Exhaustive minimum of eq. 34 on the nx × ny grid from (x0, y0); row by row, O(nx) memory.

    If ``costs_out`` has shape (ny, nx) every cost is stored there too. Returns (i, j, E_min).
    """
    ux = np.empty(nx)
    uy = np.empty(nx)
    mean = np.empty(nx)
    cost = np.empty(nx)
    best = np.inf
    best_i = -1
    best_j = -1
    keep = costs_out.shape[0] == ny and costs_out.shape[1] == nx
    for j in range(ny):
        _row_costs(bx, by, ca, sa, y0 + j * step, x0, step, nx, ux, uy, mean, cost)
        for i in range(nx):
            if cost[i] < best:
                best = cost[i]
                best_i = i
                best_j = j
            if keep:  # element by element: a row copy compiles a slow shape check
                costs_out[j, i] = cost[i]
    return best_i, best_j, best


def _local_minima(costs: FloatArray, count: int) -> list[tuple[int, int]]:
    """(row, column) of the ``count`` lowest local minima (8-neighbourhood) of a cost grid."""
    padded = np.pad(costs, 1, constant_values=np.inf)
    centre = padded[1:-1, 1:-1]
    is_min = np.ones(costs.shape, dtype=bool)
    rows, cols = costs.shape
    for dr in (-1, 0, 1):
        for dc in (-1, 0, 1):
            if dr or dc:
                is_min &= centre <= padded[1 + dr:1 + dr + rows, 1 + dc:1 + dc + cols]
    candidates = np.argwhere(is_min)
    order = np.argsort(costs[is_min], kind="stable")[:count]
    return [(int(r), int(c)) for r, c in candidates[order]]


def _falls_outside(args: tuple[FloatArray, ...], x0: float, y0: float, step: float,
                   cell: tuple[int, int], shape: tuple[int, int]) -> bool:
    """Whether a lattice neighbour outside the grid costs less than the grid point ``cell``.

    ``cell`` is (i, j) of the best grid point and ``shape`` the grid's (nx, ny). Every neighbour
    inside the grid costs at least as much as the best point, so a lower neighbour outside means
    that the grid's minimum is only the minimum of its edge, not a minimum of eq. 34: the search
    stopped where the cost was still falling. The 3 × 3 block is scored in one call, centre
    included, so the comparison is between costs computed alike.
    """
    (i, j), (nx, ny) = cell, shape
    around = np.empty((3, 3))
    grid_search(*args, x0 + (i - 1) * step, y0 + (j - 1) * step, step, 3, 3, around)
    for dj in range(3):
        for di in range(3):
            outside = not (0 <= i + di - 1 < nx and 0 <= j + dj - 1 < ny)
            if outside and around[dj, di] < around[1, 1]:
                return True
    return False


class Mex(Localizer):
    """Method of exhaustion: the grid point with the smallest mean squared azimuth error (eq. 34).

    Every grid point (x, y) is scored with E_ref = mean ε_i² over all measurements, with the
    heading φ' of eq. 29; the answer is the best grid point and its φ'. There is no outlier
    rejection: it is the paper's reference method, guaranteed to find the optimum on the grid.
    When that optimum is on the grid's edge and the cost still falls beyond it, the camera is
    outside the searched area and the answer is ``ok=False`` with that reason, not the edge point.

    ``coarse_step`` enables a coarse-to-fine search for long studies: the cost on a coarse grid,
    then descents on the fine grid (same lattice as the exhaustive one) from the
    ``n_candidates`` lowest coarse local minima and from every beacon. The exhaustive grid stays
    the default.

    Without ``bounds`` the search covers the map's extent in two stages: first the measured
    beacons' bounding box (the cheapest grid, and the whole answer for a camera that sees
    beacons on every side, azimuths spread over π or more: it can only be inside their hull),
    then, for a narrower view whose cost keeps falling beyond that box's edge, the map's
    beacons' bounding box grown by ``margin`` on every side. A forward camera sees the beacons
    ahead of it, so it is never inside the box of those it sees; the second stage finds it.

    Args:
        step: Grid spacing [m] (the paper: 1 cm).
        bounds: (x_min, y_min, x_max, y_max) [m], the area searched; None: the map's extent
            (above). The grid may hold at most ``_mex_area.MAX_GRID_POINTS`` points (the coarse
            grid, with ``coarse_step``). In a spec: ``mex:bounds=x_min,y_min,x_max,y_max``.
        coarse_step: Spacing of the coarse pass [m], a multiple of ``step``; None: exhaustive.
        n_candidates: Coarse local minima refined on the fine grid.
        margin: How far beyond the map's outermost beacons the camera may be [m] (without
            ``bounds``): a camera sees beacons from metres away.
    """

    name = "mex"

    def __init__(
        self,
        *,
        step: float = 0.01,
        bounds: tuple[float, float, float, float] | None = None,
        coarse_step: float | None = None,
        n_candidates: int = 8,
        margin: float = DEFAULT_MARGIN,
    ) -> None:
        self.step = step
        self.bounds = bounds
        self.coarse_step = coarse_step
        self.n_candidates = n_candidates
        self.margin = margin
        self._validate_once()

    def _check_params(self) -> None:
        name = type(self).__name__
        check_range(name, "step", self.step, low=0.0, low_open=True)
        check_range(name, "n_candidates", self.n_candidates, low=1, integer=True)
        check_range(name, "margin", self.margin, low=0.0)
        if self.coarse_step is not None:
            check_range(name, "coarse_step", self.coarse_step, low=self.step)
            ratio = self.coarse_step / self.step
            if abs(ratio - round(ratio)) > STEP_ROUNDING:
                raise InvalidInputError(
                    f"{name}.coarse_step must be a multiple of step={self.step}, "
                    f"got {self.coarse_step}"
                )
            if round(ratio) > MAX_COARSE_RATIO:
                raise InvalidInputError(
                    f"{name}.coarse_step must be at most {MAX_COARSE_RATIO} steps, got "
                    f"{self.coarse_step} = {round(ratio)} × step"
                )
        if self.bounds is not None:
            check_bounds(name, self.bounds)
            self._grid_shape(as_box(self.bounds), "bounds")

    def grid(self, problem: Problem) -> tuple[float, float, int, int]:
        """(x0, y0, nx, ny) of the fine grid for this frame.

        Raises:
            InvalidInputError: The grid is too large to search (see ``_grid_shape``).
        """
        if self.bounds is not None:
            box, where = as_box(self.bounds), "bounds"
        else:
            box, where = seen_box(problem), SEEN_BOX
        nx, ny = self._grid_shape(box, where)
        return box[0], box[1], nx, ny

    def _grid_shape(self, box: Box, where: str) -> tuple[int, int]:
        """(nx, ny) of the fine grid over ``box`` (:func:`~azgym.localize._mex_area.grid_shape`).

        Raises:
            InvalidInputError: The grid cannot be searched.
        """
        return grid_shape(type(self).__name__, self.step, self.coarse_step, box, where)

    def extent(self, box: Box) -> Box:
        """The area searched without ``bounds``: the map's beacons' ``box`` grown by ``margin``."""
        return grown(box, self.margin)

    def _localize_frame(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        problem = Problem.from_frame(measurements, beacons)
        if problem.n_distinct < MIN_MEASUREMENTS:
            return super()._localize_frame(measurements, beacons)  # the standard refusal
        return self._search(problem, beacons.bounds())

    def _localize(self, problem: Problem) -> Estimate:
        """A :class:`Problem` without its map: the map's beacons are the measured ones."""
        return self._search(problem, seen_box(problem))

    def _search(self, problem: Problem, map_box: Box) -> Estimate:
        """``bounds``, or the measured beacons' box, then the map's extent (class docstring)."""
        estimate, on_edge = self._solve(problem, *self.grid(problem),
                                        "bounds" if self.bounds is not None else SEEN_BOX)
        # The map's extent is searched when the box's best point is on its edge: a refusal whose
        # cost keeps falling outside ("grid_point"), or an answer (rising outside, it may yet be
        # a local minimum only, next to a beacon whose direction turns fast).
        beyond = "grid_point" in estimate.diagnostics or (estimate.ok and on_edge)
        if self.bounds is not None or not beyond or azimuth_spread(problem.azimuth) >= math.pi:
            return estimate  # beacons on every side: the camera is inside their hull
        extent = self.extent(map_box)
        if extent == seen_box(problem):
            return estimate  # the map's extent is the box just searched
        where = f"the map's extent (its beacons' box and margin={self.margin:g} m)"
        try:
            nx, ny = self._grid_shape(extent, where)
        except InvalidInputError as exc:
            return Estimate.failure(f"{estimate.reason}; {exc}", problem.n_measurements,
                                    estimate.diagnostics) if not estimate.ok else estimate
        wider, _ = self._solve(problem, extent[0], extent[1], nx, ny, where)
        # An answer is replaced only by one of lower cost: a true answer stays bit for bit.
        lower = wider.ok and wider.diagnostics["cost"] < estimate.diagnostics.get("cost", math.inf)
        return wider if lower or not estimate.ok else estimate

    def _solve(self, problem: Problem, x0: float, y0: float, nx: int, ny: int,
               where: str) -> tuple[Estimate, bool]:
        """The nx × ny grid's minimum from (x0, y0) (refused if only the edge's); if on the edge.

        ``where`` names the area searched in the refusal's message.
        """
        args = (problem.bx, problem.by, problem.cos_az, problem.sin_az)
        step = float(self.step)
        no_store = np.empty((0, 0))
        if self.coarse_step is None:
            i, j, cost = grid_search(*args, x0, y0, step, nx, ny, no_store)
        else:
            i, j, cost = self._coarse_to_fine(args, self.coarse_step, x0, y0, nx, ny, no_store)
        if i < 0:
            return Estimate.failure("no grid point has a finite cost",
                                    problem.n_measurements), False
        x = x0 + i * step
        y = y0 + j * step
        on_edge = i in (0, nx - 1) or j in (0, ny - 1)
        if on_edge and _falls_outside(args, x0, y0, step, (i, j), (nx, ny)):
            return Estimate.failure(
                f"the best grid point ({x:.6g}, {y:.6g}) is on the edge of the grid and the cost "
                f"keeps falling outside it: the camera is outside the searched area ({where}; "
                "give bounds that contain it)", problem.n_measurements,
                {"cost": float(cost), "grid_point": (float(x), float(y))},
            ), True
        if singular_at(problem.bx, problem.by, np.ones(problem.size, dtype=np.bool_), x, y):
            return Estimate.failure(
                "the measured beacons do not determine the pose at the best grid point "
                "(e.g. all on one line through it)", problem.n_measurements,
            ), on_edge
        dx = problem.bx - x
        dy = problem.by - y
        dist = np.hypot(dx, dy)
        seen = dist > 0.0  # a grid point may coincide with a beacon, whose direction is unknown
        # φ' of eq. 29 at the winner: the circular mean of β_b − α_b.
        hx = np.sum((dx * problem.cos_az + dy * problem.sin_az)[seen] / dist[seen])
        hy = np.sum((dy * problem.cos_az - dx * problem.sin_az)[seen] / dist[seen])
        heading = math.atan2(hy, hx)
        return Estimate(
            x=float(x), y=float(y), heading=heading,
            inliers=problem.expand(np.ones(problem.size, dtype=bool)),
            diagnostics={"cost": float(cost), "grid_shape": (ny, nx)},
        ), on_edge

    def _coarse_to_fine(
        self, args: tuple[FloatArray, ...], coarse_step: float, x0: float, y0: float, nx: int,
        ny: int, no_store: FloatArray,
    ) -> tuple[int, int, float]:
        """Coarse grid (``coarse_step`` apart), then a descent on the fine grid from each seed.

        The seeds are the best coarse local minima and the beacons' positions. Around each seed
        the fine grid is searched in a window of ± one coarse step; while the window's best point
        lies on its edge (and not on the grid's), the window moves there and the search repeats.
        So each seed ends in a fine-grid local minimum, and the answer is the exhaustive argmin
        unless the coarse grid misses the global minimum's basin entirely.
        """
        ratio = int(round(coarse_step / self.step))
        cnx = (nx - 1) // ratio + 1
        cny = (ny - 1) // ratio + 1
        coarse = np.empty((cny, cnx))
        grid_search(*args, x0, y0, float(coarse_step), cnx, cny, coarse)
        # Seeds on the fine grid: the best coarse local minima, and every beacon inside the grid.
        # Near a beacon E_ref is singular (its direction turns arbitrarily fast), so a camera at
        # or next to a beacon has its minimum in a basin narrower than the coarse step.
        seeds = [(ci * ratio, cj * ratio, SEED_MOVES)
                 for cj, ci in _local_minima(coarse, self.n_candidates)]
        bx, by = args[0], args[1]
        step = float(self.step)
        for b in range(bx.size):
            bi, bj = round((bx[b] - x0) / step), round((by[b] - y0) / step)
            if 0 <= bi < nx and 0 <= bj < ny:
                seeds.append((int(bi), int(bj), BEACON_SEED_MOVES))
        best = (-1, -1, math.inf)
        for ci, cj, moves in seeds:
            for _ in range(moves):
                lo_i, hi_i = max(ci - ratio, 0), min(ci + ratio, nx - 1)
                lo_j, hi_j = max(cj - ratio, 0), min(cj + ratio, ny - 1)
                i, j, cost = grid_search(*args, x0 + lo_i * self.step, y0 + lo_j * self.step,
                                         float(self.step), hi_i - lo_i + 1, hi_j - lo_j + 1,
                                         no_store)
                if i < 0:
                    break
                ci, cj = lo_i + i, lo_j + j
                on_edge = (ci in (lo_i, hi_i) and ci not in (0, nx - 1)) or (
                    cj in (lo_j, hi_j) and cj not in (0, ny - 1))
                if not on_edge:
                    break
            if i >= 0 and cost < best[2]:
                best = (ci, cj, cost)
        return best
