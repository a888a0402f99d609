"""The navigation suites: localizers scored by where they get the forklift, in closed loop.

A frame suite (:mod:`azgym.bench.suites`) scores each estimate against the truth. A navigation
suite scores what the estimates are for: a navigator drives a Navigate environment on the pose
a localizer gives it, and the drive is scored (:mod:`azgym.bench.navigation.scoring`: success, SPL,
collisions, time to goal, and the localization error along the way). Every answer moves the
forklift, so the localizer's next frame depends on its last answer: no two localizers see the
same frames, and the suite is defined by its episodes, not by frames drawn in advance.

Episode k of a run is the environment's ``reset(seed=seed + k)``: the start and goal spots and
every noise draw follow from it. The ``dev`` split uses the suite's fixed seed; the ``test``
split a seed drawn at run time (and reported), as for the frame suites, whose episodes are none
of the dev split's.
"""

from __future__ import annotations

import secrets
from dataclasses import dataclass, field
from typing import Any

from azgym.arguments import MAX_SEED
from azgym.registry import Registry

__all__ = ["NAVIGATION_SUITES", "NAVIGATORS", "NavigationSuite", "get_navigation_suite",
           "overlap"]

NAVIGATORS = ("pure-pursuit", "ppo")
"""The built-in navigators: the scripted baseline and the shipped PPO policy
(:mod:`azgym.nav.policy_file`)."""


@dataclass(frozen=True)
class NavigationSuite:
    """A named, versioned set of navigation episodes.

    Attributes:
        name: Identifier (``azgym bench --suite NAME``).
        version: Bumped whenever its episodes or their scoring change (2: SPL against the
            geodesic shortest path, :mod:`azgym.nav.geodesic`; 3: a stable-baselines3 policy
            acts through torch's portable CPU kernels, :mod:`azgym.torch_kernels`, so that its
            episodes repeat on every x86-64 processor).
        description: One line for listings and reports.
        dev_seed: The seed of the ``dev`` split's first episode.
        env_id: The Navigate environment driven.
        episodes: Episodes per contender.
        quick_episodes: Episodes per contender in the suite's small version (``--quick``).
        localizers: The localizers and trackers run when none is named. A tracker starts
            without the start pose (the navigator must find itself), so ``dead-reckoning``,
            which needs one, is not among them.
        env_kwargs: Further arguments of the environment (the camera model).
    """

    name: str
    version: int
    description: str
    dev_seed: int
    env_id: str
    episodes: int
    quick_episodes: int
    localizers: tuple[str, ...]
    env_kwargs: dict[str, Any] = field(default_factory=dict)

    def size(self, quick: bool) -> int:
        """Episodes per contender in the full or the small version."""
        return self.quick_episodes if quick else self.episodes

    @property
    def dev_episodes(self) -> range:
        """The seeds of the dev split's episodes (a test split's must be others)."""
        return range(self.dev_seed, self.dev_seed + self.episodes)

    def test_seed(self) -> int:
        """A fresh seed for a test split: its episodes are none of the dev split's."""
        while True:
            seed = secrets.randbelow(MAX_SEED - self.episodes)
            if not overlap(range(seed, seed + self.episodes), self.dev_episodes):
                return seed


def overlap(first: range, second: range) -> range:
    """The seeds two runs of episodes share (empty: none)."""
    return range(max(first.start, second.start), min(first.stop, second.stop))


NAVIGATION_SUITES: Registry[NavigationSuite] = Registry("navigation suite", {
    suite.name: suite for suite in (
        NavigationSuite(
            "navigation", 3, "closed loop in warehouse-small: a navigator drives spot to spot on "
            "each localizer's pose; success, SPL, collisions, time to goal, error along the way",
            2300, "azgym/Navigate-WarehouseSmall-v2", 100, 10,
            ("truth", "ransac", "lsq", "mex-coarse", "loo", "ng-ransac", "learned", "tkf", "lpkf",
             "gated-ekf")),
        NavigationSuite(
            "navigation-image", 3, "the navigation suite through the fisheye image path: blobs "
            "detected from pixels, ids decoded from blinking (30 Hz camera)",
            2400, "azgym/Navigate-WarehouseSmall-v2", 100, 5, ("ransac", "lsq", "gated-ekf"),
            {"sensor": "image", "ids": "blink"}),
    )})
"""The navigation suites by name, in the order the board shows them."""


def get_navigation_suite(name: str) -> NavigationSuite:
    """The navigation suite of that name ("Did you mean ...?" otherwise)."""
    return NAVIGATION_SUITES[name]
