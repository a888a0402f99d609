"""Log format 2: profiles, turning odometry, position-only truth, and real loggers' clocks."""

from __future__ import annotations

import csv
import dataclasses
import json
import math

import numpy as np
import pytest
from logs.mini_log import MANIFEST_2, mini_files, mini_files_2, write_log

from azgym.bench.suites.data import log_cases
from azgym.cli import main
from azgym.logs import LogError, export_route, read_log
from azgym.logs import export as export_module
from azgym.sensing.motion import OdometrySamples
from azgym.sensing.protocol import Observation


def _read(tmp_path, files):
    return read_log(write_log(tmp_path / "log", files))


def test_format_2_reads_the_profile_a_turning_odometry_and_an_imu_without_accelerations(
        tmp_path):
    log = _read(tmp_path, mini_files_2())
    assert log.manifest.format == 2
    assert log.manifest.profile.hyperparameters() == {
        "vehicle": "differential-drive", "camera_ahead": 0.1, "delta_alpha_d": 0.01,
        "field_of_view": 6.0}
    cases = log_cases(log)
    assert [c.frame for c in cases] == [10, 12, 13]  # the log's frame numbers
    odometry = cases[2].motion.odometry
    assert odometry.reports_yaw_rate and odometry.yaw_rate.tolist() == [0.5]
    assert np.isnan(odometry.steer).all()
    assert cases[2].motion.imu.accel.shape == (1, 2) and np.isnan(cases[2].motion.imu.accel).all()


def test_a_format_1_log_reads_as_before(mini_log):
    log = read_log(mini_log)
    assert log.manifest.format == 1 and log.manifest.profile.empty and log.has_heading
    cases = log_cases(log)
    assert [c.frame for c in cases] == [0, 1, 2]
    assert not cases[1].motion.odometry.reports_yaw_rate
    assert cases[1].motion.odometry.steer.tolist() == [0.0]
    assert cases[1].motion.imu.accel.tolist() == [[0.1, 0.0]]


def _manifest(old, new):
    def change(files):
        assert old in files["log.toml"], old
        files["log.toml"] = files["log.toml"].replace(old, new, 1)
    return change


def _table(name, content):
    def change(files):
        files[name] = content
    return change


_CLOCKWISE = "\n".join(
    [mini_files_2()["detections.csv"].splitlines()[0],
     *(",".join([*row[:2], repr(-float(row[2])), *row[3:]]) for row in (
         line.split(",") for line in mini_files_2()["detections.csv"].splitlines()[1:]))]) + "\n"
MALFORMED_2 = {
    "sensor huge": (_manifest("delta_alpha_d = 0.01", "delta_alpha_d = 1e300"),
                    r"log.toml: sensor.delta_alpha_d: must be in \[0, 1.5708\) rad, got 1e\+300"),
    "sensor not a number": (_manifest("field_of_view = 6.0", 'field_of_view = "wide"'),
                            r"log.toml: sensor.field_of_view: must be a finite number \[rad\], got "
                            r"'wide'"),
    "sensor negative": (_manifest("delta_alpha_d = 0.01", "delta_alpha_d = -0.01"),
                        r"sensor.delta_alpha_d: must be in \[0, 1.5708\) rad, got -0.01"),
    "sensor typo": (_manifest("field_of_view", "field_of_veiw"),
                    r"log.toml: sensor: unknown key 'field_of_veiw'"),
    "sensor not a table": (lambda f: f.update({"log.toml": MANIFEST_2.replace(
        "[sensor]\ndelta_alpha_d = 0.01\nfield_of_view = 6.0\n", "").replace(
        "simulated = true\n", 'simulated = true\nsensor = "fisheye"\n')}),
                           r"log.toml: sensor: must be a table"),
    "vehicle unknown": (_manifest('kind = "differential-drive"', 'kind = "tank"'),
                        r"log.toml: vehicle.kind: must be one of 'forklift', "
                        r"'differential-drive', got 'tank'"),
    "steer on a differential drive": (
        _table("odometry.csv", "time,speed,steer\n0.05,1.0,0.0\n"),
        r"odometry.csv, column steer: column steer, but log.toml says vehicle.kind = "
        r"'differential-drive': a differential drive has no steering angle"),
    "both turn columns": (_table("odometry.csv", "time,speed,steer,yaw_rate\n0.05,1,0,0\n"),
                          r"odometry.csv: both columns steer and yaw_rate: odometry reports "
                          r"exactly one"),
    "no turn column": (_table("odometry.csv", "time,speed\n0.05,1\n"),
                       r"odometry.csv: neither column steer nor yaw_rate"),
    "one acceleration": (_table("imu.csv", "time,yaw_rate,ay\n0.05,0,0\n"),
                         r"imu.csv: column ay without ax \(give both accelerations or neither\)"),
    "turn rate in degrees": (_table("odometry.csv", "time,speed,yaw_rate\n0.05,1,45.0\n"),
                             r"odometry.csv, line 2, column yaw_rate: 45.0 is outside \[-20, 20\] "
                             r"\(rad/s; degrees per second\?\)"),
    "heading without position": (_table("frames.csv", "frame,time,heading\n10,0,0\n"),
                                 r"frames.csv: truth partly present: columns heading without x, "
                                 r"y \(give x and y, and optionally heading"),
    "position-only truth, azimuths clockwise": (
        lambda f: f.update({"frames.csv": "frame,time,x,y\n10,0.0,5.0,5.0\n12,0.1,5.1,5.0\n"
                                          "13,0.2,5.2,5.0\n", "detections.csv": _CLOCKWISE}),
        r"detections.csv, column azimuth: the azimuths disagree with the truth: .* over 8 "
        r"detections .* \(measured clockwise, in degrees, or scaled\?\)"),
    "epoch time running back": (
        _table("odometry.csv", "time,speed,yaw_rate\n1248440000.2,1,0\n1248440000.1,1,0\n"),
        r"odometry.csv, line 3, column time: 1248440000.1 is less than the row before's "
        r"1248440000.2 \(a clock never runs back\)"),
}


@pytest.mark.parametrize("case", MALFORMED_2, ids=list(MALFORMED_2))
def test_each_malformed_format_2_log_is_refused_naming_its_problem(tmp_path, case):
    change, message = MALFORMED_2[case]
    files = mini_files_2()
    change(files)
    with pytest.raises(LogError, match=message):
        _read(tmp_path, files)


def test_position_only_truth_reads_with_no_heading_and_no_start_pose(tmp_path):
    files = mini_files_2()
    files["frames.csv"] = "frame,time,x,y\n10,0.0,5.0,5.0\n12,0.1,5.1,5.0\n13,0.2,5.2,5.0\n"
    log = _read(tmp_path, files)
    assert log.has_truth and not log.has_heading
    cases = log_cases(log)
    assert cases[1].pose[:2] == (5.1, 5.0) and math.isnan(cases[1].pose[2])
    assert cases[0].initial is None  # a tracker refuses a start without a heading
    files = mini_files()  # format 1 keeps the all-or-nothing truth
    files["frames.csv"] = "frame,time,x,y\n0,0.0,5.0,5.0\n1,0.1,5.1,5.0\n2,0.2,5.2,5.0\n"
    with pytest.raises(LogError, match=r"truth partly present: columns x, y without heading"):
        _read(tmp_path / "1", files)


@pytest.mark.slow
def test_position_only_truth_is_scored_on_position_and_keeps_the_frame_numbers(
        tmp_path, capsys):
    files = mini_files_2()
    files["frames.csv"] = "frame,time,x,y\n10,0.0,5.0,5.0\n12,0.1,5.1,5.0\n13,0.2,5.2,5.0\n"
    out = tmp_path / "out"
    assert main(["bench", "--data", str(write_log(tmp_path / "log", files)), "--localizer",
                 "ransac", "--workers", "1", "--out", str(out)]) == 0
    assert "position-only truth: heading not scored" in capsys.readouterr().out
    stats = json.loads((out / "results.json").read_text())["localizers"]["ransac"]["all"]
    assert stats["heading_median_deg"] is None and stats["median_cm"] < 1.0
    rows = list(csv.DictReader((out / "frames.csv").open()))
    assert [row["frame"] for row in rows] == ["10", "12", "13"]
    assert [row["ok"] for row in rows] == ["1", "1", "0"]  # frame 13 has no detection
    assert rows[0]["heading_error_rad"] == "nan"


# Clocks as real loggers write them: settled with a note, never refused.

def test_motion_before_the_first_frame_is_used_and_long_before_it_trimmed(tmp_path):
    files = mini_files_2()
    files["odometry.csv"] = "time,speed,yaw_rate\n-8.0,0.0,0.0\n-3.0,0.5,0.0\n0.05,1.0,0.0\n"
    log = _read(tmp_path, files)
    assert log.notes == ("odometry.csv: 1 sample(s) (line 2) more than 5 s before the first "
                         "frame (0.0 s) trimmed",)
    cases = log_cases(log)
    assert cases[0].motion.odometry.time.tolist() == [-3.0]  # the first frame takes it
    assert cases[1].motion.odometry.time.tolist() == [0.05]


def test_motion_long_before_a_later_sequence_is_trimmed_naming_the_sequence(tmp_path):
    files = mini_files_2()
    files["frames.csv"] = ("frame,time,x,y,heading,sequence\n10,0.0,5.0,5.0,0.0,a\n"
                           "12,20.0,5.1,5.0,0.1,b\n13,20.1,5.2,5.0,0.2,b\n")
    files["odometry.csv"] = "time,speed,yaw_rate\n10.0,1,0\n17.0,1,0\n20.05,1,0\n"
    files["imu.csv"] = "time,yaw_rate\n19.0,0.0\n"
    log = _read(tmp_path, files)
    assert log.notes == ("odometry.csv: 1 sample(s) (line 2) more than 5 s before the first "
                         "frame of sequence 'b' (20.0 s) trimmed",)
    assert [c.motion.odometry.time.tolist() for c in log_cases(log)] == [[], [17.0], [20.05]]


def test_repeated_time_stamps_are_merged_into_their_mean(tmp_path):
    files = mini_files_2()
    files["odometry.csv"] = ("time,speed,yaw_rate\n0.05,1.0,0.0\n0.05,3.0,0.2\n0.05,2.0,0.1\n"
                             "0.15,1.0,0.5\n")
    files["imu.csv"] = "time,yaw_rate,heading\n0.05,0.0,3.1\n0.05,0.2,-3.1\n0.15,0.0,\n"
    log = _read(tmp_path, files)
    assert log.notes == (
        "odometry.csv: 1 time stamp(s) repeated (lines 2-4, 3 rows): the rows of each merged "
        "into one sample, their mean",
        "imu.csv: 1 time stamp(s) repeated (lines 2-3, 2 rows): the rows of each merged into "
        "one sample, their mean")
    odometry = log_cases(log)[1].motion.odometry
    assert odometry.time.tolist() == [0.05] and odometry.speed.tolist() == [2.0]
    assert odometry.yaw_rate[0] == pytest.approx(0.1)
    imu = log_cases(log)[1].motion.imu
    assert imu.yaw_rate[0] == pytest.approx(0.1)
    assert abs(abs(imu.heading[0]) - math.pi) < 1e-12  # the circular mean, not 0


def test_a_repeated_frame_time_is_moved_just_after_the_frame_before(tmp_path):
    files = mini_files_2()
    files["frames.csv"] = files["frames.csv"].replace("13,0.2", "13,0.1")
    files["odometry.csv"] = "time,speed,yaw_rate\n0.05,1.0,0.0\n0.1,1.0,0.5\n"
    files["imu.csv"] = "time,yaw_rate\n0.05,0.0\n"
    log = _read(tmp_path, files)
    assert log.notes == ("frames.csv: 1 frame(s) (line 4) had the time of the frame before: "
                         "each moved 1e-06 s after it (frame times must increase; the first "
                         "from 0.1 s to 0.100001 s)",)
    cases = log_cases(log)
    assert [c.time for c in cases] == [0.0, 0.1, 0.1 + 1e-6]
    assert [c.frame for c in cases] == [10, 12, 13]  # both frames kept, each scored
    assert cases[1].motion.odometry.time.tolist() == [0.05, 0.1]


def test_epoch_times_are_printed_in_full_and_jitter_is_left_alone(tmp_path, capsys):
    files = mini_files_2()
    files["frames.csv"] = "".join(
        [files["frames.csv"].splitlines(keepends=True)[0], "10,1248440000.123,5.0,5.0,0.0\n",
         "12,1248440000.223,5.1,5.0,0.1\n", "13,1248440000.323,5.2,5.0,0.2\n"])
    files["odometry.csv"] = ("time,speed,yaw_rate\n1248440000.125,1,0\n1248440000.131,1,0\n"
                             "1248440000.171,1,0\n1248440000.173,1,0\n1248440000.4,1,0\n")
    files["imu.csv"] = "time,yaw_rate\n1248440000.2,0.0\n"
    folder = write_log(tmp_path / "log", files)
    assert read_log(folder).notes == (
        "odometry.csv: 1 sample(s) (line 6) after the last frame (1248440000.323 s) trimmed",)
    assert main(["import", str(folder)]) == 0
    out = capsys.readouterr().out
    assert "from 1248440000.123 s" in out and "1248440000.323 s) trimmed" in out
    assert "e+09" not in out


def test_an_exported_route_is_format_2_and_writes_a_turn_rate_odometry(tmp_path, monkeypatch):
    simulate, driven = export_module.simulate, []

    def turning(*args, **kwargs):  # a vehicle whose odometry reports its turn rate
        for k, frame in enumerate(simulate(*args, **kwargs)):
            o = frame.odometry
            driven.append(OdometrySamples.turning(o.time, o.speed, 0.5 * o.steer))
            seen = frame.observation  # frame 3 sees nothing
            blind = Observation(seen.measured[:, :0], seen.true[:, :0], seen.ints[:, :0])
            yield dataclasses.replace(frame, odometry=driven[-1],
                                      observation=blind if k == 3 else seen)

    monkeypatch.setattr(export_module, "simulate", turning)
    export_route("warehouse-small", "pick-and-back", 0, tmp_path / "log", motion_rate_hz=20.0)
    assert (tmp_path / "log" / "odometry.csv").read_text().startswith("time,speed,yaw_rate\n")
    log = read_log(tmp_path / "log")
    assert log.manifest.format == 2 and log.notes == ()
    cases = log_cases(log)
    assert len(cases[3].measurements) == 0 < len(cases[4].measurements)  # a frame seeing none
    odometry = [c.motion.odometry for c in cases]
    assert all(o.reports_yaw_rate for o in odometry if o.time.size)
    for key in ("time", "speed", "yaw_rate"):  # written by repr: read back bit for bit
        assert np.array_equal(np.concatenate([getattr(o, key) for o in odometry]),
                              np.concatenate([getattr(o, key) for o in driven]))
