"""What a benchmark suite is: a named, versioned way to draw the cases every contender is scored on.

A suite draws its cases from a seed. The ``dev`` split uses the suite's fixed seed, so anyone can
reproduce and study it; the ``test`` split uses a seed drawn fresh at run time (and reported), so
nobody can tune to it. Every case records its cause, the worst fault among its detections, so
results can be broken down by cause.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from azgym.bench.run.profiles import AS_SHIPPED, SimulatedNoise
from azgym.core import Measurements, Pose
from azgym.errors import InvalidInputError
from azgym.profile import Profile
from azgym.sensing.labels import DIRECT, DISTRACTOR, GHOST, MISIDENTIFIED, MOVED, PARTIAL
from azgym.sensing.motion import Motion, joined

if TYPE_CHECKING:
    from azgym.world.drive import Frame

__all__ = ["CAUSES", "Case", "NO_TEST_SPLIT", "Suite", "frame_cause", "keep_every", "route_cases"]

NO_TEST_SPLIT = (
    "split: {suite} has no test split: its routes are the same for every seed (the seed draws "
    "only the noise), so frames drawn from a secret seed would have the dev split's true poses, "
    "which a localizer can redraw; score it on the dev split")
"""Why a suite of driven routes has no test split (``Suite.routes``)."""
CAUSES = ("clean", "partial", "moved", "ghost", "misidentified", "outlier")
"""Case causes, from harmless to harmful; a case's cause is its worst detection's."""

# A distractor (a lamp's blob, with no id) is harmless to a localizer that ignores unknown ids.
_LABEL_CAUSE = {DIRECT: 0, PARTIAL: 1, MOVED: 2, GHOST: 3, MISIDENTIFIED: 4, DISTRACTOR: 0}


@dataclass(frozen=True, eq=False)
class Case:
    """One case of a suite: what the localizer gets, and what it is scored against.

    Attributes:
        scenario: Name of the scenario (its beacon map is the localizer's map).
        measurements: The frame's detections.
        pose: The true camera pose (x, y, heading) [m, m, rad]; the heading is NaN where the
            truth has none (position-only truth: scored on position alone).
        cause: The worst fault among the detections (one of ``CAUSES``).
        group: A sub-set name for reports (e.g. "K=3", "warehouse-small, heavy").
        sequence: The sequence (a driven route) the frame belongs to, in order; "" for a frame
            on its own. A tracker is reset at the start of each sequence.
        motion: The odometry and IMU samples since the sequence's previous frame, or None.
        initial: On a sequence's first frame, its known start pose (the dock the forklift
            leaves), handed to the tracker's ``reset``; None elsewhere.
        time: The frame's time in its sequence [s] (NaN for a frame on its own).
        event: On the first frame after an event of the sequence ("kidnap": the forklift was
            carried elsewhere without motion data; "outage": no frames for a while), its name.
        frame: The frame's number in its recording (a log's ``frame`` column), or None: the
            results number it by its place.
    """

    scenario: str
    measurements: Measurements
    pose: Pose
    cause: str
    group: str
    sequence: str = ""
    motion: Motion | None = None
    initial: Pose | None = None
    time: float = math.nan
    event: str = ""
    frame: int | None = None


@dataclass(frozen=True)
class Suite:
    """A named, versioned benchmark suite.

    Attributes:
        name: Identifier (``azgym bench --suite NAME``).
        version: Bumped whenever the cases it draws change.
        description: One line for listings and reports.
        dev_seed: The seed of the public ``dev`` split.
        build: ``build(seed, quick)`` draws the cases; a suite that ``simulates`` profile
            fields draws them with ``build(seed, quick, noise=SimulatedNoise(...))`` too.
        routes: Whether its cases are driven routes (sequences with motion): trackers' suites.
            Such a suite drives the same routes for every seed, so it has no test split
            (:data:`NO_TEST_SPLIT`).
        simulates: The profile fields (``section.field``) its simulator takes
            (:mod:`azgym.bench.run.profiles`); none: it takes no profile.
        vehicle: The kind of vehicle that drives its routes (a profile of another kind is
            refused); None: any (frames on their own).
        profile: The profile it is drawn with (:meth:`profiled`); None: as shipped.
        defaults: The profile its contenders take their defaults from as shipped, as a log's
            manifest gives its own: the vehicle and camera its scenario declares and the
            simulator's motion errors (a tracker's defaults are the forklift's otherwise);
            None: the contenders' own defaults (they fit the forklift suites' simulator).
    """

    name: str
    version: int
    description: str
    dev_seed: int
    build: Callable[..., list[Case]]
    routes: bool = False
    simulates: tuple[str, ...] = ()
    vehicle: str | None = None
    profile: Profile | None = None
    defaults: Callable[[], Profile] | None = None

    def contender_profile(self) -> Profile | None:
        """What the contenders take their defaults from: the run's profile over ``defaults``."""
        if self.defaults is None:
            return self.profile
        return self.defaults() if self.profile is None else self.profile.over(self.defaults())

    def check_profile(self, profile: Profile) -> None:
        """Refuse a profile the suite cannot be drawn with (:meth:`profiled` says why)."""
        if not self.simulates:
            raise InvalidInputError(f"profile: {self.name} takes no profile: its simulator's "
                                    "noise is not one a profile sets")
        if self.profile is not None:
            raise InvalidInputError(f"profile: {self.name} is drawn with a profile already")
        kind = profile.vehicle.kind
        if kind is not None and self.vehicle is not None and kind != self.vehicle:
            raise InvalidInputError(
                f"profile: vehicle.kind is {kind!r}, but {self.name}'s routes are driven by a "
                f"{self.vehicle}: its motion data would not be the kind the profile describes")

    def profiled(self, profile: Profile) -> Suite:
        """The suite drawn with a profile's sensor and motion noise (:class:`SimulatedNoise`).

        Its cases differ from the suite's as shipped (unless the profile sets none of the
        fields it ``simulates``), so a leaderboard entry of the suite cannot be one of them.

        Raises:
            InvalidInputError: The suite takes no profile, is profiled already, or its
                routes are driven by another kind of vehicle than the profile's.
        """
        self.check_profile(profile)
        return dataclasses.replace(
            self, build=functools.partial(self.build, noise=SimulatedNoise(profile)),
            profile=profile)


def frame_cause(labels: np.ndarray) -> str:
    """The worst cause among a frame's detection labels (:mod:`azgym.sensing.labels`)."""
    worst = max((_LABEL_CAUSE[int(label)] for label in labels), default=0)
    return CAUSES[worst]


def route_cases(scenario: str, group: str, frames: Iterable[Frame],
                noise: SimulatedNoise = AS_SHIPPED) -> list[Case]:
    """Every frame of a driven route, as one sequence for trackers, from its start pose.

    ``noise`` is the one the route was simulated with: its odometry reads the speed as it says
    (:meth:`SimulatedNoise.read`).
    """
    cases = [Case(scenario, frame.measurements, frame.pose, frame_cause(frame.truth.label),
                  group, sequence=group, motion=noise.read(frame.motion), time=frame.time)
             for frame in frames]
    if cases:
        cases[0] = dataclasses.replace(cases[0], initial=cases[0].pose)
    return cases


def keep_every(cases: list[Case], every: int) -> list[Case]:
    """Cases 0, every, 2·every, …; a kept frame gets the motion of the frames dropped before it.

    Within a sequence, a kept frame's motion joins the samples since the previous kept frame
    (:func:`azgym.sensing.motion.joined`), and a sequence's first kept frame carries its pose
    as the known start.
    """
    kept: list[Case] = []
    pending: list[Motion] = []
    for k, case in enumerate(cases):
        if k and case.sequence != cases[k - 1].sequence:
            pending = []
        if case.motion is not None:
            pending.append(case.motion)
        if k % every:
            continue
        first = not kept or kept[-1].sequence != case.sequence or not case.sequence
        kept.append(dataclasses.replace(
            case, motion=joined(pending) if pending else None,
            initial=case.pose if first and case.sequence else case.initial))
        pending = []
    return kept
