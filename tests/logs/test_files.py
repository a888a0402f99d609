"""A log's files read safely: no symlink or folder taken for a table, byte and cell limits, a
Parquet table's size checked from its metadata, and one bad cell giving one problem."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
from logs.mini_log import mini_files, write_log

from azgym.logs import LogError, read_log
from azgym.logs import tables as T
from azgym.logs.files import read_limited
from azgym.logs.problems import Problems


def _log(tmp_path, **changes) -> Path:
    files = mini_files()
    for name, content in changes.items():
        if content is None:
            del files[name.replace("_", ".")]
        else:
            files[name.replace("_", ".")] = content
    return write_log(tmp_path / "log", files)


@pytest.mark.parametrize("target", ["/etc/passwd", "/proc/self/status", "../elsewhere.csv"])
def test_a_map_or_table_that_is_a_symlink_is_refused(tmp_path, target):
    folder = _log(tmp_path, beacons_csv=None, imu_csv=None)
    (tmp_path / "elsewhere.csv").write_text("id,x,y\n1,0,0\n")
    os.symlink(target, folder / "beacons.csv")
    os.symlink(target, folder / "imu.csv")
    with pytest.raises(LogError) as caught:
        read_log(folder)
    assert caught.value.problems == [
        "log.toml: 'beacons.csv' is not a file in the log's folder (a symlink or a path "
        "elsewhere: copy the file into the folder)",
        "imu.csv: 'imu.csv' is not a file in the log's folder (a symlink or a path elsewhere: "
        "copy the file into the folder)"]
    assert "root:" not in str(caught.value)


def test_a_folder_named_like_a_table_is_reported(tmp_path):
    folder = _log(tmp_path, imu_csv=None)
    (folder / "imu.csv").mkdir()
    with pytest.raises(LogError, match=r"imu.csv: 'imu.csv' is not a file in the log's folder "
                                       r"\(a folder\)"):
        read_log(folder)


def test_a_file_is_read_with_a_byte_limit_whatever_its_size_on_disk_says():
    problems = Problems("log")
    assert Path("/proc/self/status").stat().st_size == 0
    assert read_limited(Path("/proc/self/status"), problems, limit=10) is None
    assert problems.found == ["status: too large: more than 10 bytes, a log's table has at most "
                              "10 (split the recording into several logs)"]


def test_a_csv_table_stops_at_the_cell_limit(tmp_path, monkeypatch):
    """The header's four cells count: 4 + 4 × 4 rows reach 20, the fifth row passes it."""
    monkeypatch.setattr(T, "MAX_TABLE_CELLS", 20)
    with pytest.raises(LogError, match=r"detections.csv, line 6: too many cells: more than 20 "
                                       r"\(rows × columns\) by this line"):
        read_log(_log(tmp_path))


def test_one_bad_frame_number_is_one_problem(tmp_path):
    folder = _log(tmp_path, frames_csv="frame,time,x,y,heading\n0,0.0,5.0,5.0,0.0\n"
                                       "x,0.1,5.1,5.0,0.1\n2,0.2,5.2,5.0,0.2\n")
    with pytest.raises(LogError) as caught:
        read_log(folder)
    frames = [p for p in caught.value.problems if p.startswith("frames.csv")]
    assert frames == ["frames.csv, line 3, column frame: 'x' is not a whole number"]


def _parquet_log(tmp_path, table) -> Path:
    pq = pytest.importorskip("pyarrow.parquet")
    folder = _log(tmp_path, odometry_csv=None)
    pq.write_table(table, folder / "odometry.parquet", compression="zstd")
    return folder


def test_a_parquet_bomb_is_refused_from_its_metadata_before_it_is_read(tmp_path, monkeypatch):
    pa = pytest.importorskip("pyarrow")
    zeros = np.zeros(1_400_000)
    folder = _parquet_log(tmp_path, pa.table({"time": zeros, "speed": zeros, "steer": zeros}))
    assert (folder / "odometry.parquet").stat().st_size < 100_000
    monkeypatch.setattr(pa.parquet.ParquetFile, "read", lambda *_a, **_k: pytest.fail("read"))
    with pytest.raises(LogError, match=r"odometry.parquet: too many cells: 1400000 rows × 3 "
                                       r"columns, a log's table has at most 4000000"):
        read_log(folder)


@pytest.mark.parametrize(("column", "message"), [
    ([1.0, float("nan")], r"odometry.parquet, row 2, column speed: 'nan' is not finite"),
    ("timestamp", r"odometry.parquet, column speed: type timestamp\[ns\] is neither numbers "
                  r"nor text"),
])
def test_parquet_values_are_named_for_what_they_are(tmp_path, column, message):
    pa = pytest.importorskip("pyarrow")
    speed = pa.array([1, 2], type=pa.timestamp("ns")) if column == "timestamp" else column
    folder = _parquet_log(tmp_path, pa.table({"time": [0.05, 0.15], "speed": speed,
                                              "steer": [0.0, 0.0]}))
    with pytest.raises(LogError, match=message):
        read_log(folder)
