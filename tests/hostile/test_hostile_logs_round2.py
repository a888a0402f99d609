"""A hostile log's second round: a header wide enough to hang the reader, a Parquet dictionary
bomb, and times in milliseconds without ``camera.rate_hz``. Each is refused by name, in bounded
time and memory: the attacks run in a subprocess with a timeout and an address-space limit, so
that a regression fails instead of hanging or exhausting the machine."""

from __future__ import annotations

import csv
import re
import shutil
from pathlib import Path

import pytest
from helpers import bounded_outcome
from logs.mini_log import mini_files, write_log

from azgym.logs import LogError, read_log
from azgym.logs.read import shipped_logs

MEMORY_MB = 3000
"""The address space an attack runs in [MB]: azgym with pyarrow loaded, and room to spare."""
SECONDS = 60
"""The time an attack gets (the old reader took minutes on the wide header)."""


def _refusal(code: str) -> str:
    """Run ``code`` bounded; the type and message of what it raises."""
    return bounded_outcome(code, memory_bytes=MEMORY_MB << 20, seconds=SECONDS)


def _simulated(tmp_path: Path) -> Path:
    folder = tmp_path / "log"
    shutil.copytree(shipped_logs()["warehouse-small-simulated"], folder)
    return folder


def test_a_wide_header_is_refused_at_once(tmp_path):
    """A 1.5 MB header (200 000 columns): the old repeated-column check took minutes."""
    folder = _simulated(tmp_path)
    (folder / "odometry.csv").write_text(",".join(f"c{k}" for k in range(200_000)) + "\n")
    out = _refusal(f"from azgym.logs import read_log\nread_log({str(folder)!r})")
    assert "LogError" in out
    assert "odometry.csv: too many columns: the header names 200000, a log's table has at " \
           "most 100" in out


def test_a_wide_header_counts_against_the_cell_limit(tmp_path, monkeypatch):
    import azgym.logs.tables as T

    monkeypatch.setattr(T, "MAX_TABLE_CELLS", 3)
    folder = _simulated(tmp_path)
    with pytest.raises(LogError, match=r"odometry.csv, line 2: too many cells"):
        read_log(folder)  # odometry.csv's header names 3 columns: its first row passes 3 cells


def test_a_changed_dataset_is_refused_by_its_digest_before_it_is_parsed(tmp_path):
    """The log of a dataset entry, its detections.csv replaced by a wide header: refused as
    changed (its SHA-256), not read first (which hung the board's build)."""
    from azgym.bench.leaderboard import entries as L
    from azgym.bench.run.runner import Contender, run_log_benchmark

    log = write_log(tmp_path / "mini", mini_files())
    run_log_benchmark(read_log(log), [Contender("lsq", "lsq")]).write(tmp_path / "results")
    shutil.copytree(log, tmp_path / "datasets" / "mini")
    entry = L.submit(tmp_path / "results", "lsq", tmp_path / "entries", name="lsq-data-mini",
                     version="1", authors=["A. Author"])
    (tmp_path / "datasets" / "mini" / "detections.csv").write_text(
        ",".join(["frame"] * 200_000) + "\n")
    out = _refusal(f"""
        from azgym.bench.leaderboard import entries as L
        L.load_entry(__import__("pathlib").Path({str(entry)!r}))
        """)
    assert "LeaderboardError" in out
    assert re.search(r"dataset/sha256: the log \S*mini changed since the entry was made", out)


def test_a_parquet_dictionary_bomb_is_refused_within_bounded_memory(tmp_path):
    """11 kB whose million rows each decode to an 8.5 kB string (8.5 GB): the footer says
    8 MB, so the old size check passed it, and decoding ended in a MemoryError."""
    pa = pytest.importorskip("pyarrow")
    pq = pytest.importorskip("pyarrow.parquet")
    folder = _simulated(tmp_path)
    (folder / "odometry.csv").unlink()
    rows = 1_000_000
    speed = pa.DictionaryArray.from_arrays(pa.array([0] * rows, pa.int32()),
                                           pa.array(["1" * 8500]))
    table = pa.table({"time": pa.array([0.0] * rows), "speed": speed,
                      "steer": pa.array([0.0] * rows)})
    pq.write_table(table, folder / "odometry.parquet", store_schema=False, compression="zstd")
    assert (folder / "odometry.parquet").stat().st_size < 100_000
    out = _refusal(f"from azgym.logs import read_log\nread_log({str(folder)!r})")
    assert "LogError" in out
    assert "odometry.parquet: too large: its text decodes to more than 67108864 bytes" in out


def _scaled(folder: Path, factor: float) -> Path:
    """The log with every table's times multiplied by ``factor`` and no ``camera.rate_hz``."""
    for name in ("frames.csv", "odometry.csv", "imu.csv"):
        with (folder / name).open(newline="") as file:
            rows = list(csv.reader(file))
        column = rows[0].index("time")
        for row in rows[1:]:
            row[column] = repr(float(row[column]) * factor)
        (folder / name).write_text("".join(",".join(row) + "\n" for row in rows))
    manifest = folder / "log.toml"
    manifest.write_text(re.sub(r"rate_hz *=.*\n", "", manifest.read_text()))
    return folder


@pytest.mark.parametrize(("factor", "shown"), [(1000.0, "1003 times"), (1 / 60, "0.01672 times")],
                         ids=["milliseconds", "minutes"])
def test_times_in_another_unit_are_refused_without_a_camera_rate(tmp_path, factor, shown):
    """Scored, such a log put gated-ekf's p75 at 1 383 m; the truth's own speed tells."""
    folder = _scaled(_simulated(tmp_path), factor)
    with pytest.raises(LogError) as caught:
        read_log(folder)
    message = str(caught.value)
    assert f"frames.csv, column time: odometry.csv's speed, integrated over the tables' times, " \
           f"gives {shown} the distance the truth covers" in message
    assert "imu.csv's yaw_rate" in message and "not milliseconds or minutes" in message


def test_the_same_log_in_seconds_reads(tmp_path):
    assert len(read_log(_scaled(_simulated(tmp_path), 1.0)).frames["time"]) == 246
