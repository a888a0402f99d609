"""Changes made to a site's world after its map was made: beacons moved, a rack moved.

The map a mapper is given stays as it was; the world (where the simulator puts each beacon and
rack) changes. One rule places what moves:

* a **moved beacon** goes :data:`BEACON_MOVE` metres (drawn uniformly) in a direction drawn
  uniformly, to a place inside the site (:data:`SITE_MARGIN` from its bounds), outside every
  rack (:data:`RACK_MARGIN` from its faces), without crossing a wall (it stays on its side of
  each), at its own height;
* a **moved rack** slides :data:`RACK_MOVE` metres along its own axis (a rack row stays in its
  row, its aisles keep their direction), carrying the beacons mounted on it (within
  :data:`MOUNTED` of its footprint). Its new footprint stays inside the site, covers no other
  beacon, and keeps from every other rack, wall and the route driven at least the clearance it
  had, up to :data:`CLEARANCE` (so the forklift still passes where it passed).

A site may ship with beacons moved already (its ``moved_to``): the world starts from where they
are (:attr:`~azgym.site.scenario.Scenario.beacon_positions`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from azgym.core import BeaconMap, FloatArray
from azgym.errors import InvalidInputError
from azgym.site import Scenario
from azgym.site.elements import Rack, Route

__all__ = ["BEACON_MOVE", "CLEARANCE", "MAX_DRAWS", "MOUNTED", "RACK_MARGIN", "RACK_MOVE",
           "SITE_MARGIN", "Perturbed", "move_beacons", "move_rack", "true_map"]

BEACON_MOVE = (0.3, 3.0)
"""How far a moved beacon goes [m] (drawn uniformly)."""
RACK_MOVE = (0.5, 2.0)
"""How far a moved rack slides along its axis [m] (drawn uniformly, either way)."""
SITE_MARGIN = 0.2
"""Least distance of a moved beacon from the site's bounds [m]."""
RACK_MARGIN = 0.1
"""Least distance of a moved beacon from a rack's faces [m]."""
MOUNTED = 0.05
"""A beacon within this distance of a rack's footprint is mounted on it [m]."""
CLEARANCE = 1.5
"""A moved rack keeps from the other racks, the walls and the route at least the clearance it
had, up to this [m]."""
MAX_DRAWS = 1000
"""Draws tried for one move before the site is said to leave no room for it."""


@dataclass(frozen=True, eq=False)
class Perturbed:
    """A site whose world changed after its map was made.

    Attributes:
        world: The scenario as the world has it (its racks, and ``physical_xyz``: where each
            beacon is); its ``beacons`` are still the map as it was.
        moved: Ids of the beacons the change moved, sorted.
    """

    world: Scenario
    moved: tuple[int, ...]


def true_map(scenario: Scenario) -> BeaconMap:
    """The map of where the world has each beacon (``moved_to`` and any perturbation applied)."""
    return BeaconMap(scenario.beacons.ids, scenario.beacon_positions, scenario.beacons.width)


def move_beacons(scenario: Scenario, rng: np.random.Generator, count: int,
                 among: Sequence[int], distance: tuple[float, float] = BEACON_MOVE
                 ) -> Perturbed:
    """``count`` beacons drawn from ``among`` (ids), each moved by the module's rule.

    Raises:
        InvalidInputError: ``among`` has fewer than ``count`` beacons of the site, or a beacon
            has no room to go (no valid place in :data:`MAX_DRAWS` draws).
    """
    ids = scenario.beacons.ids.tolist()
    candidates = sorted(set(among) & set(ids))
    if len(candidates) < count:
        raise InvalidInputError(f"{scenario.name}: {count} beacons to move, but only "
                                f"{len(candidates)} to draw from")
    xyz = scenario.beacon_positions.copy()
    chosen = sorted(int(b) for b in rng.choice(candidates, count, replace=False))
    for beacon in chosen:
        row = ids.index(beacon)
        xyz[row, :2] = _new_place(scenario, rng, xyz[row, :2], distance, beacon)
    return Perturbed(dataclasses.replace(scenario, physical_xyz=xyz), tuple(chosen))


def move_rack(scenario: Scenario, rng: np.random.Generator, route: Route) -> Perturbed:
    """One rack slid along its axis by the module's rule, its beacons with it.

    The rack is drawn among those carrying beacons (among all, when none does).

    Raises:
        InvalidInputError: The site has no rack, or no draw within :data:`MAX_DRAWS` finds room.
    """
    if not scenario.racks:
        raise InvalidInputError(f"{scenario.name} has no rack to move")
    xyz = scenario.beacon_positions
    mounted = [np.flatnonzero([_point_distance(rack, p) <= MOUNTED for p in xyz[:, :2]])
               for rack in scenario.racks]
    carrying = [k for k, rows in enumerate(mounted) if rows.size] or list(range(len(
        scenario.racks)))
    path = [(route.waypoints[k], route.waypoints[k + 1]) for k in range(len(route.waypoints) - 1)]
    for _ in range(MAX_DRAWS):
        k = int(rng.choice(carrying))
        rack = scenario.racks[k]
        step = rng.uniform(*RACK_MOVE) * rng.choice((-1.0, 1.0)) * np.array(
            [math.cos(rack.angle), math.sin(rack.angle)])
        moved = dataclasses.replace(rack, center=(float(rack.center[0] + step[0]),
                                                  float(rack.center[1] + step[1])))
        others = [r for j, r in enumerate(scenario.racks) if j != k]
        if _fits(scenario, rack, moved, others, path, xyz, mounted[k]):
            new = xyz.copy()
            new[mounted[k], :2] += step
            racks = tuple(moved if j == k else r for j, r in enumerate(scenario.racks))
            world = dataclasses.replace(scenario, racks=racks, physical_xyz=new)
            return Perturbed(world, tuple(sorted(
                int(b) for b in scenario.beacons.ids[mounted[k]].tolist())))
    raise InvalidInputError(f"{scenario.name}: no rack can be moved {RACK_MOVE[0]:g}-"
                            f"{RACK_MOVE[1]:g} m without blocking the route {route.name!r}")


def _new_place(scenario: Scenario, rng: np.random.Generator, start: FloatArray,
               distance: tuple[float, float], beacon: int) -> FloatArray:
    """Where a moved beacon goes (the module's rule)."""
    x0, y0, x1, y1 = scenario.bounds
    for _ in range(MAX_DRAWS):
        angle = rng.uniform(0.0, 2.0 * math.pi)
        place = start + rng.uniform(*distance) * np.array([math.cos(angle), math.sin(angle)])
        if not (x0 + SITE_MARGIN < place[0] < x1 - SITE_MARGIN
                and y0 + SITE_MARGIN < place[1] < y1 - SITE_MARGIN):
            continue
        if any(rack.contains(place[0], place[1], margin=-RACK_MARGIN) for rack in scenario.racks):
            continue
        if any(_crosses(start, place, np.array(w.start), np.array(w.end))
               for w in scenario.walls):
            continue
        return place
    raise InvalidInputError(f"{scenario.name}: beacon {beacon} has no room to move "
                            f"{distance[0]:g}-{distance[1]:g} m")


def _fits(scenario: Scenario, rack: Rack, moved: Rack, others: list[Rack],
          path: list[tuple[FloatArray, FloatArray]], xyz: FloatArray,
          carried: np.ndarray) -> bool:
    """Whether a rack's new footprint keeps the module's rule."""
    x0, y0, x1, y1 = scenario.bounds
    corners = moved.corners()
    if not ((corners[:, 0] > x0).all() and (corners[:, 0] < x1).all()
            and (corners[:, 1] > y0).all() and (corners[:, 1] < y1).all()):
        return False
    rest = np.setdiff1d(np.arange(len(xyz)), carried)
    if rest.size and np.any(moved.contains(xyz[rest, 0], xyz[rest, 1], margin=-RACK_MARGIN)):
        return False
    obstacles = [_edges(other) for other in others] + [
        [(np.array(w.start, dtype=float), np.array(w.end, dtype=float))] for w in scenario.walls]
    obstacles.append(path)
    return all(_rack_distance(moved, segments) >= min(_rack_distance(rack, segments), CLEARANCE)
               for segments in obstacles)


def _edges(rack: Rack) -> list[tuple[FloatArray, FloatArray]]:
    """A rack footprint's four sides."""
    corners = rack.corners()
    return [(corners[k], corners[(k + 1) % 4]) for k in range(4)]


def _rack_distance(rack: Rack, segments: list[tuple[FloatArray, FloatArray]]) -> float:
    """Least distance from a rack's footprint to segments (0 when one touches or enters it)."""
    edges = _edges(rack)
    best = math.inf
    for a, b in segments:
        if rack.contains(a[0], a[1], margin=0.0) or rack.contains(b[0], b[1], margin=0.0):
            return 0.0
        for c, d in edges:
            if _crosses(a, b, c, d):
                return 0.0
            best = min(best, _segment_point(a, b, c), _segment_point(a, b, d),
                       _segment_point(c, d, a), _segment_point(c, d, b))
    return best


def _point_distance(rack: Rack, point: FloatArray) -> float:
    """Distance from a point to a rack's footprint (0 inside it)."""
    if rack.contains(point[0], point[1], margin=0.0):
        return 0.0
    return min(_segment_point(c, d, point) for c, d in _edges(rack))


def _segment_point(a: FloatArray, b: FloatArray, p: FloatArray) -> float:
    """Distance from point ``p`` to the segment ``a``-``b``."""
    ab = b - a
    length2 = float(ab @ ab)
    t = 0.0 if length2 == 0.0 else min(1.0, max(0.0, float((p - a) @ ab) / length2))
    return math.dist(p, a + t * ab)


def _crosses(a: FloatArray, b: FloatArray, c: FloatArray, d: FloatArray) -> bool:
    """Whether segments ``a``-``b`` and ``c``-``d`` cross (an end on the other one does not)."""
    def side(p: FloatArray, q: FloatArray, r: FloatArray) -> float:
        return float((q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0]))

    return side(a, b, c) * side(a, b, d) < 0.0 and side(c, d, a) * side(c, d, b) < 0.0
