"""evo, given the TUM files ``azgym bench`` writes, reproduces azgym's RMSE and drift figures.

ransac and gated-ekf on warehouse-routes (quick: two routes, 268 frames, ransac refusing 36 of
them) through the command; then, per route and pooled, what ``evo_ape tum TRUTH EST`` (the
translation part, no alignment) and ``evo_rpe tum TRUTH EST --delta D --delta_unit m
--all_pairs --pairs_from_reference`` compute, through evo's own functions, and once through
the real ``evo_ape`` command.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from contextlib import redirect_stdout
from io import StringIO

import numpy as np
import pytest
from evo.core import metrics as evo_metrics
from evo.core.sync import associate_trajectories
from evo.main_ape import ape
from evo.main_rpe import rpe
from evo.tools.file_interface import read_tum_trajectory_file

from azgym import cli

CONTENDERS = ("ransac", "gated-ekf")


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """The bench's output folder, results.json and what it printed."""
    out = tmp_path_factory.mktemp("evo") / "run"
    argv = ["bench", "--suite", "warehouse-routes", "--quick", "--workers", "1", "--out",
            str(out)]
    for spec in CONTENDERS:
        argv += ["--localizer", spec]
    printed = StringIO()
    with redirect_stdout(printed):
        assert cli.main(argv) == 0
    return out, json.loads((out / "results.json").read_text()), printed.getvalue()


def files(out, summary, label, sequence):
    """The truth's and the contender's TUM files of a sequence."""
    where = summary["trajectories"]
    name = where["files"][sequence]
    return (out / where["folder"] / where["folders"]["truth"] / name,
            out / where["folder"] / where["folders"][label] / name)


def associated(truth_file, estimate_file):
    """The two files as evo reads and associates them (its default 10 ms)."""
    return associate_trajectories(read_tum_trajectory_file(truth_file),
                                  read_tum_trajectory_file(estimate_file))


def test_evo_ape_gives_azgym_s_rmse_per_route_and_pooled(run):
    out, summary, _ = run
    for label in CONTENDERS:
        row = summary["localizers"][label]
        squares = []
        for sequence, record in row["sequences"].items():
            truth, estimate = associated(*files(out, summary, label, sequence))
            assert estimate.num_poses == record["written"]
            result = ape(truth, estimate, evo_metrics.PoseRelation.translation_part)
            assert result.stats["rmse"] == pytest.approx(record["rmse_cm"] / 100, abs=1e-6)
            squares.append(result.np_arrays["error_array"] ** 2)
        pooled = float(np.sqrt(np.mean(np.concatenate(squares))))
        assert pooled == pytest.approx(row["all"]["rmse_cm"] / 100, abs=1e-6)
    assert summary["localizers"]["ransac"]["sequences"]["warehouse-small/aisle-loop"][
        "refused"] > 0  # the refused frames are left out of its files, and evo agrees


def test_evo_rpe_gives_azgym_s_drift_per_route_and_pooled(run):
    out, summary, _ = run
    for label in CONTENDERS:
        row = summary["localizers"][label]
        pooled: dict[float, list[np.ndarray]] = {}
        for sequence, record in row["sequences"].items():
            for drift in record["drift"]:
                distance = drift["distance_m"]
                errors = {}
                for relation in (evo_metrics.PoseRelation.translation_part,
                                 evo_metrics.PoseRelation.rotation_angle_deg):
                    truth, estimate = associated(*files(out, summary, label, sequence))
                    errors[relation] = rpe(
                        truth, estimate, relation, delta=distance,
                        delta_unit=evo_metrics.Unit.meters, all_pairs=True,
                        pairs_from_reference=True).np_arrays["error_array"]
                moved = errors[evo_metrics.PoseRelation.translation_part]
                turned = errors[evo_metrics.PoseRelation.rotation_angle_deg]
                assert drift["pairs"] == moved.size
                assert drift["translation_pct"] == pytest.approx(
                    100 * moved.mean() / distance, abs=1e-9)
                assert drift["heading_deg_per_m"] == pytest.approx(turned.mean() / distance,
                                                                   abs=1e-9)
                pooled.setdefault(distance, []).append(moved)
        for drift in row["drift"]:
            moved = np.concatenate(pooled[drift["distance_m"]])
            assert drift["translation_pct"] == pytest.approx(
                100 * moved.mean() / drift["distance_m"], abs=1e-9)


def test_the_printed_summary_counts_the_refused_frames_left_out(run):
    _, summary, printed = run
    refused = sum(record["refused"] for record in
                  summary["localizers"]["ransac"]["sequences"].values())
    assert refused > 0
    text = " ".join(printed.split())  # the lines unwrapped
    counts = re.search(r"refused frames left out: ([^;.]*)[;.]", text).group(1)
    left_out = dict(item.rsplit(" ", 1) for item in counts.split(", "))
    assert left_out == {label: str(sum(record["refused"] for record in summary["localizers"][
        label]["sequences"].values())) for label in CONTENDERS}
    assert left_out["ransac"] == str(refused)
    assert "drift over 5 m travelled" in text


def test_the_evo_ape_command_prints_azgym_s_rmse(run, tmp_path):
    command = shutil.which("evo_ape")
    if command is None:
        pytest.skip("evo_ape is not on PATH")
    out, summary, _ = run
    sequence = "warehouse-paper/A-B-C-D"
    truth, estimate = files(out, summary, "ransac", sequence)
    environment = {**os.environ, "HOME": str(tmp_path)}  # evo writes its settings there
    printed = subprocess.run([command, "tum", str(truth), str(estimate)], capture_output=True,
                             text=True, timeout=120, env=environment, check=True).stdout
    rmse = float(re.search(r"rmse\s+([0-9.]+)", printed).group(1))
    expected = summary["localizers"]["ransac"]["sequences"][sequence]["rmse_cm"] / 100
    assert rmse == pytest.approx(expected, abs=1e-6)  # evo prints 6 decimals
