"""The benchmark runner: repeatable figures, honest failures, plug-ins that misbehave."""

from __future__ import annotations

import json
import textwrap

import numpy as np
import pytest

from azgym.bench.report.table import ranked_table
from azgym.bench.run.runner import Contender, run_benchmark
from azgym.bench.suites import CAUSES, SUITES, get_suite
from azgym.cli import main
from azgym.errors import InvalidInputError

FIGURES = ("n", "availability", "failure_rate", "mean_cm", "median_cm", "p75_cm", "p95_cm",
           "max_cm", "heading_mean_deg")


def figures(summary):
    return {label: {key: row["all"][key] for key in FIGURES}
            for label, row in summary["localizers"].items()}


@pytest.fixture(scope="module")
def quick_static():
    return run_benchmark(get_suite("warehouse-static"), [Contender("ransac", "ransac"),
                                                         Contender("lsq", "lsq")], quick=True)


@pytest.mark.slow
def test_two_workers_give_the_same_figures_as_one(quick_static):
    parallel = run_benchmark(get_suite("warehouse-static"), [Contender("ransac", "ransac"),
                                                             Contender("lsq", "lsq")],
                             quick=True, workers=2)
    assert figures(parallel.summary) == figures(quick_static.summary)


def test_the_dev_split_is_fixed_and_the_test_split_draws_a_reported_seed(quick_static):
    assert quick_static.summary["seed"] == get_suite("warehouse-static").dev_seed
    test = run_benchmark(get_suite("stress"), [Contender("ransac", "ransac")], quick=True,
                         split="test")
    assert test.summary["split"] == "test" and isinstance(test.summary["seed"], int)


@pytest.mark.slow
def test_every_suite_draws_frames_with_known_causes():
    for name, suite in SUITES.items():
        frames = suite.build(suite.dev_seed, True)
        assert len(frames) > 20, name
        assert {frame.cause for frame in frames} <= set(CAUSES)
    static = SUITES["warehouse-static"].build(7, True)
    groups = {frame.group: set() for frame in static}
    for frame in static:
        groups[frame.group].add(frame.cause)
    assert groups["warehouse-small, clean"] <= {"clean", "partial"}
    assert "ghost" in groups["warehouse-small, heavy"] | groups["warehouse-paper, heavy"]


def test_ransac_beats_lsq_where_there_are_faults(quick_static):
    rows = quick_static.summary["localizers"]
    assert rows["ransac"]["all"]["p75_all_cm"] < rows["lsq"]["all"]["p75_all_cm"]
    assert rows["ransac"]["by_cause"]["clean"]["median_cm"] < 5.0
    assert rows["ransac"]["runtime_us"]["ratio_to_ransac"] == 1.0
    table = ranked_table(quick_static.summary)
    assert table.splitlines()[3].split()[1] == "ransac"  # ranked first by the headline


def test_a_crashing_plugin_is_scored_unavailable_and_never_stops_the_run(tmp_path):
    plugin = tmp_path / "flaky.py"
    plugin.write_text(textwrap.dedent("""
        import azgym

        class Flaky:
            def __init__(self):
                self.calls = 0
                self.ransac = azgym.make_localizer("ransac")

            def localize(self, measurements, beacons):
                self.calls += 1
                if self.calls % 2:
                    raise RuntimeError("every other frame")
                return self.ransac.localize(measurements, beacons)
    """))
    spec = f"{plugin}:Flaky"
    result = run_benchmark(get_suite("stress"), [Contender("flaky", spec)], quick=True)
    row = result.summary["localizers"]["flaky"]
    assert row["crashes"] > 0 and "every other frame" in row["first_error"]
    assert 0.3 < row["all"]["availability"] < 0.7
    assert np.isnan(result.outcomes["flaky"].position[~result.outcomes["flaky"].ok]).all()
    broken = run_benchmark(get_suite("stress"), [Contender("missing", f"{tmp_path}/no.py:X")],
                           quick=True)
    assert broken.summary["localizers"]["missing"]["all"]["availability"] == 0.0


def test_a_pose_with_a_nan_or_infinite_part_is_scored_as_no_estimate(tmp_path):
    plugin = tmp_path / "nan_heading.py"
    plugin.write_text(textwrap.dedent("""
        import dataclasses, math
        import azgym

        class NanHeading:
            def __init__(self):
                self.ransac = azgym.make_localizer("ransac")
                self.calls = 0

            def localize(self, measurements, beacons):
                self.calls += 1
                estimate = self.ransac.localize(measurements, beacons)
                bad = (math.nan, math.inf, -math.inf)[self.calls % 3]
                if self.calls % 10 == 0:  # a truthy string is not ok=True
                    return dataclasses.replace(estimate, ok="False")
                return dataclasses.replace(estimate, heading=bad) if self.calls % 2 else estimate
    """))
    result = run_benchmark(get_suite("stress"), [Contender("nan", f"{plugin}:NanHeading")],
                           quick=True)
    row, outcome = result.summary["localizers"]["nan"], result.outcomes["nan"]
    assert row["crashes"] > 0 and "Estimate.ok must be True or False" in row["first_error"]
    assert 0.3 < row["all"]["availability"] < 0.7
    assert np.isfinite(outcome.heading[outcome.ok]).all()


def test_cli_default_run_prints_a_ranked_table_and_writes_results(tmp_path, capsys):
    assert main(["bench", "--out", str(tmp_path), "--workers", "1"]) == 0
    printed = capsys.readouterr().out
    assert "warehouse-static v1 (dev, seed 7, quick)" in printed
    summary = json.loads((tmp_path / "results.json").read_text())
    assert set(summary["localizers"]) == {"ransac", "ransac-weighted", "loo", "lsq", "triplet",
                                          "mex-coarse"}
    lines = (tmp_path / "frames.csv").read_text().splitlines()
    assert len(lines) == 1 + 6 * summary["n_frames"]




@pytest.mark.parametrize("name", ["warehouse-routes", "image-routes", "route-events"])
def test_a_suite_of_driven_routes_has_no_secret_test_split(name):
    # Its routes are the same for every seed: a test split's true poses would be the dev split's.
    suite = get_suite(name)
    dev = suite.build(suite.dev_seed, True)
    other = suite.build(suite.dev_seed + 1, True)
    assert [case.pose for case in dev] == [case.pose for case in other]
    with pytest.raises(InvalidInputError, match=rf"split: {name} has no test split: its routes "
                                               r"are the same for every seed"):
        run_benchmark(suite, split="test", quick=True)
