"""Hostile inputs to the survey: each answered by name, never a guess, a hang or a traceback."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from azgym.core import BeaconMap, Measurements
from azgym.errors import InvalidInputError
from azgym.mapping import Drive, Prior, SurveyFrame, survey
from azgym.sensing.motion import ImuSamples, Motion, OdometrySamples

pytest.importorskip("gtsam")

RATE = 10.0
SAMPLES = 5


def straight_drive(beacons: np.ndarray, speed: float, seconds: float = 10.0,
                   odometry: bool = True, start: tuple | None = (0.0, 0.0, 0.0)) -> Drive:
    """A forklift's camera driving east along y = 0 (or standing), seeing ``beacons`` exactly."""
    frames = []
    count = int(seconds * RATE)
    for k in range(count):
        time = k / RATE
        x = speed * time
        ids = np.arange(1, len(beacons) + 1)
        azimuth = np.arctan2(beacons[:, 1], beacons[:, 0] - x)
        sample_times = time - np.arange(SAMPLES)[::-1] / (RATE * SAMPLES) if k else np.zeros(0)
        n = sample_times.size
        zeros = np.zeros(n)
        odo = OdometrySamples(sample_times if odometry else np.zeros(0),
                              np.full(n if odometry else 0, speed),
                              zeros.copy() if odometry else np.zeros(0))
        imu = ImuSamples(sample_times.copy(), zeros.copy(), np.zeros((n, 2)), np.full(n, np.nan))
        frames.append(SurveyFrame(time, Measurements(ids, azimuth), Motion(time, odo, imu)))
    return Drive(tuple(frames), start, "the test drive")


def test_no_motion_leaves_every_beacon_unobservable() -> None:
    beacons = np.array([[5.0, 3.0], [2.0, -4.0], [-3.0, 1.0]])
    result = survey(straight_drive(beacons, speed=0.0))
    assert not result.observable.any()
    assert np.isnan(result.xy).all()
    assert all("too narrow a baseline" in reason for reason in result.reasons)


def test_beacons_collinear_with_the_path_are_unobservable() -> None:
    beacons = np.array([[20.0, 0.0], [30.0, 0.0]])  # straight ahead, on the path's line
    result = survey(straight_drive(beacons, speed=1.0))
    assert not result.observable.any()
    assert all("too narrow a baseline" in reason for reason in result.reasons)


def test_one_beacon_beside_the_path_is_surveyed() -> None:
    beacons = np.array([[5.0, 4.0]])
    result = survey(straight_drive(beacons, speed=1.0))
    assert result.observable.all()
    np.testing.assert_allclose(result.xy[0], beacons[0], atol=0.02)


def test_one_anchor_leaves_the_map_frame_free() -> None:
    beacons = np.array([[5.0, 4.0]])
    prior = Prior(BeaconMap([1], [[5.0, 4.0, 3.0]]), (1,))
    with pytest.raises(InvalidInputError, match="map frame is free.*1 anchor and no start pose"):
        survey(straight_drive(beacons, speed=1.0, start=None), prior)


def test_two_anchors_unseen_by_a_drive_without_a_start() -> None:
    beacons = np.array([[5.0, 4.0], [8.0, -3.0]])
    prior = Prior(BeaconMap([7, 8], [[5.0, 4.0, 3.0], [1.0, 1.0, 3.0]]), (7, 8))
    with pytest.raises(InvalidInputError, match="the test drive has no known start pose and "
                                                "observes 0 anchors"):
        survey(straight_drive(beacons, speed=1.0, start=None), prior)


def test_two_anchors_place_a_drive_without_a_start() -> None:
    beacons = np.array([[5.0, 4.0], [8.0, -3.0], [3.0, -5.0]])
    prior = Prior(BeaconMap([1, 2], [[5.0, 4.0, 3.0], [8.0, -3.0, 3.0]]), (1, 2))
    result = survey(straight_drive(beacons, speed=1.0, start=None), prior)
    np.testing.assert_allclose(result.xy[2], beacons[2], atol=0.05)


def test_unknown_anchor_id_is_named() -> None:
    with pytest.raises(InvalidInputError, match=r"anchor id \[42\] not in the map"):
        Prior(BeaconMap([1, 2], np.zeros((2, 3))), (42,))
    with pytest.raises(InvalidInputError, match="without a map"):
        Prior(None, (1, 2))


def test_no_odometry_unseen_motion_is_not_trusted() -> None:
    """Without odometry the motion is unobserved: nothing surveyed from a standing guess."""
    beacons = np.array([[5.0, 4.0], [2.0, -4.0]])
    result = survey(straight_drive(beacons, speed=1.0, odometry=False))
    assert not result.observable.any()


def test_no_frames() -> None:
    with pytest.raises(InvalidInputError, match="no frames"):
        survey(Drive(()))


def test_cli_log_without_odometry_and_an_unknown_anchor(tmp_path: Path) -> None:
    """The command names the problem (a subprocess, bounded by a timeout)."""
    log = tmp_path / "log"
    subprocess.run([sys.executable, "-m", "azgym", "export", "route", "--scenario",
                    "warehouse-small", "--route", "aisle-loop", "--out", str(log)],
                   check=True, capture_output=True, timeout=120)
    command = [sys.executable, "-m", "azgym"]
    run = subprocess.run([*command, "survey", str(log), "--anchor", "1",
                          "42", "--out", str(tmp_path / "map")], capture_output=True,
                         text=True, timeout=120)
    assert run.returncode != 0 and "anchor id [42] not in the map" in run.stderr
    (log / "odometry.csv").unlink()
    (log / "imu.csv").unlink()
    run = subprocess.run([*command, "survey", str(log), "--anchor", "1",
                          "2", "--out", str(tmp_path / "map")], capture_output=True,
                         text=True, timeout=120)
    assert run.returncode != 0 and "no odometry.csv or imu.csv" in run.stderr
    assert not (tmp_path / "map" / "beacons.csv").exists()


def test_a_beacon_the_solve_leaves_indeterminate_is_unobservable_not_a_gtsam_error() -> None:
    """pick-and-back (seed 2, 1 % misread ids) under Huber: the ghosts drag one beacon where its
    agreeing rays no longer spread, and GTSAM's marginals found the graph indeterminate (a raw
    RuntimeError). The beacon is reported unobservable; the others keep their covariances."""
    import dataclasses

    from azgym.mapping import Settings, simulated_drive
    from azgym.site import load_scenario
    from azgym.site.elements import Faults
    from azgym.world.drive import simulate

    shipped = load_scenario("warehouse-small")
    scenario = dataclasses.replace(shipped, faults=Faults(0.01))
    frames = list(simulate(scenario, "pick-and-back", 2))
    result = survey(simulated_drive(frames, frames[0].pose), Prior(shipped.beacons, (1, 2)),
                    Settings(loss="huber"))
    assert not result.observable.all()
    assert all(reason for reason, seen in zip(result.reasons, result.observable, strict=True)
               if not seen)
    kept = result.covariances[result.observable]
    assert np.isfinite(kept).all() and (np.linalg.eigvalsh(kept) > 0).all()
    assert np.isnan(result.covariances[~result.observable]).all()
