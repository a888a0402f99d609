"""The reproduction's outputs: results files always, figures on request."""

from __future__ import annotations

import json

import pytest

from azgym.bench.run.runner import Contender
from azgym.bench.suites.paper import ProtocolConfig
from azgym.experiments.paper.report import write_outputs
from azgym.experiments.paper.reproduce import reproduce

pytest.importorskip("matplotlib")

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
TINY = ProtocolConfig(grid_step=4, realisations=1, outlier_counts=(0, 1, 3), seed=3)


@pytest.fixture(scope="module")
def tiny_reproduction():
    return reproduce(config=TINY, contenders=[Contender("ransac", "ransac"),
                                              Contender("lsq", "lsq")])


def test_write_outputs_draws_an_error_map_per_k_and_the_cdfs(tiny_reproduction, tmp_path):
    written = write_outputs(tiny_reproduction, tmp_path)
    assert [path.name for path in written] == [
        "results.json", "results.md", "runs.npz", "error_map_k0.png", "error_map_k1.png",
        "error_cdf.png"]
    assert json.loads((tmp_path / "results.json").read_text())["limit"].keys() == {"0", "1", "3"}
    for path in written[3:]:
        assert path.read_bytes().startswith(PNG_SIGNATURE)


def test_without_figures_only_the_results_are_written(tiny_reproduction, tmp_path):
    written = write_outputs(tiny_reproduction, tmp_path, figures=False)
    assert [path.name for path in written] == ["results.json", "results.md", "runs.npz"]
    assert not list(tmp_path.glob("*.png"))


def test_error_maps_are_drawn_only_for_ransac_and_mex(tmp_path):
    only_lsq = reproduce(config=TINY, contenders=[Contender("lsq", "lsq")])
    names = [path.name for path in write_outputs(only_lsq, tmp_path)]
    assert names == ["results.json", "results.md", "runs.npz", "error_cdf.png"]
