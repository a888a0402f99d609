"""The benchmark's figures: one file per figure, written even for a localizer that never answers."""

from __future__ import annotations

import pytest

from azgym.bench.report.plots import write_figures
from azgym.bench.run.runner import Contender, run_benchmark
from azgym.bench.suites import get_suite

pytest.importorskip("matplotlib")

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def test_write_figures_draws_the_cdf_the_causes_and_one_error_map_per_scenario(tmp_path):
    # "absent" fails on every frame: its errors sit at +inf on the CDF and at the map's top.
    result = run_benchmark(get_suite("warehouse-static"),
                           [Contender("ransac", "ransac"),
                            Contender("absent", f"{tmp_path}/no_such_file.py:Nothing")],
                           quick=True)
    assert result.summary["localizers"]["absent"]["all"]["availability"] == 0.0
    written = write_figures(result.summary, result.cases, result.outcomes, tmp_path)
    scenarios = list(dict.fromkeys(case.scenario for case in result.cases))
    assert len(scenarios) > 1
    assert [path.name for path in written] == (
        ["cdf.png", "causes.png"] + [f"error_map_{name}.png" for name in scenarios])
    for path in written:
        assert path.parent == tmp_path
        assert path.read_bytes().startswith(PNG_SIGNATURE)


def test_driven_routes_also_get_their_trajectories_on_the_floor_plan(tmp_path):
    result = run_benchmark(get_suite("warehouse-routes"), [Contender("ransac", "ransac")],
                           quick=True)
    written = write_figures(result.summary, result.cases, result.outcomes, tmp_path)
    names = [path.name for path in written]
    assert names == ["cdf.png", "causes.png", "error_map_warehouse-small.png",
                     "trajectories_warehouse-small.png", "error_map_warehouse-paper.png",
                     "trajectories_warehouse-paper.png"]
    assert all(path.read_bytes().startswith(PNG_SIGNATURE) for path in written)
