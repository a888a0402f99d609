"""The TUM files of a run: the truth and each contender per sequence, named safely, read back."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from logs.mini_log import mini_files_2, write_log

from azgym.bench.report.results import BenchResult
from azgym.bench.report.trajectories import (
    MAX_STEM,
    TRAJECTORY_FILES,
    file_stem,
    trajectory_files,
)
from azgym.bench.run.runner import Contender, run_benchmark, run_log_benchmark
from azgym.bench.suites import get_suite
from azgym.bench.suites.base import Case
from azgym.errors import InvalidInputError
from azgym.files import claim_folder
from azgym.logs import read_log
from azgym.logs.problems import Problems
from azgym.logs.tum import parse_tum


@pytest.fixture(scope="module")
def routes(tmp_path_factory):
    """ransac and dead reckoning on warehouse-routes (quick), written."""
    out = tmp_path_factory.mktemp("tum") / "run"
    result = run_benchmark(get_suite("warehouse-routes"),
                           [Contender("ransac", "ransac"),
                            Contender("dead-reckoning", "dead-reckoning")], quick=True)
    result.write(out, figures=False)
    return out, result


def read_back(path, heading=True):
    problems = Problems(str(path.parent))
    trajectory = parse_tum(path.name, path.read_bytes(), problems, heading)
    problems.check()
    return trajectory


def test_each_sequence_has_the_truth_s_file_and_each_contender_s(routes):
    out, result = routes
    summary = json.loads((out / "results.json").read_text())
    where = summary["trajectories"]
    assert where["folders"] == {"truth": "truth", "ransac": "ransac",
                                "dead-reckoning": "dead-reckoning"}
    assert where["files"] == {"warehouse-small/aisle-loop": "warehouse-small_aisle-loop.tum",
                              "warehouse-paper/A-B-C-D": "warehouse-paper_A-B-C-D.tum"}
    written = sorted(path.relative_to(out).as_posix() for path in out.glob(TRAJECTORY_FILES))
    assert written == sorted(f"trajectories/{folder}/{file}" for folder in where["folders"]
                             .values() for file in where["files"].values())
    cases = result.cases
    for sequence, file in where["files"].items():
        frames = [k for k, case in enumerate(cases) if case.sequence == sequence]
        truth = read_back(out / "trajectories" / "truth" / file)
        # Every float reads back as written: the frame's time, its true pose.
        assert truth.time.tolist() == [cases[k].time for k in frames]
        assert truth.x.tolist() == [cases[k].pose[0] for k in frames]
        assert truth.y.tolist() == [cases[k].pose[1] for k in frames]
        assert np.abs(truth.heading - [cases[k].pose[2] for k in frames]).max() < 1e-12
        outcome = result.outcomes["ransac"]
        answered = [k for k in frames if outcome.ok[k]]
        record = summary["localizers"]["ransac"]["sequences"][sequence]
        assert (record["frames"], record["written"], record["refused"]) == \
            (len(frames), len(answered), len(frames) - len(answered))
        assert record["refused"] > 0
        estimate = read_back(out / "trajectories" / "ransac" / file)
        assert estimate.time.tolist() == [cases[k].time for k in answered]
        assert estimate.x.tolist() == outcome.estimate[answered, 0].tolist()
        text = (out / "trajectories" / "ransac" / file).read_text()
        assert text.startswith(f"# ransac on {sequence}: {record['refused']} refused frame(s) "
                               "left out\n# timestamp tx ty tz qx qy qz qw\n")


def test_a_frame_suite_writes_no_trajectory(tmp_path):
    result = run_benchmark(get_suite("stress"), [Contender("ransac", "ransac")], quick=True)
    written = result.write(tmp_path / "run", figures=False)
    assert result.summary["trajectories"] is None
    assert result.summary["localizers"]["ransac"]["sequences"] == {}
    assert not (tmp_path / "run" / "trajectories").exists()
    assert len(written) == 2


def test_a_position_only_truth_is_written_with_the_identity_orientation_and_said(tmp_path):
    files = mini_files_2()
    files["frames.csv"] = "\n".join(",".join(line.split(",")[:4])
                                    for line in files["frames.csv"].splitlines()) + "\n"
    log = read_log(write_log(tmp_path / "log", files))
    result = run_log_benchmark(log, [Contender("gated-ekf", "gated-ekf")])
    result.write(tmp_path / "run", figures=False)
    assert result.summary["trajectories"]["truth_heading"] is False
    truth = tmp_path / "run" / "trajectories" / "truth" / "mini2.tum"
    assert truth.read_text().startswith("# orientation: the identity (the truth has no heading")
    assert read_back(truth).heading.tolist() == [0.0, 0.0, 0.0]
    drift = result.summary["localizers"]["gated-ekf"]["drift"]
    assert all(math.isnan(record["translation_pct"]) for record in drift)


def test_a_name_s_file_keeps_letters_digits_dashes_and_underscores_only():
    assert file_stem("warehouse-small/aisle-loop") == "warehouse-small_aisle-loop"
    assert file_stem("ransac:max_iter=20") == "ransac_max_iter_20"
    assert file_stem("../../etc/passwd") == "______etc_passwd"
    assert file_stem("path/to/mine.py:Mine:tag=\"fast\"") == "path_to_mine_py_Mine_tag__fast_"
    long = file_stem("x" * 300)
    assert len(long) == MAX_STEM and long != file_stem("x" * 299)


def frames_of(*sequences):
    return [Case("s", None, (0.0, 0.0, 0.0), "clean", name, sequence=name, time=0.0)
            for name in sequences]


@pytest.mark.parametrize(("labels", "sequences", "message"), [
    (["ransac:a=1", "ransac_a_1"], ["r"], "the contender 'ransac:a=1' and the contender "
                                          "'ransac_a_1' would both be written as 'ransac_a_1'"),
    (["Mine.py:A", "mine.py:A"], ["r"], "would both be written as 'mine_py_A'"),
    (["truth"], ["r"], "the truth and the contender 'truth' would both be written as 'truth'"),
    (["ransac"], ["a/b", "a_b"], "the sequence 'a/b' and the sequence 'a_b' would both be "
                                 "written as 'a_b.tum'"),
])
def test_two_names_that_would_share_a_file_are_refused(labels, sequences, message):
    with pytest.raises(InvalidInputError, match=message.replace("(", r"\(").replace(".", r"\.")):
        trajectory_files(labels, frames_of(*sequences))


def test_bench_claims_the_tum_files_of_a_previous_run(routes):
    # azgym bench checks --out before a run: its TUM files are among the files it writes.
    from azgym.cli.bench import BENCH_FILES

    out, _ = routes
    assert TRAJECTORY_FILES in BENCH_FILES
    with pytest.raises(InvalidInputError, match="truth/warehouse-paper_A-B-C-D.tum"):
        claim_folder(out, [TRAJECTORY_FILES], False, "--out")


def test_the_results_name_the_trajectories_written(routes):
    out, result = routes
    assert isinstance(result, BenchResult)
    assert (out / "trajectories") in result.write(out, figures=False)
