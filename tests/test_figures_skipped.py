"""Without matplotlib a command says which figures it skipped, or refuses before its work."""

from __future__ import annotations

import importlib.util

import pytest

from azgym.cli import main


@pytest.fixture
def no_matplotlib(monkeypatch):
    found = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name.split(".")[0] == "matplotlib"
                        else found(name, *a))


def test_bench_without_matplotlib_says_which_figures_it_skipped(no_matplotlib, tmp_path, capsys):
    assert main(["bench", "--quick", "--localizer", "lsq", "--workers", "1",
                 "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "figures skipped (cdf.png, causes.png, error_map_*.png, trajectories_*.png): " \
           "matplotlib is not installed; pip install \"azgym[plot]\" draws them" in out
    assert not list(tmp_path.glob("*.png"))


@pytest.mark.parametrize("argv", [["reproduce", "plotter", "--runs", "1"],
                                  ["reproduce", "paper", "--quick"],
                                  ["study", "error-model", "--frames", "2"]])
def test_a_study_whose_figures_cannot_be_drawn_is_refused_before_its_work(
        no_matplotlib, argv, tmp_path, capsys):
    assert main([*argv, "--out", str(tmp_path / "out")]) == 2
    assert 'matplotlib is not installed; run: pip install "azgym[plot]"' in \
        capsys.readouterr().err
    assert not (tmp_path / "out").exists()
