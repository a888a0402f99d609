"""The records of map repair (:mod:`azgym.track.repair`): a run of rejections, and a repair."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from azgym.core import FloatArray
from azgym.track.repair_rays import RayStore

__all__ = ["Repair", "Run"]


@dataclass(frozen=True, eq=False)
class Repair:
    """A beacon found moved and put at its new position (in :attr:`MapRepair.placed`, or since).

    Attributes:
        time: When [s] (the frame's time).
        frame: Which frame, counted from 0 since ``reset``.
        beacon: The beacon's id.
        old: Its map position (x, y) [m].
        new: Its new position (x, y) [m].
        covariance: The new position's covariance (2, 2) [m²], the track's shared error in it;
            a read-only copy (what a caller is handed cannot change the tracker).
        rays: How many rays located it.
    """

    time: float
    frame: int
    beacon: int
    old: tuple[float, float]
    new: tuple[float, float]
    covariance: FloatArray
    rays: int

    def __post_init__(self) -> None:
        covariance = np.array(self.covariance, dtype=np.float64)
        covariance.setflags(write=False)
        object.__setattr__(self, "covariance", covariance)

    @property
    def std(self) -> float:
        """The new position's standard deviation along its worst axis [m]."""
        return float(math.sqrt(np.linalg.eigvalsh(self.covariance)[-1]))


@dataclass(eq=False)
class Run:
    """One beacon's run of rejected sightings, and its rays (a repaired one's, refined)."""

    since: float
    last: float
    others_accepted: int
    others_rejected: int
    others_by: dict[int, int]
    """Each beacon's agreeing sightings when the run began."""
    rejected: int = 0
    suspected: bool = False
    fitted: bool = False
    """Whether the fit test (:mod:`azgym.track.repair_fit`) made it a suspect, not rejections."""
    agreed: int = 0
    rays: RayStore = field(default_factory=RayStore)
    sightings: int = 0
    """Sightings whose rays were added."""
    tried: int = 0
    """Rays added when the suspect was last located (or not) from them."""
    tried_span: float = 0.0
    """Its rays' spread then [rad]."""
    std: float = math.inf
    """The worst-axis standard deviation of the position its rays last gave (:func:`worst_std`)."""
