"""``azgym layout optimize``: place new beacons to lower the p95 of the predicted σ over the floor.

The information matrix of a layout at a cell is the sum of its beacons' contributions
(:mod:`azgym.placement.information`), so each candidate's contribution at every cell is computed
once, and trying a candidate is one addition per cell. The search:

1. **Greedy**: add, one at a time, the candidate that lowers the objective
   (:func:`azgym.placement.objective.objective`) most; stop early when none lowers it (a beacon
   that helps no cell is not placed, so fewer than asked may be placed, or none).
2. **Swaps**: for each placed beacon in turn, try every unused candidate in its stead and keep
   the best swap if it lowers the objective; repeat until a whole round changes nothing (at most
   :data:`MAX_SWAP_ROUNDS` rounds). Greedy choices made early, for cells a later beacon covers
   better, are undone here.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from azgym.arguments import whole_number
from azgym.core import FloatArray, IntArray
from azgym.errors import InvalidInputError
from azgym.placement.candidates import Candidates
from azgym.placement.floor import Floor
from azgym.placement.information import contributions, position_sigma
from azgym.placement.objective import objective
from azgym.placement.visibility import visible_beacons
from azgym.progress import Progress, counter
from azgym.site import Scenario

__all__ = ["MAX_ADD", "Placement", "check_add", "place_beacons"]

MAX_ADD = 100
"""The most beacons one run places."""
MAX_SWAP_ROUNDS = 10
"""Rounds of the swap pass at most."""
IMPROVEMENT = 1e-12
"""A layout must lower the objective by more than this to count as better [m]."""
CHUNK_VALUES = 4_000_000
"""Floats of candidate layouts scored at once (bounds the memory of a large floor)."""


@dataclass(frozen=True)
class Placement:
    """The beacons placed and the predicted σ before and after.

    Attributes:
        candidates: The places searched.
        chosen: Indices of the places chosen, in the order placed (fewer than asked, or none,
            when no other candidate lowers the objective).
        width: Width W of the new beacons [m] (the median of the scenario's).
        before, after: Predicted σ_pos per cell [m], shape (P,).
        visible_before, visible_after: Beacons seen per cell, shape (P,).
        greedy_score, score: The objective after the greedy pass and after the swaps.
    """

    candidates: Candidates
    chosen: tuple[int, ...]
    width: float
    before: FloatArray
    after: FloatArray
    visible_before: IntArray
    visible_after: IntArray
    greedy_score: float
    score: float

    @property
    def new_xyz(self) -> FloatArray:
        """Where the new beacons go, shape (add, 3) [m]."""
        return self.candidates.xyz[list(self.chosen)]


def check_add(add: object, candidates: Candidates) -> int:
    """``add`` as a count of new beacons: 1 to :data:`MAX_ADD`, and no more than the places."""
    count = whole_number("add", add)
    if count > min(MAX_ADD, len(candidates)):
        raise InvalidInputError(
            f"add must be at most {min(MAX_ADD, len(candidates))} (the most one run places is "
            f"{MAX_ADD}; there are {len(candidates)} candidate places), got {count}")
    return count


def place_beacons(scenario: Scenario, floor: Floor, candidates: Candidates, add: int,
                  progress: Progress | None = None) -> Placement:
    """Choose ``add`` of the candidate places (module docstring).

    ``progress`` hears what is done, counted (:func:`azgym.progress.counter`): the cells whose
    line of sight to the beacons and the candidates is tested, the beacons placed by the greedy
    pass, the rounds of swaps (at most :data:`MAX_SWAP_ROUNDS`; the count ends early when a
    round changes nothing).
    """
    add = check_add(add, candidates)
    points, beacons, model = floor.points, scenario.beacons, scenario.error_model
    width = float(np.median(beacons.width))
    widths = np.full(len(candidates), width)
    with counter(progress, "line of sight", len(points), "cells") as tested:
        seen_all = visible_beacons(scenario, points, np.vstack([beacons.xyz, candidates.xyz]),
                                   np.concatenate([beacons.width, widths]), tested)
    seen, seen_new = seen_all[:, :len(beacons)], seen_all[:, len(beacons):]
    base = contributions(points, beacons.xy, beacons.width, model, seen).sum(axis=1)
    base_count = seen.sum(axis=1)
    gain = np.ascontiguousarray(contributions(
        points, candidates.xyz[:, :2], widths, model, seen_new).transpose(1, 0, 2))
    search = _Search(base, base_count, gain, np.ascontiguousarray(seen_new.T))
    chosen: list[int] = []
    current = search.score(chosen)
    with counter(progress, "greedy", add, "beacons") as placed:
        for _ in range(add):
            scores = search.scores(chosen, chosen)
            best = int(np.nanargmin(scores))
            if not scores[best] < current - IMPROVEMENT:  # no candidate helps: stop
                break
            chosen.append(best)
            current = float(scores[best])
            placed(len(chosen))
    greedy_score = search.score(chosen)
    with counter(progress, "swaps", MAX_SWAP_ROUNDS, "rounds") as rounds:
        chosen = search.swap(chosen, rounds)
    info, count = search.layout(chosen)
    return Placement(candidates, tuple(chosen), width, position_sigma(base, base_count),
                     position_sigma(info, count), base_count, count, greedy_score,
                     search.score(chosen))


class _Search:
    """Scores layouts made of the scenario's beacons and some candidates, by sums."""

    def __init__(self, base: FloatArray, base_count: IntArray, gain: FloatArray,
                 seen: np.ndarray) -> None:
        self.base, self.base_count, self.gain, self.seen = base, base_count, gain, seen

    def layout(self, chosen: list[int]) -> tuple[FloatArray, IntArray]:
        """Information and beacons seen per cell with the ``chosen`` candidates added."""
        return (self.base + self.gain[chosen].sum(axis=0),
                self.base_count + self.seen[chosen].sum(axis=0))

    def score(self, chosen: list[int]) -> float:
        """The objective of a layout."""
        return float(objective(position_sigma(*self.layout(chosen))))

    def scores(self, fixed: list[int], used: list[int]) -> FloatArray:
        """The objective of ``fixed`` plus each candidate in turn (NaN for those in ``used``)."""
        info, count = self.layout(fixed)
        result = np.full(len(self.gain), np.nan)
        unused = np.setdiff1d(np.arange(len(self.gain)), used)
        chunk = max(1, CHUNK_VALUES // max(1, self.gain[0].size))
        for start in range(0, unused.size, chunk):
            part = unused[start:start + chunk]
            sigma = position_sigma(info[None] + self.gain[part], count[None] + self.seen[part])
            result[part] = objective(sigma)
        return result

    def swap(self, chosen: list[int], rounds: Callable[[int], None]) -> list[int]:
        """The swap pass (module docstring): ``chosen`` improved one swap at a time.

        ``rounds`` is called with the number of rounds done as each ends.
        """
        chosen = list(chosen)
        current = self.score(chosen)
        for done in range(1, MAX_SWAP_ROUNDS + 1):
            improved = False
            for k in range(len(chosen)):
                others = chosen[:k] + chosen[k + 1:]
                scores = self.scores(others, chosen)
                best = int(np.nanargmin(scores)) if np.isfinite(scores).any() else -1
                if best >= 0 and scores[best] < current - IMPROVEMENT:
                    chosen[k], current, improved = best, float(scores[best]), True
            rounds(done)
            if not improved:
                break
        return chosen
