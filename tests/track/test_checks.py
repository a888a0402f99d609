"""check_tracker: every built-in tracker passes, and a broken one is named by the check it fails."""

from __future__ import annotations

import numpy as np
import pytest

import azgym
from azgym.track.checks import TrackerCheckError


@pytest.mark.parametrize("name", [*azgym.list_trackers(), "ransac"])
def test_every_built_in_tracker_passes(name, capsys):
    azgym.check_tracker(azgym.make_tracker(name))
    assert "passed all" in capsys.readouterr().out


class Lazy(azgym.Tracker):
    """Follows ransac, but can be made to answer the origin, a string ok, or at random."""

    def __init__(self, *, fault: str = ""):
        self.fault = fault
        self.ransac = azgym.make_localizer("ransac")
        self._validate_once()

    def _reset(self, rng, initial):
        pass

    def _predict(self, motion):
        pass

    def _update(self, measurements, beacons):
        estimate = self.ransac.localize(measurements, beacons)
        if self.fault == "origin":
            return azgym.Estimate(0.0, 0.0, 0.0, inliers=estimate.inliers)
        if self.fault == "string-ok":
            return azgym.Estimate(estimate.x, estimate.y, estimate.heading,
                                  inliers=estimate.inliers, ok="yes")
        if self.fault == "random":  # global randomness: a fresh copy answers differently
            return azgym.Estimate(estimate.x + np.random.normal(0, 1e-3), estimate.y,
                                  estimate.heading, inliers=estimate.inliers)
        return estimate


@pytest.mark.parametrize(("fault", "check"), [
    ("origin", "follows a route from its start pose: median position error"),
    ("string-ok", "a well-formed Estimate: frame 0"),
    ("random", "reset forgets"),
])
def test_a_broken_tracker_is_named_by_the_check_it_fails(fault, check):
    with pytest.raises(TrackerCheckError, match=check):
        azgym.check_tracker(Lazy(fault=fault), verbose=False)
    azgym.check_tracker(Lazy(), verbose=False)


def test_the_command_checks_trackers_too(capsys):
    from azgym.cli import main

    assert main(["check", "robust"]) == 0
    assert "check_tracker: Robust passed all 5 checks" in capsys.readouterr().out
