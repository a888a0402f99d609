"""azgym import, and azgym bench --data refusing what it cannot score."""

from __future__ import annotations

from logs.mini_log import mini_files, write_log

from azgym.cli import main


def test_import_summarizes_a_log(mini_log, capsys):
    assert main(["import", str(mini_log)]) == 0
    out = capsys.readouterr().out
    assert "mini: SIMULATED data, log format 1" in out
    assert "frames: 3 over 0.200 s" in out and "10 detections" in out
    assert "1 frames without any" in out
    assert "ids not in the map: 1 detections; undecoded (negative ids): 1" in out
    assert "odometry: 2 samples (speed, steer)" in out  # the one after the last frame: trimmed
    assert "the reader changed (1):\n    odometry.csv: 1 sample(s) (line 4) after the last frame " \
        "(0.2 s) trimmed" in out


def test_import_lists_every_problem_and_exits_2(tmp_path, capsys):
    files = mini_files()
    files["frames.csv"] = files["frames.csv"].replace("1,0.1,", "1,abc,")
    files["imu.csv"] = files["imu.csv"].replace("0.15,", "0.01,")
    assert main(["import", str(write_log(tmp_path / "log", files))]) == 2
    err = capsys.readouterr().err
    assert "2 problems" in err and "frames.csv, line 3, column time" in err
    assert "imu.csv, line 3, column time" in err


def test_bench_data_refuses_a_log_without_truth(tmp_path, capsys):
    files = mini_files()
    files["frames.csv"] = "frame,time\n0,0.0\n1,0.1\n2,0.2\n"
    folder = write_log(tmp_path / "log", files)
    assert main(["bench", "--data", str(folder), "--out", str(tmp_path / "out")]) == 2
    assert "no truth" in capsys.readouterr().err


def test_bench_data_takes_no_suite(mini_log, tmp_path, capsys):
    assert main(["bench", "--data", str(mini_log), "--suite", "stress"]) == 2
    assert "takes no --suite" in capsys.readouterr().err
