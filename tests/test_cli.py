"""The ``azgym`` command line: every sub-command parses to its handler with its defaults."""

from __future__ import annotations

import pytest

from azgym import cli

PARSED = [
    pytest.param(["bench"], cli._bench,
                 {"suite": None, "localizer": [], "split": "dev", "workers": 0, "quick": False,
                  "out": "results/bench"}, id="bench"),
    pytest.param(["bench", "--localizer", "ransac", "--localizer", "lsq", "--split", "test"],
                 cli._bench, {"localizer": ["ransac", "lsq"], "split": "test"},
                 id="bench-repeated-localizer"),
    pytest.param(["leaderboard", "submit", "out", "--localizer", "ransac", "--name", "mine",
                  "--version", "1.0", "--authors", "A. B.", "C. D."], cli._leaderboard,
                 {"action": "submit", "results": "out", "authors": ["A. B.", "C. D."],
                  "link": "", "entries": "leaderboard/entries", "overwrite": False},
                 id="leaderboard-submit"),
    pytest.param(["leaderboard", "build"], cli._leaderboard,
                 {"action": "build", "entries": "leaderboard/entries", "out": "leaderboard"},
                 id="leaderboard-build"),
    pytest.param(["leaderboard", "verify", "entry.json"], cli._leaderboard,
                 {"action": "verify", "entry": "entry.json", "workers": 1},
                 id="leaderboard-verify"),
    pytest.param(["reproduce", "paper"], cli._reproduce_paper,
                 {"target": "paper", "quick": False, "out": "results/paper", "workers": 0,
                  "seed": 2021, "no_figures": False}, id="reproduce-paper"),
    pytest.param(["study", "error-model"], cli._study_error_model,
                 {"scenario": "warehouse-small", "frames": 600, "noise": 2.0,
                  "calibration_px": 1.0, "seed": 0, "out": "results/study",
                  "no_figures": False}, id="study-error-model"),
    pytest.param(["study", "ids"], cli._study_ids,
                 {"scenario": "warehouse-small", "rate": None, "noise": 2.0, "seed": 0},
                 id="study-ids"),
    pytest.param(["scenarios"], cli._scenarios, {}, id="scenarios"),
    pytest.param(["localizers"], cli._localizers, {}, id="localizers"),
]


@pytest.mark.parametrize(("argv", "handler", "expected"), PARSED)
def test_each_sub_command_parses_to_its_handler_and_defaults(argv, handler, expected):
    args = cli.build_parser().parse_args(argv)
    assert args.command == argv[0]
    assert args.handler is handler
    assert {key: getattr(args, key) for key in expected} == expected


@pytest.mark.parametrize("argv", [[], ["leaderboard"], ["reproduce"], ["study"],
                                  ["bench", "--split", "train"],
                                  ["leaderboard", "submit", "out"]])
def test_incomplete_or_invalid_commands_are_refused(argv, capsys):
    with pytest.raises(SystemExit) as info:
        cli.build_parser().parse_args(argv)
    assert info.value.code == 2
    assert "usage: azgym" in capsys.readouterr().err


def test_version_and_defaults_are_shown(capsys):
    import azgym

    with pytest.raises(SystemExit) as done:
        cli.main(["--version"])
    assert done.value.code == 0 and capsys.readouterr().out.strip() == f"azgym {azgym.__version__}"
    with pytest.raises(SystemExit):
        cli.main(["bench", "--help"])
    assert "(default: results/bench)" in capsys.readouterr().out
