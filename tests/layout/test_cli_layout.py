"""``azgym layout``: bad arguments are refused by name before any work; the outputs it writes."""

from __future__ import annotations

import json

import numpy as np
import pytest

import azgym
from azgym import cli


@pytest.mark.parametrize(("argv", "message"), [
    (["analyze", "paper-rooom"], "unknown scenario 'paper-rooom'. Did you mean 'paper-room'"),
    (["analyze", "paper-room", "--step", "0"], "step must be a finite number > 0"),
    (["analyze", "paper-room", "--step", "-0.5"], "step must be a finite number > 0"),
    (["analyze", "paper-room", "--step", "30"], "step 30 m is larger than the room"),
    (["analyze", "paper-room", "--step", "0.02"], "use a larger step"),
    (["analyze", "paper-room", "--frames", "-1"], "frames must be an integer >= 0"),
    (["analyze", "paper-room", "--frames", "100000"], "Monte Carlo frames, more than"),
    (["analyze", "paper-room", "--localizer", "ransack"], "unknown localizer 'ransack'"),
    (["optimize", "paper-room", "--add", "0"], "add must be an integer >= 1"),
    (["optimize", "paper-room", "--add", "5000"], "add must be at most"),
    (["optimize", "paper-room", "--add", "1", "--spacing", "0"], "spacing must be a finite"),
])
def test_bad_arguments_are_named_errors(argv, message, tmp_path, capsys):
    out = tmp_path / "out"
    assert cli.main(["layout", *argv, "--out", str(out)]) == 2
    captured = capsys.readouterr()
    assert message in captured.err and captured.out == ""
    assert not out.exists()  # refused before anything is made


@pytest.mark.parametrize("action", [["analyze", "paper-room", "--frames", "0"],
                                    ["optimize", "paper-room", "--add", "1"]])
def test_an_unwritable_out_stops_before_the_work(action, tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    assert cli.main(["layout", *action, "--step", "2", "--out", str(blocker / "out")]) == 2
    captured = capsys.readouterr()
    assert "cannot write there" in captured.err
    assert captured.out == ""  # no work was started


def test_analyze_writes_the_grids_and_the_summary(tmp_path, capsys):
    out = tmp_path / "analysis"
    assert cli.main(["layout", "analyze", "paper-room", "--step", "3", "--frames", "20",
                     "--out", str(out), "--no-figures"]) == 0
    printed = capsys.readouterr().out
    assert "predicted σ_pos over 64 cells: median" in printed
    assert "cells with < 3 beacons seen: 0" in printed
    summary = json.loads((out / "layout.json").read_text())
    assert summary["monte_carlo"]["cells_compared"] == 64
    grids = np.load(out / "layout.npz")
    assert grids["sigma"].shape == grids["free"].shape == (8, 8)
    assert np.isfinite(grids["mc_rms"]).all() and (grids["visible"] == 12).all()
    assert np.nanpercentile(grids["sigma"], 95) == pytest.approx(
        summary["predicted"]["sigma_p95_m"])


def test_optimize_writes_a_scenario_that_loads(tmp_path, capsys):
    out = tmp_path / "placed"
    assert cli.main(["layout", "optimize", "paper-room", "--add", "2", "--step", "2",
                     "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "new beacon 13:" in printed and "new beacon 14:" in printed
    scenario = azgym.load_scenario(out / "paper-room-plus-2.toml")
    assert len(scenario.beacons) == 14
    assert (out / "layout-optimized.png").stat().st_size > 10_000
