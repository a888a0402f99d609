"""azgym sweep: a config checked field by field before anything runs; the same config, the same
table."""

from __future__ import annotations

import csv
import math
from datetime import UTC, datetime
from pathlib import Path

import pytest

from azgym.bench.sweep.config import MAX_RUNS, load_sweep, parse_sweep
from azgym.bench.sweep.run import FIGURES, INTERVAL, SweepResult, run_sweep, write_sweep_figure
from azgym.cli import main
from azgym.errors import InvalidInputError

EXAMPLE = Path(__file__).parents[1] / "baselines" / "sweeps" / "ransac-iterations.toml"


def config(**changes):
    data = {"suites": ["warehouse-static"], "quick": True, "seeds": [7],
            "localizer": [{"name": "ransac", "grid": {"weighted": [False, True]}},
                          {"name": "lsq"}]}
    data.update(changes)
    return data


@pytest.mark.parametrize(("changes", "message"), [
    ({"localizer": [{"name": "ransack"}]},
     r"sweep: localizer\[0\]: unknown localizer 'ransack'. Did you mean 'ransac'\?"),
    ({"localizer": [{"name": "ransac", "grid": {"iterations": [5, 10]}}]},
     r"sweep: localizer\[0\].grid.iterations: localizer 'ransac': unknown hyperparameter "
     r"'iterations'"),
    ({"localizer": [{"name": "ransac", "grid": {"pr_hit": [0.9, 2.0]}}]},
     r"sweep: localizer\[0\].grid.pr_hit: Ransac.pr_hit must be in \(0, 1\), got 2.0"),
    ({"localizer": [{"name": "ransac", "grid": {"max_iter": [5, 0]}}]},
     r"sweep: localizer\[0\].grid.max_iter: Ransac.max_iter must be an integer >= 1, got 0"),
    ({"localizer": [{"name": "ransac", "params": {"max_iter": 5, "pr_hit": 7}}]},
     r"sweep: localizer\[0\].params.pr_hit: Ransac.pr_hit must be in \(0, 1\), got 7"),
    ({"localizer": [{"name": "ransac", "bogus": 1}]},
     r"sweep: localizer\[0\]: unknown key 'bogus'"),
    ({"localizer": [{"name": "ransac", "params": {"weighted": True},
                     "grid": {"weighted": [True]}}]},
     r"sweep: localizer\[0\].grid.weighted: is also fixed in params"),
    ({"suites": ["warehouse-statc"]},
     r"sweep: suites\[0\]: unknown suite 'warehouse-statc'. Did you mean 'warehouse-static'\?"),
    ({"suites": []}, r"sweep: suites: must be a non-empty list, got \[\]"),
    ({"suites": None}, r"sweep: suites: a sweep needs suites, scenarios or both"),
    ({"scenarios": ["warehouse-lrage"]},
     r"sweep: scenarios\[0\]: unknown scenario 'warehouse-lrage'.*Did you mean 'warehouse-large'"),
    ({"scenarios": [3]}, r"sweep: scenarios\[0\]: must be a name or a \.toml file, got 3"),
    ({"scenarios": ["missing.toml"]}, r"sweep: scenarios\[0\]: .*missing\.toml"),
    ({"localizer": [{"name": "ransac", "grid": {}}]}, r"sweep: localizer\[0\].grid: is empty"),
    ({"localizer": [{"name": "ransac", "grid": {"max_iter": []}}]},
     r"sweep: localizer\[0\].grid.max_iter: must be a non-empty list, got \[\]"),
    ({"seeds": [7, -1]}, r"sweep: seeds\[1\] must be an integer in \[0, 2147483648\), got -1"),
    ({"seeds": [True]}, r"sweep: seeds\[0\] must be an integer in \[0, 2147483648\)"),
    ({"seeds": [7, 7]}, r"sweep: seeds: lists a value twice: \[7, 7\]"),
    ({"seeds": []}, r"sweep: seeds: must be a non-empty list"),
    ({"seed": [7]}, r"sweep: unknown key 'seed'. Did you mean 'seeds'\?"),
    ({"localizer": [{"name": "lsq", "grids": {}}]},
     r"sweep: localizer\[0\]: unknown key 'grids'. Did you mean 'grid'\?"),
    ({"localizer": []}, r"sweep: localizer: at least one \[\[localizer\]\] table is needed"),
    ({"localizer": [{"name": "ransac", "grid": {"max_iter": list(range(1, 101)),
                                                "pr_hit": [0.5, 0.9, 0.99, 0.999]}}],
      "seeds": [1, 2, 3]},
     rf"sweep: localizer: the sweep holds 1200 runs .* more than the cap of {MAX_RUNS}"),
    ({"metric": "p76_cm"}, r"sweep: metric: unknown metric 'p76_cm'. Did you mean 'p75_cm'\?"),
    ({"quick": "yes"}, r"sweep: quick: must be true or false, got 'yes'"),
    ({"time_limit": 0}, r"sweep: time_limit: must be >= 0.01 s, got 0"),
    ({"time_limit": 1e-300},
     r"sweep: time_limit: must be >= 0.01 s, got 1e-300"),
    ({"localizer": [{"name": "ransac", "grid": {"pr_hit": [datetime(1979, 5, 27, tzinfo=UTC)]}}]},
     r"sweep: localizer\[0\].grid.pr_hit: must be true, false, a number or a string \(a JSON "
     r"scalar\), got datetime"),
    ({"localizer": [{"name": "ransac", "params": {"pr_hit": [0.5]}}]},
     r"sweep: localizer\[0\].params.pr_hit: must be true, false, a number or a string"),
    ({"localizer": [{"name": "ransac:pr_hit=0.5", "grid": {"pr_hit": [0.9]}}]},
     r"sweep: localizer\[0\].grid.pr_hit: is also fixed in the name 'ransac:pr_hit=0.5'"),
    ({"localizer": [{"name": "ransac-weighted", "params": {"weighted": False}}]},
     r"sweep: localizer\[0\].params.weighted: is also fixed in the name 'ransac-weighted'"),
    ({"scenarios": [""]}, r"sweep: scenarios\[0\]: must be a name or a \.toml file, got ''"),
    ({"scenarios": ["/etc/site.toml"]},
     r"sweep: scenarios\[0\]: '/etc/site.toml' is outside the config's folder"),
    ({"scenarios": ["../../../etc/passwd.toml"]},
     r"sweep: scenarios\[0\]: '\.\./\.\./\.\./etc/passwd.toml' is outside the config's folder"),
    ({"localizer": [{"name": "lsq"}, {"name": "lsq"}]},
     r"sweep: localizer\[1\]: grid point 'lsq' is already in the sweep \(localizer\[0\]\)"),
])
def test_every_field_of_a_sweep_is_checked_by_name(changes, message):
    with pytest.raises(InvalidInputError, match=message):
        parse_sweep(config(**changes))


def test_a_file_that_is_not_toml_is_named(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("suites = [warehouse-static\n")
    with pytest.raises(InvalidInputError, match=r"bad.toml: not a TOML file"):
        load_sweep(path)


def test_arrays_nested_too_deeply_are_named(tmp_path):
    path = tmp_path / "deep.toml"
    path.write_text("x = " + "[" * 5000 + "]" * 5000 + "\n")
    with pytest.raises(InvalidInputError,
                       match=r"deep.toml: not a TOML file \(arrays or tables nested too deeply\)"):
        load_sweep(path)


def test_a_scenario_file_in_a_folder_below_the_config_is_taken(tmp_path):
    (tmp_path / "sites").mkdir()
    assert main(["generate", "--seed", "3", "--out", str(tmp_path / "sites" / "a.toml")]) == 0
    (tmp_path / "link.toml").symlink_to(tmp_path / "sites" / "a.toml")
    on = {key: value for key, value in config().items() if key != "suites"}
    sweep = parse_sweep({**on, "scenarios": ["sites/a.toml"]}, folder=tmp_path)
    assert [suite.name for suite in sweep.suites] == ["static:a"]
    outside = tmp_path / "config"
    outside.mkdir()
    (outside / "out.toml").symlink_to(tmp_path / "sites" / "a.toml")
    with pytest.raises(InvalidInputError, match=r"scenarios\[0\]: 'out.toml' is outside"):
        parse_sweep({**on, "scenarios": ["out.toml"]}, folder=outside)


def test_the_figure_copes_with_a_metric_that_is_nan_everywhere(tmp_path):
    """Every localizer failing every frame: no error to draw, no log scale, a note instead."""
    sweep = parse_sweep(config(localizer=[{"name": "lsq"}, {"name": "ransac"}]))
    assert sweep.metric == "p75_all_cm"  # the headline by default
    figures = {"n": 240, "p75_all_cm": math.inf, "availability": 0.0, "failure_rate": 1.0}
    row = ["warehouse-static", 7, "lsq", "lsq", *(figures.get(f, math.nan) for f in FIGURES),
           math.inf, math.inf]
    result = SweepResult(sweep, ["suite", "seed", "localizer", "label", *FIGURES, *INTERVAL],
                         [row, [*row[:2], "ransac", "ransac", *row[4:]]], [])
    assert write_sweep_figure(result, tmp_path / "sweep.png").stat().st_size > 0


def test_workers_below_zero_and_an_empty_out_are_refused_by_name(capsys):
    for option in (["--workers", "-1"], ["--out", ""]):
        with pytest.raises(SystemExit):
            main(["sweep", str(EXAMPLE), *option])
    err = capsys.readouterr().err
    assert "argument --workers: must be an integer >= 0 (0: one per core), got '-1'" in err
    assert "argument --out: is empty: give a folder (. for the current one)" in err


def test_the_example_config_is_valid_and_its_points_are_canonical_specs():
    sweep = load_sweep(EXAMPLE)
    labels = [p.contender.label for p in sweep.points]
    assert labels[0] == "ransac:max_exhaustive=1,pr_hit=0.5,weighted=false"
    assert labels[-1] == "lsq" and len(labels) == 9 and sweep.runs == 18


def test_a_small_sweep_gives_the_same_table_whatever_the_workers(tmp_path, capsys):
    sweep = parse_sweep(config())
    one = run_sweep(sweep, workers=1)
    path = tmp_path / "sweep.toml"
    path.write_text('suites = ["warehouse-static"]\nquick = true\nseeds = [7]\n'
                    '[[localizer]]\nname = "ransac"\ngrid = { weighted = [false, true] }\n'
                    '[[localizer]]\nname = "lsq"\n')
    assert main(["sweep", str(path), "--workers", "2", "--out", str(tmp_path / "out")]) == 0
    written = (tmp_path / "out" / "sweep.csv").read_bytes().decode()
    assert written == one.csv()
    rows = list(csv.DictReader(written.splitlines()))
    assert [r["label"] for r in rows] == ["ransac:weighted=false", "ransac-weighted", "lsq"]
    assert [r["weighted"] for r in rows] == ["false", "true", ""]
    assert float(rows[0]["p75_all_cm"]) < float(rows[2]["p75_all_cm"])  # ransac beats lsq
    assert float(rows[0]["p75_all_cm_lo"]) <= float(rows[0]["p75_all_cm"]) <= \
        float(rows[0]["p75_all_cm_hi"])
    assert (tmp_path / "out" / "runtimes.csv").is_file()
    assert (tmp_path / "out" / "sweep.png").stat().st_size > 0
    assert "ransac-weighted" in capsys.readouterr().out


def test_sweep_refuses_an_address_without_the_ray_backend(capsys):
    assert main(["sweep", str(EXAMPLE), "--address", "127.0.0.1:6379"]) == 2
    assert "--address is for --backend ray" in capsys.readouterr().err


def test_a_scenario_axis_scores_random_poses_in_a_generated_warehouse(tmp_path):
    """A scenario file beside the config (here a generated one, not shipped) is a suite of
    random poses, its beacon map sent to the workers with the frames."""
    assert main(["generate", "--seed", "3", "--out", str(tmp_path / "site.toml")]) == 0
    path = tmp_path / "sweep.toml"
    path.write_text('scenarios = ["site.toml", "warehouse-small"]\nquick = true\n'
                    'seeds = [1]\n[[localizer]]\nname = "ransac"\n')
    sweep = load_sweep(path)
    assert [suite.name for suite in sweep.suites] == ["static:site",
                                                      "static:warehouse-small"]
    table = run_sweep(sweep, workers=1)
    assert [(row[0], row[1]) for row in table.rows] == [("static:site", 1),
                                                        ("static:warehouse-small", 1)]
    n, availability = (table.columns.index(key) for key in ("n", "availability"))
    assert all(row[n] == 40 and row[availability] > 0.5 for row in table.rows)


@pytest.mark.parametrize("scenario", ["warehouse-large", "warehouse-small.toml"])
def test_suites_and_scenarios_in_one_sweep_are_each_scored_on_their_own_maps(tmp_path, scenario):
    """Mixing the axes changes no row: warehouse-static keeps its shipped maps beside a shipped
    scenario it does not draw from, and beside a scenario file that shadows one of its own
    (a generated warehouse saved as warehouse-small.toml); the scenario is scored on its map."""
    assert main(["generate", "--seed", "3", "--out", str(tmp_path / "warehouse-small.toml")]) == 0
    both = {"suites": ["warehouse-static"], "scenarios": [scenario],
            "quick": True, "seeds": [7], "localizer": [{"name": "ransac"}]}
    mixed = run_sweep(parse_sweep(both, folder=tmp_path), workers=1)
    alone = [run_sweep(parse_sweep({k: v for k, v in both.items() if k != axis},
                                   folder=tmp_path), workers=1).rows
             for axis in ("scenarios", "suites")]
    assert [row[0] for row in mixed.rows] == ["warehouse-static",
                                              f"static:{scenario.removesuffix('.toml')}"]
    assert mixed.rows == alone[0] + alone[1]
    availability = mixed.columns.index("availability")
    assert alone[0][0][availability] > 0.9  # the suite's frames answered on their own maps
