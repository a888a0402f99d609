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


@pytest.fixture(scope="module")
def robot_log(tmp_path_factory: pytest.TempPathFactory):
    from azgym.logs import export_route, read_log

    folder = tmp_path_factory.mktemp("robot") / "log"
    return read_log(export_route(azgym.load_scenario("robot-arena"), "wander-1", 0, folder))


def test_robot_arena_survey_is_accurate_and_its_covariances_honest(robot_log) -> None:
    """robot-arena (one or two beacons a frame, a drifting wheel odometry, no IMU), surveyed with
    the robot's own odometry errors: solved frame by frame, the map holds to centimetres, its
    covariances are not overconfident (the normalized errors squared average 2 when honest;
    4 is more than three standard errors above for a dozen beacons) and no beacon is called
    moved on the unchanged map."""
    from azgym.bench.suites.robot import contender_defaults
    from azgym.mapping import Prior, log_drives, settings_from_profile, survey

    scenario = azgym.load_scenario("robot-arena")
    log = robot_log
    result = survey(log_drives(log), Prior(log.beacons, (1, 2)),
                    settings_from_profile(contender_defaults()))
    truth = dict(zip(scenario.beacons.ids.tolist(), scenario.beacon_positions[:, :2],
                     strict=True))
    surveyed = [b for b, i in enumerate(result.ids.tolist())
                if result.observable[b] and i in truth and i not in (1, 2)]
    errors = np.array([result.xy[b] - truth[int(result.ids[b])] for b in surveyed])
    nees = [e @ np.linalg.solve(result.covariances[b], e) for b, e in
            zip(surveyed, errors, strict=True)]
    assert len(surveyed) >= 9
    assert np.median(np.hypot(*errors.T)) < 0.05
    assert np.mean(nees) < 4.0
    assert result.moved == ()


def test_robot_arena_survey_with_a_forklifts_motion_noise_places_nothing(robot_log) -> None:
    """The exported log's own profile leaves the motion noise out: the forklift's defaults are 40
    times too sure of a robot's turn rate. The solve then strains the azimuths beyond their
    error model, and the survey says so for every beacon instead of placing them decimetres off
    and calling them moved."""
    from azgym.mapping import Prior, log_drives, settings_from_profile, survey

    result = survey(log_drives(robot_log), Prior(robot_log.beacons, (1, 2)),
                    settings_from_profile(robot_log.manifest.profile))
    assert result.moved == ()
    assert set(result.ids[result.observable].tolist()) == {1, 2}  # the anchors alone
    strained = [r for r in result.reasons if r.startswith("the azimuths strain")]
    assert len(strained) >= 9
