"""``azgym bench mapping``: the mapping suite's runner of ``azgym bench``, its options checked
before the run, its table printed and its file written, never over one unasked."""

from __future__ import annotations

import json

import pytest
from mapping_files import hand_result

from azgym import cli
from azgym.cli import bench
from azgym.mapping.registry import DEFAULT_MAPPERS


@pytest.fixture
def runs(monkeypatch):
    """``run_mapping`` replaced by the invented run; the calls it got."""
    import azgym.bench.mapping.benchmark as benchmark

    calls = []

    def run(suite, mappers, *, quick, workers, time_limit, progress):
        calls.append({"suite": suite, "mappers": mappers, "quick": quick, "workers": workers,
                      "time_limit": time_limit})
        return hand_result()

    monkeypatch.setattr(benchmark, "run_mapping", run)
    return calls


def test_bench_mapping_parses_to_its_handler_and_its_options_mean_the_same_on_either_side():
    parse = cli.build_parser().parse_args
    args = parse(["bench", "mapping"])
    assert args.handler is bench._bench_mapping and args.runner == "mapping"
    assert (args.quick, args.time_limit, args.workers, args.out, args.overwrite) == \
        (False, None, 0, None, False)
    assert not hasattr(args, "mapper")
    after = parse(["bench", "mapping", "--quick", "--workers", "2", "--time-limit", "5",
                   "--out", "o", "--mapper", "rays"])
    before = parse(["bench", "--quick", "--workers", "2", "--time-limit", "5", "--out", "o",
                    "mapping", "--mapper", "rays"])
    assert vars(after) == vars(before)
    assert parse(["bench"]).handler is bench._bench and parse(["bench"]).runner is None


def test_a_run_prints_the_table_and_writes_mapping_json(runs, tmp_path, capsys):
    out = tmp_path / "out"
    assert cli.main(["bench", "mapping", "--quick", "--workers", "1", "--out", str(out)]) == 0
    assert runs == [{"suite": "mapping", "mappers": list(DEFAULT_MAPPERS), "quick": True,
                     "workers": 1, "time_limit": 10.0}]
    printed = capsys.readouterr().out
    assert "1  rays " in printed and "2  prior " in printed
    assert "Ranked by the error p95" in " ".join(printed.split())
    assert f"wrote {out / 'mapping.json'}" in printed
    assert json.loads((out / "mapping.json").read_text())["kind"] == "mapping"


def test_mappers_named_run_once_each_in_order(runs, tmp_path):
    assert cli.main(["bench", "mapping", "--mapper", "rays", "--mapper", "prior", "--mapper",
                     "rays", "--time-limit", "3", "--out", str(tmp_path)]) == 0
    assert (runs[0]["mappers"], runs[0]["time_limit"]) == (["rays", "prior"], 3.0)


def test_a_previous_run_is_kept_unless_overwrite(runs, tmp_path, capsys):
    (tmp_path / "mapping.json").write_text("mine")
    assert cli.main(["bench", "mapping", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert f"--out: {tmp_path / 'mapping.json'} already exists; nothing was written" in err
    assert (tmp_path / "mapping.json").read_text() == "mine" and not runs
    assert cli.main(["bench", "mapping", "--out", str(tmp_path), "--overwrite"]) == 0
    assert json.loads((tmp_path / "mapping.json").read_text())["kind"] == "mapping"


@pytest.mark.parametrize(("argv", "message"), [
    (["bench", "--split", "test", "mapping"], "--split is not for azgym bench mapping: it runs "
     "the mapping suite's dev split (its routes are public)"),
    (["bench", "--navigator", "ppo", "mapping"], "--navigator is not for azgym bench mapping"),
    (["bench", "--profile", "p.toml", "mapping"], "--profile is not for azgym bench mapping"),
    (["bench", "--backend", "ray", "mapping"], "--backend is not for azgym bench mapping"),
    (["bench", "--localizer", "ransac", "mapping"], "--localizer is not for azgym bench "
     "mapping: it scores mappers, named by --mapper"),
    (["bench", "--with-builtins", "mapping"], "--with-builtins is not for azgym bench mapping"),
    (["bench", "--data", "roh", "mapping"], "--data is not for azgym bench mapping"),
    (["bench", "--suite", "mapping"], "--suite mapping: a mapping suite scores mappers: run "
     "azgym bench mapping [--mapper SPEC ...]"),
    (["bench", "mapping", "--mapper", "survy"], "Did you mean 'survey'?"),
    (["bench", "mapping", "--mapper", "rays:nonsense=1"], "nonsense"),
    (["bench", "mapping", "--mapper", "survey:loss=huber,loss=cauchy"], "loss"),
], ids=["split", "navigator", "profile", "backend", "localizer", "with-builtins", "data",
        "suite", "misspelt-mapper", "bad-hyperparameter", "unreadable-spec"])
def test_what_the_mapping_runner_does_not_take_is_refused_before_the_run(argv, message, runs,
                                                                         tmp_path, capsys):
    assert cli.main([*argv, "--out", str(tmp_path / "o")]) == 2
    assert message in capsys.readouterr().err
    assert not runs and not (tmp_path / "o").exists()
