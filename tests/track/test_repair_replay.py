"""robust:repair=true re-runs the track without a new suspect from before its stretch of sightings.

A suspect's earlier sightings, fitted before they were rejected, dragged the track; once it is
suspected the track going forward is the one that never used it, from the state before its
stretch began, and the lag that makes that possible is bounded in seconds and frames.
"""

from __future__ import annotations

import numpy as np
import pytest

import azgym
from azgym import Measurements
from azgym.track.repair_lag import LAG_FRAMES, LAG_S
from azgym.world.drive import simulate


@pytest.fixture(scope="module")
def route():
    scenario = azgym.load_scenario("warehouse-small")  # ships beacon 9 moved 1.5 m
    return scenario, list(simulate(scenario, "aisle-loop", seed=7))


def without(measurements: Measurements, beacon: int) -> Measurements:
    keep = measurements.ids != beacon
    return Measurements(measurements.ids[keep], measurements.azimuth[keep])


def test_after_a_suspicion_the_track_is_the_one_that_never_used_the_suspect(route):
    scenario, frames = route
    repairing = azgym.make_tracker("robust", repair=True)
    repairing.reset(seed=0, initial=frames[0].pose)
    answers = []
    for frame in frames:
        repairing.predict(frame.motion)
        answers.append(repairing.update(frame.measurements, scenario.beacons))
    suspicion = next(k for k, a in enumerate(answers) if "suspected" in a.diagnostics)
    (suspect,) = answers[suspicion].diagnostics["suspected"]
    start = suspicion - answers[suspicion].diagnostics["replayed"] + 1
    repaired = next(k for k, a in enumerate(answers) if "repaired" in a.diagnostics)
    assert suspect == 9 and 0 <= start < suspicion < repaired
    # the track re-run from the start of the suspect's stretch without it: robust, never given it
    plain = azgym.make_tracker("robust")
    plain.reset(seed=0, initial=frames[0].pose)
    for k, frame in enumerate(frames[:repaired]):
        plain.predict(frame.motion)
        measurements = without(frame.measurements, suspect) if k >= start else \
            frame.measurements
        estimate = plain.update(measurements, scenario.beacons)
        if k >= suspicion:  # from the suspicion on, the same track (until the repair)
            assert answers[k].ok and estimate.ok
            np.testing.assert_allclose(answers[k].pose, estimate.pose, rtol=0, atol=1e-12)
            np.testing.assert_allclose(answers[k].covariance, estimate.covariance, rtol=0,
                                       atol=1e-15)


def test_the_answers_given_before_the_suspicion_are_not_changed(route):
    scenario, frames = route
    repairing = azgym.make_tracker("robust", repair=True)
    plain = azgym.make_tracker("robust")
    for tracker in (repairing, plain):
        tracker.reset(seed=0, initial=frames[0].pose)
    for frame in frames:
        repairing.predict(frame.motion)
        plain.predict(frame.motion)
        answer = repairing.update(frame.measurements, scenario.beacons)
        before = plain.update(frame.measurements, scenario.beacons)
        if "suspected" in answer.diagnostics:
            break
        assert answer.pose == before.pose  # nothing suspected yet: robust's answers


def test_the_lag_keeps_at_most_its_seconds_and_frames():
    scenario = azgym.load_scenario("warehouse-small")
    frames = list(simulate(scenario, "aisle-loop", seed=7, max_time=2.0 * LAG_S))
    tracker = azgym.make_tracker("robust", repair=True)
    tracker.reset(seed=0, initial=frames[0].pose)
    longest = 0
    for frame in frames:
        tracker.predict(frame.motion)
        tracker.update(frame.measurements, scenario.beacons)
        kept = tracker._lag.frames
        assert len(kept) <= LAG_FRAMES and kept[-1][1] - kept[0][1] <= LAG_S  # (steps, time, …)
        assert len(tracker._lag.snapshots) <= len(kept) // 10 + 2  # one a second, at 10 a second
        longest = max(longest, len(kept))
    assert frames[-1].time > LAG_S and longest >= int(LAG_S * 10) - 1  # 10 frames a second
