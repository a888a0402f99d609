"""TUM files: written as evo reads them, read back exactly, and a log's truth taken from one."""

from __future__ import annotations

import math
import shutil

import numpy as np
import pytest

from azgym.bench.run.runner import Contender, run_log_benchmark
from azgym.cli import main
from azgym.logs import read_log
from azgym.logs.problems import LogError, Problems
from azgym.logs.read import shipped_logs
from azgym.logs.tum import parse_tum, tum_text

SHIPPED = "warehouse-small-simulated"


def test_written_poses_read_back_as_the_very_floats_and_the_heading_as_its_yaw():
    rng = np.random.default_rng(0)
    time = np.cumsum(rng.uniform(0.01, 0.2, 50)) + 1.7e9  # epoch times keep every digit
    x, y = rng.normal(0, 30, (2, 50))
    heading = rng.uniform(-math.pi, math.pi, 50)
    text = tum_text(time, x, y, heading, note="a\nnote")
    assert text.splitlines()[:2] == ["# a note", "# timestamp tx ty tz qx qy qz qw"]
    problems = Problems("here")
    poses = parse_tum("t.tum", text.encode(), problems, heading=True)
    assert not problems
    assert poses.time.tolist() == time.tolist() and poses.x.tolist() == x.tolist()
    assert poses.y.tolist() == y.tolist()
    assert np.abs(poses.heading - heading).max() < 1e-15
    assert poses.lines == tuple(range(3, 53))
    identity = parse_tum("t.tum", tum_text(time, x, y).encode(), problems, heading=True)
    assert identity.heading.tolist() == [0.0] * 50
    assert parse_tum("t.tum", text.encode(), problems, heading=False).heading is None


def tum_log(tmp_path, heading=True, every=1, max_gap=None):
    """The shipped simulated log in format 2 with its truth moved to truth.tum (every
    ``every``-th frame's pose as a sample)."""
    folder = tmp_path / "log"
    shutil.copytree(shipped_logs()[SHIPPED], folder)
    frames = (folder / "frames.csv").read_text().splitlines()
    rows = [line.split(",") for line in frames[1:]]
    (folder / "frames.csv").write_text("frame,time\n" + "".join(
        f"{row[0]},{row[1]}\n" for row in rows))
    samples = np.array([[float(v) for v in row[1:5]] for row in rows])
    samples = samples[sorted({*range(0, len(samples), every), len(samples) - 1})]
    (folder / "truth.tum").write_text(tum_text(*samples.T))
    manifest = (folder / "log.toml").read_text().replace("format = 1", "format = 2")
    gap = "" if max_gap is None else f"\nmax_gap = {max_gap}"
    (folder / "log.toml").write_text(manifest + f'file = "truth.tum"\nheading = '
                                                f'{str(heading).lower()}{gap}\n')
    return folder


def test_a_log_s_truth_from_a_tum_file_at_the_frames_times_is_the_truth_it_was(tmp_path):
    original = read_log(SHIPPED)
    log = read_log(tum_log(tmp_path))
    assert log.frames["x"].tolist() == original.frames["x"].tolist()
    assert log.frames["y"].tolist() == original.frames["y"].tolist()
    assert np.abs(log.frames["heading"] - original.frames["heading"]).max() < 1e-12
    assert log.sha256 != original.sha256
    before = run_log_benchmark(original, [Contender("gated-ekf", "gated-ekf")]).outcomes
    after = run_log_benchmark(log, [Contender("gated-ekf", "gated-ekf")]).outcomes
    for label in before:  # gated-ekf, and ransac (the runtime reference)
        assert after[label].ok.tolist() == before[label].ok.tolist()
        np.testing.assert_allclose(after[label].position, before[label].position, rtol=0,
                                   atol=1e-12)


def test_frames_between_samples_get_the_interpolated_truth_and_position_only_none(tmp_path):
    original = read_log(SHIPPED)
    log = read_log(tum_log(tmp_path, heading=False, every=3))
    assert not log.has_heading and log.has_truth
    error = np.hypot(log.frames["x"] - original.frames["x"],
                     log.frames["y"] - original.frames["y"])
    assert error[::3].max() == 0.0  # a frame at a sample's time: that sample, bit for bit
    assert 0 < error.max() < 0.02  # between: linear over 0.3 s of speeding up and turning


def test_the_truth_file_is_part_of_the_log_s_digest(tmp_path):
    folder = tum_log(tmp_path)
    digest = read_log(folder).sha256
    lines = (folder / "truth.tum").read_text().splitlines()
    lines[5] = lines[5].replace(" 0.0 0.0 0.0 ", " 0.5 0.0 0.0 ", 1)  # tz: not read, but hashed
    (folder / "truth.tum").write_text("\n".join(lines) + "\n")
    assert read_log(folder).sha256 != digest


@pytest.mark.parametrize("gap", [0.05, 0.25])
def test_max_gap_says_how_far_apart_samples_may_be_interpolated(tmp_path, gap):
    folder = tum_log(tmp_path, every=3, max_gap=gap)
    if gap < 0.3:
        with pytest.raises(LogError, match=r"truth.tum: frame 1 \(time 0.1 s\) lies in a "
                                            r"0.300 s gap between truth samples 0 and 1"):
            read_log(folder)
    else:
        read_log(folder)


def test_azgym_import_accepts_a_log_whose_truth_is_a_tum_file(tmp_path, capsys):
    assert main(["import", str(tum_log(tmp_path, heading=False, every=2))]) == 0
    assert "truth: x, y on every frame (position only: heading not scored)" in \
        capsys.readouterr().out


@pytest.mark.parametrize("style", ["evo", "crlf", "tabs", "bom and comments"])
def test_a_truth_file_as_evo_and_other_tools_write_it_is_read(tmp_path, style):
    from evo.core.trajectory import PoseTrajectory3D
    from evo.tools import file_interface

    folder = tum_log(tmp_path)
    ours = parse_tum("t", (folder / "truth.tum").read_bytes(), Problems("t"), heading=True)
    half = ours.heading / 2  # evo writes '%.18e' (scientific notation), qw last
    file_interface.write_tum_trajectory_file(str(folder / "truth.tum"), PoseTrajectory3D(
        np.column_stack([ours.x, ours.y, np.zeros_like(ours.x)]),
        np.column_stack([np.cos(half), 0 * half, 0 * half, np.sin(half)]), ours.time))
    data = (folder / "truth.tum").read_bytes()
    assert b"e+00" in data
    data = {"evo": data, "crlf": data.replace(b"\n", b"\r\n"), "tabs": data.replace(b" ", b"\t"),
            "bom and comments": b"\xef\xbb\xbf# evo_traj\n\n" + data.replace(b"\n", b"\n# -\n", 3)
            }[style]
    (folder / "truth.tum").write_bytes(data)
    original = read_log(SHIPPED)
    log = read_log(folder)
    assert log.frames["x"].tolist() == original.frames["x"].tolist()
    assert np.abs(log.frames["heading"] - original.frames["heading"]).max() < 1e-12
