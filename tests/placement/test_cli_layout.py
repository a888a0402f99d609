"""``azgym layout``: bad arguments are refused by name before any work; the outputs it writes."""

from __future__ import annotations

import json

import numpy as np
import pytest

import azgym
from azgym import cli
from azgym.placement.scenario_file import file_stem, fresh_ids


@pytest.mark.parametrize(("argv", "message"), [
    (["analyze", "paper-rooom"], "unknown scenario 'paper-rooom'. Did you mean 'paper-room'"),
    (["analyze", "paper-room", "--step", "0"], "step must be > 0 m"),
    (["analyze", "paper-room", "--step", "-0.5"], "step must be > 0 m"),
    (["analyze", "paper-room", "--step", "30"], "step 30 m is larger than the room"),
    (["analyze", "paper-room", "--step", "0.02"], "use a larger step"),
    (["analyze", "paper-room", "--frames", "-1"], "frames must be an integer >= 0"),
    (["analyze", "paper-room", "--frames", "100000"], "Monte Carlo frames, more than"),
    (["analyze", "paper-room", "--localizer", "ransack"], "unknown localizer 'ransack'"),
    (["optimize", "paper-room", "--add", "0"], "add must be an integer >= 1"),
    (["optimize", "paper-room", "--add", "5000"], "add must be at most"),
    (["optimize", "paper-room", "--add", "1", "--spacing", "0"], "spacing must be > 0 m"),
    (["analyze", "paper-room", "--seed=-1"], "seed must be an integer in [0, 2147483648), got -1"),
    (["analyze", "paper-room", "--seed", str(2**31)], "seed must be an integer in [0, 2147483648)"),
    (["analyze", "paper-room", "--step", "5e-324"],
     "step 4.94066e-324 m makes a grid of inf x inf cells on 'paper-room', more than 250000"),
    (["analyze", "paper-room", "--step", "1e-300"], "makes a grid of 2.1e+301 x 2.1e+301 cells"),
    (["optimize", "paper-room", "--add", "1", "--step", "2", "--spacing", "5e-324"],
     "spacing 4.94066e-324 m gives more than 5000 candidate places"),
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


def scenario_file(tmp_path, name: str, beacons: list[tuple[int, tuple[float, float, float]]],
                  extra: str = "") -> str:
    """A 20 m x 20 m room with ``beacons`` (id, xyz), written as ``name``.toml."""
    text = f'name = "{name}"\ndescription = "test"\nversion = 1\n[room]\nbounds = [0, 0, 20, 20]\n'
    for beacon, xyz in beacons:
        text += f"[[beacons]]\nid = {beacon}\nxyz = {list(xyz)}\n"
    path = tmp_path / f"{name}.toml"
    path.write_text(text + extra)
    return str(path)


CORNERS = [(0.0, 0.0, 3.0), (20.0, 0.0, 3.0), (10.0, 20.0, 3.0)]


def test_a_name_with_a_separator_writes_nowhere(tmp_path, capsys):
    """The attack: a scenario named '/abs/path' made optimize write '/abs/path-plus-1.toml'."""
    target = tmp_path / "victim"
    path = scenario_file(tmp_path, "room", list(zip([1, 2, 3], CORNERS, strict=True)))
    text = open(path).read().replace('name = "room"', f'name = "{target}"')
    open(path, "w").write(text)
    assert cli.main(["layout", "optimize", path, "--add", "1", "--step", "2", "--no-figures",
                     "--out", str(tmp_path / "out")]) == 2
    assert "name: must be a plain file name" in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == [tmp_path / "room.toml"]


def test_file_names_are_built_from_a_sanitized_name():
    """A scenario built in memory is not checked by the parser: its file names still are."""
    assert file_stem("/tmp/attack/ABS") == "tmp_attack_ABS"
    assert file_stem("../../up") == "up" and file_stem("..") == "scenario"
    assert file_stem("warehouse-small") == "warehouse-small"


def test_fresh_ids_never_pass_the_largest_id_a_file_may_give(tmp_path, capsys):
    ids = [1, 2147483647, 5]
    path = scenario_file(tmp_path, "bigid", list(zip(ids, CORNERS, strict=True)))
    out = tmp_path / "out"
    assert cli.main(["layout", "optimize", path, "--add", "2", "--step", "2", "--no-figures",
                     "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "new beacon 2:" in printed and "new beacon 3:" in printed
    assert sorted(azgym.load_scenario(out / "bigid-plus-2.toml").beacons.ids) == [1, 2, 3, 5,
                                                                                 2147483647]
    assert fresh_ids(np.array([1, 7]), 2) == [8, 9]


@pytest.mark.parametrize(("beacons", "extra"), [
    ([(1, (0.0, 0.0, 0.5)), (2, (20.0, 0.0, 0.5)), (3, (0.0, 20.0, 0.5))], ""),  # under the lens
    ([(1, (0.0, 10.0, 1.0)), (2, (0.0, 9.0, 1.0)), (3, (0.0, 11.0, 1.0))],
     "[[racks]]\ncenter = [1.0, 10]\nsize = [0.5, 19.0]\nheight = 6\n")])
def test_optimize_writes_nothing_when_no_candidate_helps(tmp_path, capsys, beacons, extra):
    path = scenario_file(tmp_path, "useless", beacons, extra)
    out = tmp_path / "out"
    assert cli.main(["layout", "optimize", path, "--add", "4", "--step", "2",
                     "--out", str(out)]) == 2
    assert ("useless: no candidate place lowers the objective (the p95 of the predicted σ, then "
            "its mean): none is seen from cells where it would help; nothing written"
            ) in capsys.readouterr().err
    assert list(out.iterdir()) == []


@pytest.mark.parametrize(("argv", "message"), [
    (["--time-limit", "0"], "argument --time-limit: must be >= 0.01 s, got 0.0"),
    (["--workers", "-1"], "argument --workers: must be an integer >= 0 (0: one per core)"),
    (["--out", ""], "argument --out: is empty: give a folder (. for the current one)"),
])
def test_malformed_options_stop_the_parser(argv, message, capsys):
    with pytest.raises(SystemExit) as stop:
        cli.main(["layout", "analyze", "paper-room", *argv])
    assert stop.value.code == 2 and message in capsys.readouterr().err


def test_one_beacon_is_singular(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(["layout", "optimize", "paper-room", "--add", "1", "--step", "3",
                     "--no-figures", "--out", "."]) == 0
    assert "placing 1 beacon on" in capsys.readouterr().out
    assert "paper-room with 1 beacon placed" in (tmp_path / "paper-room-plus-1.toml").read_text()


def test_the_summary_says_which_cells_the_localizer_ran_at(tmp_path, capsys):
    """Cells behind the rack see one beacon: they are counted, not silently left out."""
    beacons = [(1, (0.0, 0.0, 6.0)), (2, (20.0, 0.0, 6.0)), (3, (0.0, 10.0, 6.0))]
    rack = "[[racks]]\ncenter = [10.0, 14]\nsize = [19.0, 0.5]\nheight = 9\n"
    path = scenario_file(tmp_path, "shaded", beacons, rack)
    assert cli.main(["layout", "analyze", path, "--step", "2", "--frames", "3", "--no-figures",
                     "--out", str(tmp_path / "out")]) == 0
    printed = capsys.readouterr().out
    summary = json.loads((tmp_path / "out" / "layout.json").read_text())["monte_carlo"]
    run, not_run = summary["cells_run"], summary["cells_not_run"]
    assert (run, not_run) == (60, 20)
    assert (f"run at {run} cells seeing ≥ 3 beacons: 0.00 % of the frames had no fix; not run "
            f"at {not_run} cells seeing fewer (no fix)") in printed
