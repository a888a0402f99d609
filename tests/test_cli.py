"""The ``azgym`` command line: every sub-command parses to its handler with its defaults; the
localizers ``bench`` runs are named, labelled and checked before the run."""

from __future__ import annotations

import re
import textwrap

import pytest

from azgym import cli
from azgym.bench.run import runner
from azgym.bench.run.contenders import Contender, default_contenders, resolve_contenders
from azgym.cli import bench, leaderboard, studies
from azgym.cli import info as listings
from azgym.errors import InvalidInputError

PARSED = [
    pytest.param(["bench"], bench._bench,
                 {"suite": None, "localizer": [], "with_builtins": False, "split": "dev",
                  "workers": 0, "quick": False, "out": None, "profile": None},
                 id="bench"),
    pytest.param(["bench", "--localizer", "ransac", "--localizer", "lsq", "--split", "test"],
                 bench._bench, {"localizer": ["ransac", "lsq"], "split": "test"},
                 id="bench-repeated-localizer"),
    pytest.param(["leaderboard", "submit", "out", "--localizer", "ransac", "--name", "mine",
                  "--version", "1.0", "--authors", "A. B.", "C. D."], leaderboard._leaderboard,
                 {"action": "submit", "results": "out", "authors": ["A. B.", "C. D."],
                  "link": "", "entries": None, "overwrite": False},
                 id="leaderboard-submit"),
    pytest.param(["leaderboard", "build"], leaderboard._leaderboard,
                 {"action": "build", "entries": None, "out": None},
                 id="leaderboard-build"),
    pytest.param(["leaderboard", "verify", "entry.json"], leaderboard._leaderboard,
                 {"action": "verify", "entry": "entry.json", "workers": 1},
                 id="leaderboard-verify"),
    pytest.param(["reproduce", "paper"], studies._reproduce_paper,
                 {"target": "paper", "quick": False, "out": "results/paper", "workers": 0,
                  "seed": 2021, "no_figures": False}, id="reproduce-paper"),
    pytest.param(["study", "error-model"], studies._study_error_model,
                 {"scenario": "warehouse-small", "frames": 600, "noise": 2.0,
                  "calibration_px": 1.0, "seed": 0, "out": "results/study",
                  "no_figures": False}, id="study-error-model"),
    pytest.param(["study", "ids"], studies._study_ids,
                 {"scenario": "warehouse-small", "rate": None, "noise": 2.0, "seed": 0},
                 id="study-ids"),
    pytest.param(["reproduce", "plotter"], studies._reproduce_plotter,
                 {"target": "plotter", "runs": 100, "seed": 0, "out": "results/plotter"},
                 id="reproduce-plotter"),
    pytest.param(["scenarios"], listings._scenarios, {}, id="scenarios"),
    pytest.param(["localizers"], listings._localizers, {}, id="localizers"),
    pytest.param(["check", "ransac:weighted=true"], listings._check,
                 {"localizer": "ransac:weighted=true"}, id="check"),
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
    shown = " ".join(capsys.readouterr().out.split())
    assert "(default: results/bench/SUITE," in shown and "data-LOG for a log)" in shown
    assert "--with-builtins run the default built-ins too" in shown
    assert "ransac:weighted=true" in shown


@pytest.mark.parametrize("expected", default_contenders(), ids=lambda c: c.label)
def test_every_default_label_given_to_localizer_builds_that_very_contender(expected):
    assert resolve_contenders([expected.label], with_builtins=False) == [expected]


def test_a_label_never_means_two_localizers():
    labels = {c.label: c for c in default_contenders()}
    assert len(labels) == len(default_contenders())
    exhaustive = resolve_contenders(["mex"], with_builtins=False)
    assert exhaustive == [Contender("mex", "mex", {})]
    assert "mex" not in labels and labels["mex-coarse"].params == {"coarse_step": 0.1}


def test_hyperparameters_on_the_command_line_and_the_label_they_get():
    assert resolve_contenders(["ransac:weighted=true", "lsq:max_iter=20", "ransac-weighted"],
                           with_builtins=False) == [
        Contender("ransac-weighted", "ransac", {"weighted": True}),
        Contender("lsq:max_iter=20", "lsq", {"max_iter": 20})]


def test_with_builtins_adds_the_defaults_to_the_named_localizers():
    named = resolve_contenders(["lsq:max_iter=20"], with_builtins=False)
    both = resolve_contenders(["lsq:max_iter=20", "ransac"], with_builtins=True)
    assert both == default_contenders() + named
    assert resolve_contenders([], with_builtins=True) == default_contenders()


@pytest.fixture
def no_run(monkeypatch):
    """A bench run that fails the test if it starts: the refusals come before any frame."""
    def never(*_args, **_kwargs):
        raise AssertionError("the run started")

    monkeypatch.setattr(runner, "run_benchmark", never)


BROKEN = textwrap.dedent("""
    class Raises:
        def __init__(self, *, size=1):
            raise RuntimeError("no licence file")

        def localize(self, measurements, beacons):
            return None
""")


@pytest.mark.parametrize(("spec", "message"), [
    ("ransak", "cannot build ransak: unknown localizer 'ransak'. Did you mean 'ransac'?"),
    ("ransac:wieghted=true", "unknown hyperparameter 'wieghted'. Did you mean 'weighted'?"),
    ("ransac:pr_hit=2", "cannot build ransac:pr_hit=2: Ransac.pr_hit must be in (0, 1)"),
    ("ransac:weighted", "hyperparameters are written ransac:NAME=VALUE"),
    ("{tmp}/no_such.py:Mine", "no file"),
    ("{tmp}/broken.py:Raises:size=2", "RuntimeError: no licence file"),
    ("{tmp}/broken.py:Raises:sise=2", "Did you mean 'size'?"),
    ("{tmp}/broken.py:Missing", "has no attribute 'Missing'"),
])
def test_a_localizer_that_cannot_be_built_stops_bench_before_the_run(spec, message, tmp_path,
                                                                     no_run, capsys):
    (tmp_path / "broken.py").write_text(BROKEN)
    out = tmp_path / "out"
    argv = ["bench", "--localizer", "lsq", "--localizer", spec.format(tmp=tmp_path),
            "--out", str(out)]
    assert cli.main(argv) == 2
    assert re.search(re.escape(message), capsys.readouterr().err)
    assert not out.exists()


def test_check_prints_what_passed_and_refuses_a_bad_spec(capsys):
    assert cli.main(["check", "ransac-weighted"]) == 0
    assert "check_localizer: Ransac passed all 7 checks" in capsys.readouterr().out
    assert cli.main(["check", "ransac:wieghted=true"]) == 2
    assert "Did you mean 'weighted'?" in capsys.readouterr().err


def test_localizers_lists_the_presets_with_what_they_are(capsys):
    assert cli.main(["localizers"]) == 0
    listed = capsys.readouterr().out
    assert re.search(r"^ransac-weighted +ransac with weighted=true$", listed, re.M)
    assert re.search(r"^mex-coarse +mex with coarse_step=0.1$", listed, re.M)


@pytest.mark.parametrize(("extra", "message"), [
    (["--backend", "ray"], "takes no --suite, --navigator, --quick, --split, --backend or "
                           "--address"),
    (["--address", "127.0.0.1:6379"], "--address is for --backend ray"),
])
def test_bench_on_a_log_refuses_the_ray_options_by_name(extra, message, tmp_path, capsys):
    argv = ["bench", "--data", "warehouse-small-simulated", *extra, "--out", str(tmp_path)]
    assert cli.main(argv) == 2
    assert message in capsys.readouterr().err


def test_the_bench_runners_options_are_unset_at_the_parsers_defaults():
    args = cli.build_parser().parse_args(["bench"])
    for option, (attribute, unset) in bench.OPTIONS.items():
        assert getattr(args, attribute) == unset, option


GIVEN = {"suite": "stress", "navigator": ["ppo"], "quick": True, "split": "test",
         "time_limit": 3.0, "backend": "ray", "address": "auto", "profile": "profile.toml"}
"""A value of each option of bench.OPTIONS other than its default."""


@pytest.mark.parametrize("runner", sorted(bench.RUNNERS))
def test_each_bench_runner_refuses_what_it_does_not_take_naming_option_and_runner(runner):
    chosen = bench.RUNNERS[runner]
    assert chosen.refuses()
    for option in chosen.refuses():
        args = cli.build_parser().parse_args(["bench"])
        attribute, _ = bench.OPTIONS[option]
        setattr(args, attribute, GIVEN[attribute])
        named = f"^{option} is not for {re.escape(chosen.name)}: "
        with pytest.raises(InvalidInputError, match=named):
            bench.check_options(runner, args)
    for option in chosen.takes:  # what it takes passes
        args = cli.build_parser().parse_args(["bench"])
        attribute, _ = bench.OPTIONS[option]
        setattr(args, attribute, GIVEN[attribute])
        bench.check_options(runner, args)


def test_an_address_without_the_ray_backend_is_refused_before_any_frame(tmp_path, capsys):
    assert cli.main(["bench", "--address", "127.0.0.1:6379", "--out", str(tmp_path / "o")]) == 2
    captured = capsys.readouterr()
    assert "--address is for --backend ray" in captured.err and "frames drawn" not in \
        captured.out
    assert not (tmp_path / "o").exists()
