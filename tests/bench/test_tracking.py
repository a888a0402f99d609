"""Track figures, worked by hand, and the route-events suite they are made for."""

from __future__ import annotations

import math

import numpy as np
import pytest

from azgym.bench.report.tracking import tracking_metrics
from azgym.bench.run.outcome import Outcome
from azgym.bench.suites import get_suite
from azgym.bench.suites.base import Case
from azgym.sensing.motion import ImuSamples, Motion, OdometrySamples


def still(time):
    """A driven frame's motion: no sample (the vehicle's sensors said nothing new)."""
    empty = np.zeros(0)
    return Motion(time, OdometrySamples(empty, empty, empty),
                  ImuSamples(empty, empty, np.zeros((0, 2)), empty))


def track(errors_cm, events=None, sequence="route", driven=True):
    """Cases at 10 Hz and an outcome with these errors (None: no estimate)."""
    events = events or {}
    cases = [Case("s", None, (0.0, 0.0, 0.0), "clean", "g", sequence=sequence, time=k / 10,
                  event=events.get(k, ""), motion=still(k / 10) if driven else None)
             for k in range(len(errors_cm))]
    outcome = Outcome.empty(len(errors_cm))
    for k, error in enumerate(errors_cm):
        if error is not None:
            outcome.ok[k], outcome.position[k], outcome.heading[k] = True, error / 100, 0.0
    return cases, outcome


def test_a_static_recording_has_no_track_figures():
    """Sequences without motion (a log's static positions) are no track: no figures."""
    cases, outcome = track([5, 5, None, 5], driven=False)
    assert tracking_metrics(cases, outcome) is None
    cases, outcome = track([5, 5, None, 5])
    assert tracking_metrics(cases, outcome) is not None


def test_availability_counts_from_the_first_fix():
    cases, outcome = track([None, None, 5, 5, None, 5])
    metrics = tracking_metrics(cases, outcome)
    assert metrics["availability_after_first_fix"] == pytest.approx(3 / 4)
    assert metrics["max_cm_outside_kidnaps"] == 5 and metrics["frames_over_1m_outside_kidnaps"] == 0


def test_recovery_is_the_time_to_the_first_fix_within_10_cm_and_kidnap_windows_are_left_out():
    errors = [2, 2, 900, 400, None, 30, 8, 2] + [2] * 20 + [150]
    cases, outcome = track(errors, events={2: "kidnap"})
    metrics = tracking_metrics(cases, outcome)
    (event,) = metrics["events"]
    assert event["event"] == "kidnap" and event["recovery_s"] == pytest.approx(0.4)
    assert event["max_cm_before_recovery"] == 900
    # Frames 2-21 are within 2 s of the kidnapping; the 150 cm at 2.8 s is outside it.
    assert metrics["max_cm_outside_kidnaps"] == 150
    assert metrics["frames_over_1m_outside_kidnaps"] == 1


def test_an_event_never_recovered_from_says_so():
    cases, outcome = track([2, 50, 60, None], events={1: "outage"})
    assert tracking_metrics(cases, outcome)["events"][0]["recovery_s"] is None


def test_frames_on_their_own_have_no_track_figures():
    cases, outcome = track([2, 3], sequence="")
    assert tracking_metrics(cases, outcome) is None


def test_route_events_cuts_an_outage_and_a_kidnapping_into_each_route():
    cases = get_suite("route-events").build(19, False)
    marked = [case for case in cases if case.event]
    assert [case.event for case in marked] == ["outage", "kidnap"] * 2
    for case in marked:
        before = cases[cases.index(case) - 1]
        gap = case.time - before.time
        if case.event == "outage":  # no frames for 3 s, every motion sample of the gap kept
            assert gap == pytest.approx(3.1) and case.motion.odometry.time[0] <= before.time + 0.03
        else:  # carried 10 s along the route with no motion data
            assert gap == pytest.approx(10.1) and case.motion.odometry.time.size == 0
            moved = math.dist(case.pose[:2], before.pose[:2])
            assert moved > 3.0
    assert np.all(np.diff([c.time for c in cases if c.sequence == cases[0].sequence]) > 0)
