"""The tracker interface: the bookkeeping every tracker shares, and localizers as trackers."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import azgym
from azgym import InvalidInputError
from azgym.sensing.motion import ImuSamples, Motion, OdometrySamples
from azgym.world.drive import simulate


def motion(time, odometry_times=(), imu_times=(), value=0.0):
    odometry_times = np.asarray(odometry_times, dtype=float)
    imu_times = np.asarray(imu_times, dtype=float)
    return Motion(time,
                  OdometrySamples(odometry_times, np.full(odometry_times.size, value),
                                  np.zeros(odometry_times.size)),
                  ImuSamples(imu_times, np.full(imu_times.size, value),
                             np.zeros((imu_times.size, 2)), np.full(imu_times.size, math.nan)))


@pytest.fixture(scope="module")
def route():
    scenario = azgym.load_scenario("warehouse-small")
    return scenario, list(simulate(scenario, None, seed=3))[:12]


def test_a_localizer_is_a_tracker_without_memory(route):
    scenario, frames = route
    tracker, localizer = azgym.make_tracker("ransac"), azgym.make_localizer("ransac")
    assert isinstance(tracker, azgym.FrameByFrame)
    tracker.reset(seed=0)
    for frame in frames:
        tracker.predict(frame.motion)
        ours = tracker.update(frame.measurements, scenario.beacons)
        theirs = localizer.localize(frame.measurements, scenario.beacons)
        assert (ours.ok, ours.x, ours.y, ours.heading) == (theirs.ok, theirs.x, theirs.y,
                                                            theirs.heading)


def test_a_tracker_refuses_frames_before_reset(route):
    scenario, frames = route
    tracker = azgym.make_tracker("ransac")
    with pytest.raises(InvalidInputError, match=r"FrameByFrame\.update called before reset"):
        tracker.update(frames[0].measurements, scenario.beacons)
    with pytest.raises(InvalidInputError, match=r"FrameByFrame\.predict called before reset"):
        tracker.predict(frames[0].motion)


@pytest.mark.parametrize(("bad", "message"), [
    (motion(0.1), r"motion.time must be finite and not before the previous frame's \(0.2\)"),
    (motion(math.nan), "motion.time must be finite"),
    (motion(0.3, odometry_times=[0.25, 0.22]), r"motion.odometry.time must not decrease"),
    (motion(0.3, imu_times=[0.2]),
     r"motion.imu.time must not decrease and lie within \(0.2, 0.3\]"),
    (motion(0.3, imu_times=[0.35]), r"motion.imu.time must not decrease"),
    (motion(0.3, odometry_times=[0.25], value=math.nan), "motion.odometry.speed holds a NaN"),
    ("not motion", "motion must be an azgym Motion, got str"),
])
def test_motion_out_of_order_or_not_finite_is_refused(bad, message):
    tracker = azgym.make_tracker("lsq")
    tracker.reset()
    tracker.predict(motion(0.2, [0.1, 0.2], [0.05]))
    with pytest.raises(InvalidInputError, match=message):
        tracker.predict(bad)


def test_an_imu_without_orientation_sensor_reports_nan_headings_and_is_accepted():
    tracker = azgym.make_tracker("lsq")
    tracker.reset()
    tracker.predict(motion(0.2, imu_times=[0.1, 0.2]))  # heading NaN: no orientation sensor


@pytest.mark.parametrize("initial", [(1.0, 2.0), (1.0, math.inf, 0.0), "here"])
def test_reset_refuses_an_initial_pose_that_is_not_three_finite_numbers(initial):
    with pytest.raises(InvalidInputError, match="initial must be a finite pose"):
        azgym.make_tracker("ransac").reset(initial=initial)


def test_make_localizer_refuses_a_tracker_and_names_make_tracker(tmp_path):
    plugin = tmp_path / "still.py"
    plugin.write_text("class Still:\n    def reset(self, seed=None, initial=None): pass\n"
                      "    def predict(self, motion): pass\n"
                      "    def update(self, measurements, beacons): pass\n")
    assert type(azgym.make_tracker(f"{plugin}:Still")).__name__ == "Still"
    with pytest.raises(InvalidInputError, match="built a tracker.*azgym.make_tracker"):
        azgym.make_localizer(f"{plugin}:Still")


def test_the_adapter_checks_what_it_wraps():
    with pytest.raises(InvalidInputError, match="FrameByFrame.localizer must have a localize"):
        azgym.FrameByFrame(localizer=42)
    tracker = azgym.make_tracker("ransac")
    assert dataclasses.is_dataclass(tracker) is False and "localizer" in tracker.get_params()
