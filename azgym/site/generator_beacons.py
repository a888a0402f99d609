"""A generated warehouse's lights: its beacons (one maybe moved), lamps, windows, and its bumps.

Beacons hang where a surveyor would put them so that the aisles see them: on the end walls at
the end of an aisle (in a long aisle between tall racks, the walls straight ahead are all a
camera sees), along the side walls at a regular spacing, and on some rack ends, which the cross
aisles see. Everything is placed in the plan's local frame (:class:`~azgym.site.
generator_layout.Plan`) and turned into room coordinates on the way out.

The ranges drawn from, and why, are in :mod:`azgym.site.generator`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from azgym.site.generator_layout import Plan, draw

__all__ = ["CEILING_GAP", "RACK_END_Z", "beacons_data", "bumps_data", "lights_data"]

AISLE_END_SHARE = 0.8
"""Share of aisle ends (on the end walls) that carry a beacon."""
WALL_SPACING = (6.0, 10.0)
"""Spacing of the beacons along a side wall [m]."""
WALL_Z = (3.0, 9.0)
"""Height of a wall beacon [m], at most ``CEILING_GAP`` under the walls' top."""
CEILING_GAP = 0.5
"""A wall beacon or a lamp hangs at least this far under the walls' top [m]."""
RACK_END_SHARE = 0.5
"""Share of rack ends that carry a beacon."""
RACK_END_Z = (0.2, 1.0)
"""How far a rack-end beacon stands above its rack's top [m], on the end frame: the aisles on
both sides of the row see it over the rack (one below the top would be hidden from them)."""
BEACON_WIDTH = (0.02, 0.05)
"""Width of a beacon's light [m]."""
MOVED_SHARE, MOVED_BY = 0.5, (1.0, 2.5)
"""Share of sites where one wall beacon was moved after mapping, and how far along its wall."""
LAMP_SPACING, LAMP_POWER = (8.0, 14.0), (10.0, 30.0)
"""Spacing of the ceiling lamps over an aisle [m]; a lamp's flux in beacons' fluxes."""
MOST_LAMP_LINES = 4
"""Lamps hang over at most this many aisles (evenly spread): enough distractors for the image
path without making its frames slow."""
WINDOW_SHARE = 0.3
"""Share of walls with a sunny window."""
WINDOW_WIDTH, WINDOW_TALL, WINDOW_Z, WINDOW_POWER = (1.5, 3.0), (1.0, 1.5), (2.5, 4.0), (50, 150)
"""A window's width and height [m], its centre's height [m] and its flux in beacons' fluxes."""
BUMP_SHARE, BUMP_LENGTH, BUMP_TILT = 0.4, (2.0, 5.0), (1.0, 3.0)
"""Share of sites with a bumpy stretch in a cross aisle, its length [m] and tilt [degrees]."""


def beacons_data(plan: Plan, rng: np.random.Generator) -> list[dict[str, Any]]:
    """The ``[[beacons]]``: on the end walls, the side walls and the rack ends; ids from 1."""
    top = min(WALL_Z[1], plan.wall_height - CEILING_GAP)
    low = max(WALL_Z[0], max(height for _, height, _ in plan.rows))  # above the racks
    places: list[tuple[float, float, float]] = []  # (x, y, z), local
    for x in (0.0, plan.length):
        places += [(x, y, draw(rng, (low, top))) for y in plan.lanes
                   if rng.random() < AISLE_END_SHARE]
    for y in (0.0, plan.width):
        spacing = draw(rng, WALL_SPACING)
        count = max(1, round(plan.length / spacing))
        step = plan.length / count
        places += [(step * (k + 0.5 + rng.uniform(-0.2, 0.2)), y, draw(rng, (low, top)))
                   for k in range(count)]
    walls = len(places)
    for row, span in plan.racks:
        y, height, _ = plan.rows[row]
        places += [(x, y, min(top, height + draw(rng, RACK_END_Z)))
                   for x in plan.spans[span] if rng.random() < RACK_END_SHARE]
    tables = [{"id": k + 1, "xyz": [*plan.world(x, y), z],
               "width": draw(rng, BEACON_WIDTH, 0.005)} for k, (x, y, z) in enumerate(places)]
    if rng.random() < MOVED_SHARE:
        k = int(rng.integers(walls))
        tables[k]["moved_to"] = _moved(plan, places[k], rng)
    return tables


def _moved(plan: Plan, place: tuple[float, float, float],
           rng: np.random.Generator) -> list[float]:
    """Where a wall beacon at ``place`` was moved to: along its wall, staying on it."""
    x, y, _ = place
    shift = draw(rng, MOVED_BY) * float(rng.choice([-1.0, 1.0]))
    if x in (0.0, plan.length):  # an end wall: moved along y
        moved = (x, y + shift if 0.0 <= y + shift <= plan.width else y - shift)
    else:
        moved = (x + shift if 0.0 <= x + shift <= plan.length else x - shift, y)
    return plan.world(*moved)


def lights_data(plan: Plan, rng: np.random.Generator) -> list[dict[str, Any]]:
    """The ``[[lights]]``: ceiling lamps over some aisles, and sunny windows on some walls."""
    z = plan.wall_height - CEILING_GAP
    stride = -(-len(plan.lanes) // MOST_LAMP_LINES)
    spacing = draw(rng, LAMP_SPACING)
    count = max(1, round(plan.length / spacing))
    power = draw(rng, LAMP_POWER, 1.0)
    tables = [{"name": "ceiling lamp", "xyz": [*plan.world((k + 0.5) * plan.length / count, y), z],
               "width": 0.6, "tall": 0.1, "power": power}
              for y in plan.lanes[::stride] for k in range(count)]
    for wall in range(4):
        if rng.random() >= WINDOW_SHARE:
            continue
        extent = plan.length if wall < 2 else plan.width
        along = draw(rng, (2.0, extent - 2.0))
        x, y = ((along, (0.0, plan.width)[wall]) if wall < 2
                else ((0.0, plan.length)[wall - 2], along))
        tables.append({"name": "sunny window", "xyz": [*plan.world(x, y), draw(rng, WINDOW_Z)],
                       "width": draw(rng, WINDOW_WIDTH), "tall": draw(rng, WINDOW_TALL),
                       "power": draw(rng, WINDOW_POWER, 1.0)})
    return tables


def bumps_data(plan: Plan, rng: np.random.Generator) -> list[dict[str, Any]]:
    """The ``[[bumps]]``: maybe one bumpy stretch across an aisle crossing (a floor joint)."""
    if rng.random() >= BUMP_SHARE:
        return []
    x, y = float(rng.choice(plan.crossings)), float(rng.choice(plan.lanes))
    size = [2.0, draw(rng, BUMP_LENGTH)]
    return [{"center": plan.world(x, y), "size": size[::-1] if plan.turned else size,
             "tilt_deg": draw(rng, BUMP_TILT)}]
