"""A generated warehouse's floor: rack rows, aisles, walls and the routes through the aisles.

The floor is drawn in a *local* frame where the racks run along x: rows of racks across y, each
row cut into equal racks by cross aisles, with an end aisle between each end wall and the rows
and a wall aisle between each side wall and the outer rows. Every aisle's centre line is a lane
the forklift can drive; the lanes along the rows (``lanes``) and across them (``crossings``) meet
at right angles, and every route is a polyline on them, so every leg is clear of the racks by
half an aisle (at least ``MIN_AISLE`` / 2, above ``ROUTE_CLEARANCE``). Half the layouts are
turned a quarter turn (the racks along y) when written out (:meth:`Plan.world`).

The ranges drawn from, and why, are in :mod:`azgym.site.generator`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = ["AISLE", "Plan", "draw", "draw_plan", "racks_data", "routes_data", "walls_data"]

AISLE = (2.8, 4.0)
"""Width of an aisle between two rack rows [m]."""
END_AISLE = (3.6, 5.0)
"""Width of the aisle between an end wall and the rows' ends [m]."""
WALL_AISLE = (3.0, 4.5)
"""Width of the aisle between a side wall and the outer row [m]."""
CROSS_AISLE = (3.2, 4.5)
"""Width of an aisle that cuts the rows [m]."""
SINGLE_DEPTH, DOUBLE_DEPTH = (0.9, 1.3), (2.0, 2.6)
"""Depth of a single rack, and of two racks back to back [m]."""
DOUBLE_SHARE = 0.4
"""Share of layouts whose rows are back-to-back double racks."""
RACK_LENGTH = (8.0, 25.0)
"""Length of one rack between cross aisles, as drawn; cross aisles then split the rows evenly."""
RACK_HEIGHT = (2.0, 8.0)
"""Height of a row of racks [m], at most ``WALL_HEADROOM`` under the walls' top."""
WALL_HEIGHT = (6.0, 12.0)
"""Height of the walls (the building's clear height) [m]."""
WALL_HEADROOM = 1.0
"""A rack's top stays this far under the walls' top [m]."""
METAL_SHARE, METAL_REFLECTIVITY = 0.3, (0.05, 0.15)
"""Share of rows with metal faces, and the share of light such a face mirrors."""
GLASS_SHARE, GLASS_REFLECTIVITY = 0.25, (0.05, 0.12)
"""Share of walls that are glass, and the share of light a pane mirrors."""
OPEN_SHARE = 0.08
"""Share of rack places left empty (a staging area, a gap in the row)."""
SPEED = (1.0, 2.5)
"""Cruise speed of a route [m/s]: a loaded forklift's 1 m/s to an empty one's 2.5 m/s."""
PICK_DEPTH = (3.0, 12.0)
"""How far a picking trip drives into an aisle before backing out [m]."""
BACKING_ROOM = 2.5
"""A forklift backing to a stop keeps its steering reference this far from the wall behind [m]:
the default forklift's tail is 2 m behind it (0.8 m to the body's centre, 1.2 m to the tail)."""


@dataclass(frozen=True)
class Plan:
    """The floor in the local frame (racks along x) and how it turns into the room.

    Attributes:
        length: The room's extent along the racks [m].
        width: Its extent across them [m].
        turned: Whether the room is written with local x as north (the racks along y).
        wall_height: Height of the walls [m].
        depth: Depth of every rack [m].
        rows: Each row's centre, its height and its faces' reflectivity: (y, height, mirror).
        spans: Each rack's extent along x in a row: (x0, x1) [m].
        racks: The (row, span) places that hold a rack.
        lanes: Centre lines along the rows (y) [m], the wall aisles' first and last.
        crossings: Centre lines across the rows (x) [m], the end aisles' first and last.
    """

    length: float
    width: float
    turned: bool
    wall_height: float
    depth: float
    rows: tuple[tuple[float, float, float], ...]
    spans: tuple[tuple[float, float], ...]
    racks: tuple[tuple[int, int], ...]
    lanes: tuple[float, ...]
    crossings: tuple[float, ...]

    def world(self, x: float, y: float) -> list[float]:
        """A local point in room coordinates, rounded to the millimetre."""
        return [_mm(y), _mm(x)] if self.turned else [_mm(x), _mm(y)]

    @property
    def bounds(self) -> list[float]:
        """The room's [x_min, y_min, x_max, y_max] [m]."""
        return [0.0, 0.0, *self.world(self.length, self.width)]


def _mm(value: float) -> float:
    """``value`` rounded to the millimetre (and -0.0 made 0.0), as written to the file."""
    return round(float(value), 3) + 0.0


def draw(rng: np.random.Generator, low_high: tuple[float, float], step: float = 0.1) -> float:
    """A uniform draw from [low, high], rounded to ``step``."""
    return round(round(float(rng.uniform(*low_high)) / step) * step, 3)


def draw_plan(rng: np.random.Generator, sides: tuple[float, float]) -> Plan:
    """A random floor for a room of ``sides`` = (east-west, north-south) extent [m]."""
    turned = bool(rng.random() < 0.5)
    length, width = (sides[1], sides[0]) if turned else sides
    aisle = draw(rng, AISLE)
    depth = draw(rng, DOUBLE_DEPTH if rng.random() < DOUBLE_SHARE else SINGLE_DEPTH)
    wall_aisles = [draw(rng, WALL_AISLE), draw(rng, WALL_AISLE)]
    count = max(1, int((width - sum(wall_aisles) - depth) // (depth + aisle)) + 1)
    spare = width - sum(wall_aisles) - count * depth - (count - 1) * aisle
    wall_aisles = [w + spare / 2 for w in wall_aisles]  # what is left widens them (loading)
    first = wall_aisles[0] + depth / 2
    wall_height = draw(rng, WALL_HEIGHT, 0.5)
    top = min(RACK_HEIGHT[1], wall_height - WALL_HEADROOM)
    rows = tuple((first + k * (depth + aisle), draw(rng, (RACK_HEIGHT[0], top), 0.5),
                  draw(rng, METAL_REFLECTIVITY, 0.01) if rng.random() < METAL_SHARE else 0.0)
                 for k in range(count))
    spans, crossings = _spans(rng, length)
    places = [(r, s) for r in range(count) for s in range(len(spans))]
    kept = tuple(p for p in places if rng.random() >= OPEN_SHARE) or (places[0],)
    lanes = (wall_aisles[0] / 2, *(y + (depth + aisle) / 2 for y, _, _ in rows[:-1]),
             width - wall_aisles[1] / 2)
    return Plan(length=length, width=width, turned=turned, wall_height=wall_height, depth=depth,
                rows=rows, spans=spans, racks=kept, lanes=lanes, crossings=crossings)


def _spans(rng: np.random.Generator,
           length: float) -> tuple[tuple[tuple[float, float], ...], tuple[float, ...]]:
    """The racks' extents along a row, and the centre lines of the aisles across the rows."""
    ends = [draw(rng, END_AISLE), draw(rng, END_AISLE)]
    cross = draw(rng, CROSS_AISLE)
    usable = length - sum(ends)
    count = max(1, round((usable + cross) / (draw(rng, RACK_LENGTH) + cross)))
    rack = (usable - (count - 1) * cross) / count
    starts = [ends[0] + k * (rack + cross) for k in range(count)]
    spans = tuple((_mm(x0), _mm(x0 + rack)) for x0 in starts)  # a beacon on an end is on it
    crossings = (ends[0] / 2, *(x1 + cross / 2 for _, x1 in spans[:-1]), length - ends[1] / 2)
    return spans, crossings


def racks_data(plan: Plan) -> list[dict[str, Any]]:
    """The ``[[racks]]`` tables of the plan's racks."""
    tables = []
    for row, span in plan.racks:
        y, height, mirror = plan.rows[row]
        x0, x1 = plan.spans[span]
        size = [round(x1 - x0, 4), plan.depth]  # exact: the ends are whole millimetres
        center = [round((x0 + x1) / 2, 4), _mm(y)]
        tables.append({"center": center[::-1] if plan.turned else center,
                       "size": size[::-1] if plan.turned else size,
                       "height": height, "reflectivity": mirror})
    return tables


def walls_data(plan: Plan, rng: np.random.Generator) -> list[dict[str, Any]]:
    """The four ``[[walls]]`` tables, counter-clockwise from the south-west corner."""
    x_max, y_max = plan.bounds[2:]
    corners = [[0.0, 0.0], [x_max, 0.0], [x_max, y_max], [0.0, y_max]]
    return [{"start": corners[k], "end": corners[(k + 1) % 4], "height": plan.wall_height,
             "reflectivity": draw(rng, GLASS_REFLECTIVITY, 0.01)
             if rng.random() < GLASS_SHARE else 0.0} for k in range(4)]


def routes_data(plan: Plan, rng: np.random.Generator) -> list[dict[str, Any]]:
    """The ``[[routes]]``: a loop around the walls, a serpentine, a crossing and a picking trip.

    Every leg runs along a lane or a crossing, so it keeps half an aisle off the racks.
    """
    lanes, crossings = plan.lanes, plan.crossings
    west, east, south, north = crossings[0], crossings[-1], lanes[0], lanes[-1]
    corners = [(west, south), (east, south), (east, north), (west, north)]
    turn = int(rng.integers(4))
    loop = corners[turn:] + corners[:turn]
    loop = loop[::-1] if rng.random() < 0.5 else loop
    routes = [("perimeter", [*loop, loop[0]], None), ("serpentine", _serpentine(plan, rng), None),
              ("cross-aisle", _crossing(plan, rng), None), _picking(plan, rng)]
    tables = []
    for name, points, reverse in routes:
        table: dict[str, Any] = {"name": name,
                                 "waypoints": [plan.world(x, y) for x, y in points]}
        if reverse is not None:
            table["reverse"] = reverse
        tables.append({**table, "speed": draw(rng, SPEED)})
    return tables


def _serpentine(plan: Plan, rng: np.random.Generator) -> list[tuple[float, float]]:
    """Up and down two to four neighbouring lanes, through the end aisles."""
    count = int(rng.integers(2, min(4, len(plan.lanes)) + 1))
    first = int(rng.integers(len(plan.lanes) - count + 1))
    ends = [plan.crossings[0], plan.crossings[-1]][::int(rng.choice([-1, 1]))]
    points = []
    for k, y in enumerate(plan.lanes[first:first + count]):
        points += [(ends[k % 2], y), (ends[(k + 1) % 2], y)]
    return points


def _crossing(plan: Plan, rng: np.random.Generator) -> list[tuple[float, float]]:
    """Along a cross aisle (an end aisle if there is none) from one wall aisle to the other."""
    inner = plan.crossings[1:-1] or plan.crossings
    x = float(rng.choice(inner))
    others = [c for c in plan.crossings if c != x]
    south, north = (plan.lanes[0], plan.lanes[-1])[::int(rng.choice([-1, 1]))]
    return [(x, south), (x, north), (float(rng.choice(others)), north)]


def _picking(plan: Plan, rng: np.random.Generator) -> tuple[str, list, list[bool]]:
    """Into an aisle from a crossing, some metres in, and backing out to the crossing."""
    lanes, crossings = plan.lanes, plan.crossings
    start_lane, pick_lane = (float(y) for y in rng.choice(lanes, size=2, replace=False))
    entry = int(rng.integers(len(crossings)))
    x = crossings[entry]
    start = crossings[-1] if entry == 0 else crossings[0]
    inward = 1.0 if entry < len(crossings) - 1 else -1.0
    if 0 < entry < len(crossings) - 1 and rng.random() < 0.5:
        inward = -1.0
    room = abs(crossings[entry + int(inward)] - x)
    depth = min(draw(rng, PICK_DEPTH), room - 1.0)
    stop = min(max(x, BACKING_ROOM), plan.length - BACKING_ROOM)  # off the end wall behind
    points = [(start, start_lane), (x, start_lane), (x, pick_lane),
              (x + inward * depth, pick_lane), (stop, pick_lane)]
    return "pick-and-back", points, [False, False, False, True]
