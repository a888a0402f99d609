"""The geodesic shortest path: the least distance the forklift can drive from a start to a goal.

SPL (:mod:`azgym.bench.navigation.scoring`) divides the length l of the shortest path by the length
p of the path driven. l must be a true lower bound of every drive the forklift can make, or a driver
scores 1 by cutting corners the reference path went round. So l is not the planner's path
(:mod:`azgym.nav.planner` keeps 0.8 m from the racks and to the middle of the aisles, and a grid
path is up to 2.7 % longer than the straight line): it is the exact shortest path of the forklift's
reference point, the body's centre whose path ``travelled`` measures, through the free space, to the
goal region.

- **Free space.** Whatever its heading, the 1.2 m wide body holds a disc of radius 0.6 m round
  its centre, so the centre stays that far from every rack and wall, less what the physics lets
  two shapes overlap: pymunk's collision slop, 0.1 m. The centre's free space is the floor
  outside the racks and walls (walls as the world has them: segments of half their thickness)
  inflated by :data:`BODY_CLEARANCE` = 0.5 m. Inflating by more than the body always clears,
  say by the planner's 0.8 m, would over-estimate l; driven into racks at full throttle, the
  centre stays 0.58 m or more from them.
- **Inflated obstacles as polygons.** A rack inflated by a disc is a rectangle with rounded
  corners, a wall a capsule. Each is replaced by the convex polygon through points of its
  rounded outline at most :data:`ARC_STEP` apart on every arc: inscribed in the true inflated
  obstacle, so the free space only grows, and l stays a lower bound. The polygon holds the
  obstacle inflated by ``BODY_CLEARANCE · cos(ARC_STEP / 2)`` (0.49 m), so l lies between the
  exact shortest paths at that clearance and at 0.5 m.
- **Shortest paths among polygons** bend only at the obstacles' corners, along lines tangent
  to them there: Dijkstra's search (scipy.sparse.csgraph) over the visibility graph of the
  start, the corners outside every other obstacle and the goal points below, its edges the
  segments through no obstacle's interior that are tangent at their corners, is exact.
- **The goal region.** An episode succeeds once the centre is within ``goal_radius`` of the
  goal: the path ends where it first meets that disc, on its circle. From the last corner v of
  a shortest path it ends at the circle's point nearest to v when the straight line there is
  free, or where the circle crosses an obstacle's edge (those crossings are nodes of the
  graph). l is the least, over every node v, of its distance from the start plus that last leg.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import dijkstra

from azgym.core import BoolArray, FloatArray
from azgym.errors import InvalidInputError
from azgym.site import Scenario
from azgym.world.forklift import ForkliftSpec
from azgym.world.world import WALL_THICKNESS

__all__ = ["ARC_STEP", "BODY_CLEARANCE", "COLLISION_SLOP", "inflated", "obstacles_of",
           "shortest_lengths", "shortest_paths_for"]

COLLISION_SLOP = 0.1
"""pymunk's default ``Space.collision_slop``, which the world keeps: how far two shapes may
overlap before the solver pushes them apart [m]."""
BODY_CLEARANCE = 0.5 * ForkliftSpec().width - COLLISION_SLOP
"""Least distance of the body's centre from a rack or a wall, whatever its heading [m]."""
ARC_STEP = math.pi / 8
"""Largest angle between neighbouring corners of an inflated obstacle's rounded outline [rad]:
22.5°, 1 cm from the true arc at 0.5 m."""
_EPS = 1e-9
"""A segment must enter an obstacle this deep to be blocked by it, and a point lie this deep
to be inside [m]: touching the boundary is free."""
_CHUNK = 4096
"""Segments tested against the obstacles at a time (bounds the memory of the test)."""


def inflated(vertices: FloatArray, radius: float) -> FloatArray:
    """The convex polygon inscribed in ``vertices`` inflated by a disc of ``radius``.

    Args:
        vertices: A convex polygon, shape (k, 2) with k ≥ 2 (two points: a segment) [m].
        radius: The disc's radius [m], > 0.

    Returns:
        The polygon's corners, counter-clockwise, shape (m, 2): round every corner of
        ``vertices``, points of the arc at most :data:`ARC_STEP` apart.
    """
    points = np.asarray(vertices, dtype=np.float64)
    if len(points) > 2 and _area(points) < 0:
        points = points[::-1]
    outline = []
    for k, here in enumerate(points):
        before, after = points[k - 1], points[(k + 1) % len(points)]
        normal_in = math.atan2(here[1] - before[1], here[0] - before[0]) - 0.5 * math.pi
        turn = (math.atan2(after[1] - here[1], after[0] - here[0]) - 0.5 * math.pi
                - normal_in) % (2 * math.pi)
        steps = math.ceil(turn / ARC_STEP - 1e-12)
        for step in range(steps + 1):
            angle = normal_in + turn * step / max(steps, 1)
            outline.append(here + radius * np.array([math.cos(angle), math.sin(angle)]))
    return np.array(outline)


def _area(points: FloatArray) -> float:
    """Signed area of a polygon (positive counter-clockwise) [m²]."""
    x, y = points[:, 0], points[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def obstacles_of(scenario: Scenario, clearance: float = BODY_CLEARANCE) -> list[FloatArray]:
    """The racks and walls of the world inflated by ``clearance``: where the centre cannot be.

    The walls are the world's, segments of half :data:`~azgym.world.world.WALL_THICKNESS`.
    """
    return ([inflated(rack.corners(), clearance) for rack in scenario.racks]
            + [inflated(np.array([wall.start, wall.end]), clearance + 0.5 * WALL_THICKNESS)
               for wall in scenario.walls])


class _Obstacles:
    """Convex polygons as half-planes n · x ≤ c (outward unit normals), grouped by polygon."""

    def __init__(self, polygons: Sequence[FloatArray]) -> None:
        normals: list[FloatArray] = []
        offsets: list[FloatArray] = []
        starts: list[int] = []
        for polygon in polygons:
            edges = np.roll(polygon, -1, axis=0) - polygon
            lengths = np.hypot(edges[:, 0], edges[:, 1])
            keep = lengths > 1e-12
            normal = np.column_stack((edges[keep, 1], -edges[keep, 0])) / lengths[keep, None]
            starts.append(sum(len(n) for n in normals))
            normals.append(normal)
            offsets.append(np.einsum("ij,ij->i", normal, polygon[keep]))
        self.normals = np.concatenate(normals) if normals else np.zeros((0, 2))
        self.offsets = np.concatenate(offsets) if offsets else np.zeros(0)
        self.starts = np.array(starts, dtype=np.int64)

    def inside(self, points: FloatArray) -> BoolArray:
        """Which points lie in some polygon's interior, deeper than the tolerance; (P,) bool."""
        if not len(self.starts) or not len(points):
            return np.zeros(len(points), dtype=bool)
        depth = points @ self.normals.T - self.offsets
        return np.any(np.maximum.reduceat(depth, self.starts, axis=1) < -_EPS, axis=1)

    def blocks(self, ends: FloatArray, others: FloatArray) -> np.ndarray:
        """Which segments ends[i]-others[i] pass through some polygon's interior; (M,) bool.

        Cyrus-Beck: the segment's parameters t in [0, 1] where it is inside every half-plane
        of a polygon, by more than the tolerance, form an interval; it is blocked when one
        polygon's interval is not empty.
        """
        blocked = np.zeros(len(ends), dtype=bool)
        if not len(self.starts):
            return blocked
        for first in range(0, len(ends), _CHUNK):
            a_end, b_end = ends[first:first + _CHUNK], others[first:first + _CHUNK]
            a = a_end @ self.normals.T - self.offsets + _EPS
            b = (b_end - a_end) @ self.normals.T
            with np.errstate(divide="ignore", invalid="ignore"):
                limit = -a / b
            flat = np.abs(b) <= 1e-15
            low = np.where(b < -1e-15, limit, 0.0)
            high = np.where(b > 1e-15, limit, 1.0)
            high = np.where(flat & (a >= 0.0), -1.0, high)  # parallel and outside: never in
            low = np.maximum(np.maximum.reduceat(low, self.starts, axis=1), 0.0)
            high = np.minimum(np.minimum.reduceat(high, self.starts, axis=1), 1.0)
            blocked[first:first + _CHUNK] = (low < high).any(axis=1)
        return blocked


def shortest_lengths(obstacles: Sequence[FloatArray], starts: FloatArray, goals: FloatArray,
                     radius: float) -> FloatArray:
    """The length of the shortest path from each start to within ``radius`` of each goal.

    Args:
        obstacles: Convex polygons, counter-clockwise, each shape (k, 2) [m]: the paths keep
            out of their interiors (their boundaries may be touched).
        starts: Shape (S, 2) [m].
        goals: Shape (G, 2) [m].
        radius: The goal region's radius [m], ≥ 0.

    Returns:
        Shape (S, G) [m]: 0 where a start lies within a goal's region, inf where no path
        reaches it.

    Raises:
        InvalidInputError: A start inside an obstacle.
    """
    starts = np.asarray(starts, dtype=np.float64).reshape(-1, 2)
    goals = np.asarray(goals, dtype=np.float64).reshape(-1, 2)
    polygons = [np.asarray(polygon, dtype=np.float64) for polygon in obstacles]
    blockers = _Obstacles(polygons)
    trapped = blockers.inside(starts)
    if trapped.any():
        x, y = starts[int(np.argmax(trapped))]
        raise InvalidInputError(f"start ({x:g}, {y:g}) lies inside an obstacle")
    corners, before, after = _corners(polygons)
    outside = ~blockers.inside(corners)
    crossings = _crossings(polygons, goals, radius)
    crossings = crossings[~blockers.inside(crossings)]
    nodes = np.concatenate((starts, corners[outside], crossings))
    # A start or a crossing is no polygon's corner: every line through it is "tangent".
    before = np.concatenate((starts, before[outside], crossings))
    after = np.concatenate((starts, after[outside], crossings))
    first, second = np.triu_indices(len(nodes), k=1)
    useful = _tangent(nodes, before, after, first, second) & _tangent(
        nodes, before, after, second, first)
    first, second = first[useful], second[useful]
    free = ~blockers.blocks(nodes[first], nodes[second])
    first, second = first[free], second[free]
    length = np.hypot(*(nodes[second] - nodes[first]).T)
    graph = coo_matrix((length, (first, second)), shape=(len(nodes), len(nodes))).tocsr()
    distance = dijkstra(graph, directed=False, indices=np.arange(len(starts)))
    distance = distance.reshape(len(starts), len(nodes))
    return (distance[:, :, None] + _last_leg(blockers, nodes, goals, radius)[None]).min(axis=1)


def _corners(polygons: Sequence[FloatArray]) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Every polygon's corners, and each one's neighbours before and after it on its polygon."""
    if not polygons:
        empty = np.zeros((0, 2))
        return empty, empty, empty
    return (np.concatenate(polygons), np.concatenate([np.roll(p, 1, axis=0) for p in polygons]),
            np.concatenate([np.roll(p, -1, axis=0) for p in polygons]))


def _tangent(nodes: FloatArray, before: FloatArray, after: FloatArray, at: np.ndarray,
             to: np.ndarray) -> np.ndarray:
    """Whether the line from node ``at`` to node ``to`` has ``at``'s polygon on one side of it.

    A shortest path bends round a corner, so each of its segments is tangent to the polygon
    at its corners: the corner's two neighbours lie on one side of it (or on it).
    """
    direction = nodes[to] - nodes[at]
    one = _cross(direction, before[at] - nodes[at])
    other = _cross(direction, after[at] - nodes[at])
    return ~(((one > 1e-12) & (other < -1e-12)) | ((one < -1e-12) & (other > 1e-12)))


def _cross(u: FloatArray, v: FloatArray) -> FloatArray:
    return u[:, 0] * v[:, 1] - u[:, 1] * v[:, 0]


def _crossings(polygons: Sequence[FloatArray], goals: FloatArray, radius: float) -> FloatArray:
    """Where each goal's circle crosses the polygons' edges, shape (C, 2) [m]."""
    if not polygons or radius <= 0.0:
        return np.zeros((0, 2))
    starts, ends = np.concatenate(polygons), np.concatenate(
        [np.roll(p, -1, axis=0) for p in polygons])
    edge = ends - starts
    points = []
    for goal in goals:
        offset = starts - goal
        # |offset + t · edge|² = radius²: a t² + 2 b t + c = 0
        a = np.einsum("ij,ij->i", edge, edge)
        b = np.einsum("ij,ij->i", offset, edge)
        c = np.einsum("ij,ij->i", offset, offset) - radius * radius
        root = np.sqrt(np.maximum(b * b - a * c, 0.0))
        real = (b * b - a * c >= 0.0) & (a > 1e-24)
        for sign in (-1.0, 1.0):
            t = np.where(real, (-b + sign * root) / np.where(real, a, 1.0), -1.0)
            on = (t >= 0.0) & (t <= 1.0)
            points.append(starts[on] + t[on, None] * edge[on])
    return np.concatenate(points)


def _last_leg(blockers: _Obstacles, nodes: FloatArray, goals: FloatArray,
              radius: float) -> FloatArray:
    """From each node, the straight way into each goal's region (module docstring), (N, G) [m].

    0 from a node within the region; the distance to the circle's nearest point when the
    segment there is free; inf otherwise.
    """
    offset = nodes[:, None, :] - goals[None, :, :]
    far = np.hypot(offset[..., 0], offset[..., 1])
    within = far <= radius + _EPS
    share = np.where(within, 0.0, radius / np.where(within, 1.0, far))
    nearest = goals[None, :, :] + share[..., None] * offset
    ends = np.broadcast_to(nodes[:, None, :], offset.shape).reshape(-1, 2)
    free = ~blockers.blocks(ends, nearest.reshape(-1, 2)).reshape(far.shape)
    return np.where(within, 0.0, np.where(free, far - radius, np.inf))


_TABLES: dict[tuple, FloatArray] = {}
_MAX_CACHED = 16


def shortest_paths_for(scenario: Scenario, spots: FloatArray, goal_radius: float) -> FloatArray:
    """The shortest path from each spot to within ``goal_radius`` of each other one, (S, S) [m].

    Built once per floor, spots and radius in a process (16 kept).

    Raises:
        InvalidInputError: A spot closer than :data:`BODY_CLEARANCE` to a rack or a wall
            (the forklift cannot stand there), or a spot no path reaches from another.
    """
    spots = np.asarray(spots, dtype=np.float64)
    key = (scenario.racks, scenario.walls, spots.tobytes(), float(goal_radius))
    if key not in _TABLES:
        obstacles = obstacles_of(scenario)
        trapped = _Obstacles(obstacles).inside(spots)
        if trapped.any():
            x, y = spots[int(np.argmax(trapped))]
            raise InvalidInputError(
                f"scenario {scenario.name!r}: spot ({x:g}, {y:g}) is closer than "
                f"{BODY_CLEARANCE:.2f} m to a rack or a wall: the forklift cannot stand there")
        table = shortest_lengths(obstacles, spots, spots, goal_radius)
        if not np.isfinite(table).all():
            start, goal = np.argwhere(~np.isfinite(table))[0]
            raise InvalidInputError(
                f"scenario {scenario.name!r}: no path leads from spot "
                f"({spots[start][0]:g}, {spots[start][1]:g}) to spot "
                f"({spots[goal][0]:g}, {spots[goal][1]:g})")
        if len(_TABLES) >= _MAX_CACHED:
            _TABLES.pop(next(iter(_TABLES)))
        _TABLES[key] = table
    return _TABLES[key]
