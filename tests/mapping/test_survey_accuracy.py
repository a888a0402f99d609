"""The acceptance drive (baselines/survey_accuracy.py): a 2-minute drive of warehouse-small from
its known start, no map but two anchors, surveyed by ``azgym survey`` itself; every beacon within
centimetres, and ransac on the surveyed map within 10 % of its p75 on the true map."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import azgym
from azgym.core import BeaconMap

pytest.importorskip("gtsam")
SCRIPT = Path(__file__).parents[2] / "baselines" / "survey_accuracy.py"


def _script():
    spec = importlib.util.spec_from_file_location("survey_accuracy", SCRIPT)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_survey_of_the_acceptance_drive(tmp_path: Path) -> None:
    script = _script()
    log_folder = script.drive_log(0, 0.75, tmp_path)
    frames = azgym.logs.read_log(log_folder).frames["time"]
    assert frames[-1] - frames[0] >= 120.0
    surveyed, printed = script.surveyed_map(log_folder, tmp_path / "surveyed")
    assert "surveyed 15 of 15 ids" in printed
    errors = np.array(list(script.beacon_errors(surveyed).values()))
    assert errors.size == 13
    assert np.median(errors) <= 0.03 and np.percentile(errors, 95) <= 0.08
    scenario = azgym.load_scenario(script.SCENARIO)
    true_map = BeaconMap(scenario.beacons.ids, scenario.beacon_positions, scenario.beacons.width)
    assert script.ransac_p75(log_folder, surveyed) <= 1.10 * script.ransac_p75(log_folder,
                                                                               true_map)
