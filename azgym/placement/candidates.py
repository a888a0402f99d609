"""Candidate places for new beacons: along the walls and on the rack ends, where surveyors put them.

* **Walls**: every wall of the scenario (the room's four sides when it lists none), at a spacing
  of about ``spacing`` metres (each wall split into equal parts, a candidate at the middle of
  each), at the height of the scenario's beacons (their median), and at least ``CEILING_GAP``
  under the wall's top, as the generator hangs wall beacons.
* **Rack ends**: the middle of both end faces of every rack, ``RACK_END_ABOVE`` over its top
  (the middle of the generator's ``RACK_END_Z``), so that the aisles on both sides see it over
  the rack; ``END_OUTSET`` out from the face, so that rounding never puts it inside.

A candidate within ``MIN_SEPARATION`` of an existing beacon or of an earlier candidate (two
walls meeting at a corner), inside a rack's footprint, or outside the room is dropped. Places are
rounded to the millimetre, as a surveyor would mark them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from azgym.arguments import positive_number
from azgym.core import FloatArray
from azgym.errors import InvalidInputError
from azgym.site import Scenario
from azgym.site.generator_beacons import CEILING_GAP, RACK_END_Z

__all__ = ["DEFAULT_SPACING", "MIN_SEPARATION", "Candidates", "candidate_places"]

DEFAULT_SPACING = 2.0
"""Default spacing of the wall candidates [m]."""
MAX_CANDIDATES = 5_000
"""The most candidate places searched (a 1 km perimeter at 0.2 m)."""
RACK_END_ABOVE = 0.5 * (RACK_END_Z[0] + RACK_END_Z[1])
"""How far over its rack's top a rack-end candidate hangs [m]."""
END_OUTSET = 0.01
"""How far out from a rack's end face a rack-end candidate hangs [m]."""
MIN_SEPARATION = 0.5
"""A candidate this close to a beacon or an earlier candidate (horizontally) is dropped [m]."""


@dataclass(frozen=True)
class Candidates:
    """Places a new beacon may go.

    Attributes:
        xyz: Positions, shape (C, 3) [m].
        kind: "wall" or "rack end", one per place.
    """

    xyz: FloatArray
    kind: tuple[str, ...]

    def __len__(self) -> int:
        return len(self.kind)


def candidate_places(scenario: Scenario, spacing: float = DEFAULT_SPACING) -> Candidates:
    """The candidate places of ``scenario`` (module docstring).

    Raises:
        InvalidInputError: ``spacing`` is not a number > 0, or gives more than
            :data:`MAX_CANDIDATES` places.
    """
    spacing = positive_number("spacing", spacing, "m")
    height = float(np.median(scenario.beacons.xyz[:, 2]))
    places: list[tuple[float, float, float, str]] = []
    for (x1, y1), (x2, y2), top in _walls(scenario):
        ratio = min(math.hypot(x2 - x1, y2 - y1) / spacing, MAX_CANDIDATES + 1.0)  # no overflow
        parts = max(1, round(ratio))
        if len(places) + parts > MAX_CANDIDATES:
            raise InvalidInputError(f"spacing {spacing:g} m gives more than {MAX_CANDIDATES} "
                                    "candidate places; use a larger spacing")
        z = min(height, top - CEILING_GAP)
        for t in (np.arange(parts) + 0.5) / parts:
            places.append((x1 + t * (x2 - x1), y1 + t * (y2 - y1), z, "wall"))
    for rack in scenario.racks:
        reach = 0.5 * rack.size[0] + END_OUTSET
        for sign in (-1.0, 1.0):
            places.append((rack.center[0] + sign * reach * math.cos(rack.angle),
                           rack.center[1] + sign * reach * math.sin(rack.angle),
                           rack.height + RACK_END_ABOVE, "rack end"))
    return _kept(scenario, places)


def _walls(scenario: Scenario) -> list[tuple[tuple[float, float], tuple[float, float], float]]:
    """(start, end, top) of every wall; the room's sides (no top) when the scenario has none."""
    if scenario.walls:
        return [(wall.start, wall.end, wall.height) for wall in scenario.walls]
    x_min, y_min, x_max, y_max = scenario.bounds
    corners = [(x_min, y_min), (x_max, y_min), (x_max, y_max), (x_min, y_max)]
    return [(corners[k], corners[(k + 1) % 4], math.inf) for k in range(4)]


def _kept(scenario: Scenario, places: list[tuple[float, float, float, str]]) -> Candidates:
    """The places in the room, outside the racks, apart from the beacons and from each other."""
    x_min, y_min, x_max, y_max = scenario.bounds
    taken = [tuple(xy) for xy in scenario.beacons.xy]
    kept: list[tuple[float, float, float]] = []
    kinds: list[str] = []
    for x, y, z, kind in places:
        x, y, z = round(x, 3), round(y, 3), round(z, 3)
        if not (x_min <= x <= x_max and y_min <= y <= y_max):
            continue
        if any(rack.contains(x, y) for rack in scenario.racks):
            continue
        if any(math.hypot(x - tx, y - ty) < MIN_SEPARATION for tx, ty in taken):
            continue
        taken.append((x, y))
        kept.append((x, y, z))
        kinds.append(kind)
    return Candidates(np.array(kept, dtype=float).reshape(-1, 3), tuple(kinds))
