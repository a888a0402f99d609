"""Logs as a careless real logger writes them: calibrate gives a clear skip or refusal, never a
figure it cannot back (times that are not seconds, frames that share one stamp, a log too short
to bound a fit)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from logs.mini_log import BEACONS, MANIFEST_2, write_log

from azgym.logs import LogError, read_log
from azgym.logs.calibrate import calibrate
from azgym.logs.clocks import nudged, settle_frames
from azgym.logs.tables import Table

SPEED, TURN, RATE = 1.0, 0.2, 10.0  # a circle of 5 m radius, camera on the turning axis


def _files(frames: int = 300, *, scale: float = 1.0, stamps=None) -> dict[str, str]:
    """A drive round a circle with exact truth and odometry; times multiplied by ``scale``
    (1000: a logger's milliseconds) or the frames stamped ``stamps`` instead."""
    times = np.arange(frames) / RATE
    heading = TURN * times
    x = 5.0 + 5.0 * np.sin(heading)
    y = 5.0 - 5.0 * np.cos(heading)
    stamped = (times * scale).tolist() if stamps is None else [float(t) for t in stamps]
    x, y, heading = x.tolist(), y.tolist(), heading.tolist()
    lines = ["frame,time,x,y,heading"] + [
        f"{k},{stamped[k]!r},{x[k]!r},{y[k]!r},{math.remainder(heading[k], math.tau)!r}"
        for k in range(frames)]
    detections = ["frame,id,azimuth"]
    for k in range(frames):
        for number, bx, by in BEACONS:
            azimuth = math.atan2(by - y[k], bx - x[k]) - heading[k] \
                + 1e-3 * math.sin(7 * k + number)
            detections.append(f"{k},{number},{math.remainder(azimuth, math.tau)!r}")
    odometry = np.arange(0.0, times[-1], 0.02)
    wobble = 0.01 * np.sin(np.arange(odometry.size) * 1.3)
    return {
        "log.toml": MANIFEST_2,
        "beacons.csv": "id,x,y,z\n" + "".join(f"{i},{bx},{by},2.5\n" for i, bx, by in BEACONS),
        "frames.csv": "\n".join(lines) + "\n",
        "detections.csv": "\n".join(detections) + "\n",
        "odometry.csv": "time,speed,yaw_rate\n" + "".join(
            f"{t * scale!r},{SPEED + w!r},{TURN - w!r}\n"
            for t, w in zip(odometry.tolist(), wobble.tolist(), strict=True)),
    }


def _fits(tmp_path, files):
    calibration = calibrate(read_log(write_log(tmp_path / "log", files)))
    return {fit.name: fit for fit in calibration.fits}, dict(calibration.skipped)


def test_seconds_give_the_speed_factor(tmp_path):
    """The control: the same drive stamped in seconds fits the odometry's exact scale."""
    fits, _ = _fits(tmp_path, _files())
    assert fits["motion.speed_factor"].value == pytest.approx(1.0, abs=0.01)
    assert fits["motion.turn_rate_noise"].value < 0.05


def test_times_in_milliseconds_are_refused_before_any_fit(tmp_path):
    """Times in ms make the odometry read 1000 × the distance: the reader refuses the log."""
    with pytest.raises(LogError, match="gives 1000 times the distance the truth covers"):
        read_log(write_log(tmp_path / "log", _files(scale=1000.0)))


def test_a_speed_in_km_h_gives_no_speed_factor(tmp_path):
    """km/h make the odometry read 3.6 × the distance, within what the reader lets pass (a
    noisy odometry's): not written as a factor 1 / 3.6."""
    files = _files()
    rows = [line.split(",") for line in files["odometry.csv"].splitlines()]
    files["odometry.csv"] = "\n".join([",".join(rows[0])] + [
        ",".join([time, repr(float(speed) * 3.6), turn]) for time, speed, turn in rows[1:]]) + "\n"
    fits, skipped = _fits(tmp_path, files)
    assert "motion.speed_factor" not in fits
    assert "another unit" in skipped["motion.speed_factor"]
    assert "km/h" in skipped["motion.speed_factor"]


@pytest.mark.parametrize("stamps", [
    [3.0] * 300,  # a sequence whose frames all share one time
    [0.1 * (k // 2) for k in range(300)],  # every other frame repeats the time before
], ids=["one-time", "pairs"])
def test_frames_sharing_stamps_give_no_motion_fits(tmp_path, stamps):
    """A repeated stamp's frame is moved a microsecond on; the intervals beside it are no
    measure of speed (the old code fitted speed factors near 10⁵)."""
    fits, skipped = _fits(tmp_path, _files(stamps=stamps))
    for name in ("motion.speed_factor", "motion.turn_rate_noise", "vehicle.camera_ahead"):
        assert name not in fits, name
        assert "fewer than 10" in skipped[name]
    assert "sensor.delta_alpha_d" in fits  # the detections against the truth still hold


def test_a_log_of_one_block_gives_no_zero_width_interval(tmp_path):
    """3 s of frames are one 5 s bootstrap block: the spread is unknown, not zero."""
    fits, _ = _fits(tmp_path, _files(frames=30))
    for name in ("sensor.delta_alpha_d", "vehicle.camera_ahead"):
        assert fits[name].interval is None, name
        assert "no interval" in fits[name].method
        assert math.isfinite(fits[name].value)


def test_one_frame_says_why_nothing_is_fitted(tmp_path):
    _, skipped = _fits(tmp_path, _files(frames=1))
    assert skipped["vehicle.camera_ahead"] == "fewer than 10 usable frame intervals"
    assert "fewer than" in skipped["sensor.delta_alpha_d"]


@pytest.mark.parametrize("start", [0.0, 1.7e9, 1.7e12])
def test_nudged_marks_exactly_the_frames_settle_moved(start):
    time = start + np.array([0.0, 0.0, 0.0, 0.1, 0.2, 0.2, 0.3])
    table = Table("frames.csv", ["time"], [], list(range(2, 9)))
    notes: list[str] = []
    settled = settle_frames(table, time, notes)
    assert nudged(settled).tolist() == [False, True, True, False, False, True, False]
    assert not nudged(start + np.arange(5) * 1e-3).any()  # a 1000 Hz camera


@pytest.mark.parametrize(("header", "needle"), [
    ("time,speed,steer,yaw_rate", "both columns steer and yaw_rate"),
    ("time,speed", "neither column steer nor yaw_rate"),
])
def test_odometry_with_both_turns_or_neither_is_refused_by_name(tmp_path, header, needle):
    files = _files(frames=20)
    width = header.count(",")
    files["odometry.csv"] = header + "\n" + "".join(
        f"{0.1 * k!r}" + ",0.5" * width + "\n" for k in range(20))
    with pytest.raises(LogError, match=needle):
        read_log(write_log(tmp_path / "log", files))


def test_frames_overtaken_by_a_long_run_of_one_stamp_are_said():
    """A stuck clock's run pushes later, distinct stamps on: the note says so, not that they
    repeated the time before."""
    time = np.array([0.0, 0.0, 0.0, 1.5e-6, 0.1])
    table = Table("frames.csv", ["time"], [], list(range(2, 7)))
    notes: list[str] = []
    settled = settle_frames(table, time, notes)
    assert np.all(np.diff(settled) > 0) and settled[-1] == 0.1
    assert "1 of them (line 5) stamped later but overtaken" in notes[0]


def test_no_odometry_and_no_imu_is_said_as_such(tmp_path):
    files = _files()
    del files["odometry.csv"]
    _, skipped = _fits(tmp_path, files)
    assert skipped["motion.turn_rate_noise"] == "the log has no IMU and no odometry"


def test_a_static_recording_hands_no_contender_its_truth() -> None:
    """Roh's sequences are fixed positions: a start pose would be every frame's truth, so a
    tracker that holds it (dead reckoning) would score 0 cm. A log without motion has none."""
    from azgym.bench.suites.data import log_cases
    from azgym.logs import read_log

    cases = log_cases(read_log("roh"))
    assert all(case.initial is None for case in cases)
    assert all(case.motion is None for case in cases)


def test_a_huge_whole_camera_rate_is_named_not_a_crash(tmp_path) -> None:
    """camera.rate_hz = 10**400 is reported by field, not converted to a float (OverflowError)."""
    import shutil

    from azgym.logs import LogError, read_log
    from azgym.logs.read import shipped_logs

    folder = tmp_path / "roh"
    shutil.copytree(shipped_logs()["roh"], folder)
    manifest = folder / "log.toml"
    manifest.write_text(manifest.read_text().replace(
        "[camera]\n", "[camera]\nrate_hz = 1" + "0" * 400 + "\n"))
    with pytest.raises(LogError, match=r"camera.rate_hz: must be in \(0, 10000\) Hz, got 1000"):
        read_log(folder)
