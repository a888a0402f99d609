"""``--profile``: a profile's hyperparameters are every contender's defaults (a spec's own win),
resolved in the worker; on a suite it sets the simulator's sensor and motion noise too."""

from __future__ import annotations

import inspect
import json
import math
import re
import shutil
import textwrap

import numpy as np
import pytest

from azgym.bench.leaderboard.entries import LeaderboardError, submit
from azgym.bench.run.contenders import Contender, contender
from azgym.bench.run.profiles import SimulatedNoise, contender_params
from azgym.bench.run.runner import run_benchmark, run_contenders, run_log_benchmark
from azgym.bench.suites import SUITES, get_suite
from azgym.bench.suites.data import log_profile
from azgym.bench.suites.warehouse import scenario_suite
from azgym.cli import main
from azgym.errors import InvalidInputError
from azgym.logs import read_log
from azgym.profile import MotionProfile, Profile, SensorProfile, VehicleProfile
from azgym.sensing.motion import DifferentialOdometryModel, ImuSamples, Motion, OdometrySamples
from azgym.site import load_scenario

WIDE = Profile(sensor=SensorProfile(delta_alpha_d=0.05))
"""A profile that widens ransac's tolerance far from its default (0.4°)."""
REPORTER = '''
import numpy as np
import azgym


class Reporter:
    """Answers x = 1000 delta_alpha_d, y = how many hyperparameters it was given."""

    def __init__(self, *, delta_alpha_d=0.0, tag="plain"):
        self.delta_alpha_d, self.given = delta_alpha_d, (delta_alpha_d != 0.0) + (tag != "plain")

    def localize(self, measurements, beacons):
        return azgym.Estimate(1000.0 * self.delta_alpha_d, float(self.given), 0.0,
                              np.ones(len(measurements), dtype=bool))


class Anything:
    """Takes any keyword (**given), none of them by name: answers x = how many it got."""

    def __init__(self, **given):
        self.count = len(given)

    def localize(self, measurements, beacons):
        return azgym.Estimate(float(self.count), 0.0, 0.0, np.ones(len(measurements), dtype=bool))
'''


@pytest.fixture(scope="module")
def cases():
    return get_suite("warehouse-static").build(7, True)[::15]  # clean, as shipped and heavy


@pytest.fixture(scope="module")
def reporter(tmp_path_factory):
    path = tmp_path_factory.mktemp("plugins") / "reporter.py"
    path.write_text(textwrap.dedent(REPORTER))
    return str(path)


def answered_x(outcome):
    assert outcome.ok.all(), outcome.errors[:1]
    return set(outcome.estimate[:, 0].round(9))


def same_answers(a, b):
    return np.array_equal(a.estimate, b.estimate, equal_nan=True) and np.array_equal(a.ok, b.ok)


def test_a_profile_s_delta_alpha_d_reaches_ransac_in_its_worker(cases):
    plain, profiled = (run_contenders(cases, [contender("ransac"), contender("ransac-weighted")],
                                      profile=profile) for profile in (None, WIDE))
    by_spec = run_contenders(cases, [contender("ransac:delta_alpha_d=0.05"),
                                     contender("ransac:delta_alpha_d=0.05,weighted=true")])
    assert set(profiled) == {"ransac", "ransac-weighted"}  # labels as written
    assert same_answers(profiled["ransac"], by_spec["ransac:delta_alpha_d=0.05"])
    assert same_answers(profiled["ransac-weighted"],
                        by_spec["ransac:delta_alpha_d=0.05,weighted=true"])  # the preset's class
    assert not same_answers(profiled["ransac"], plain["ransac"])
    assert not same_answers(profiled["ransac-weighted"], plain["ransac-weighted"])


def test_a_spec_s_own_hyperparameter_wins_and_a_plugin_gets_only_names_it_takes(cases, reporter):
    profile = Profile(sensor=SensorProfile(delta_alpha_d=0.02, coverage=False),
                      motion=MotionProfile(speed_noise=0.1))
    outcomes = run_contenders(cases, [
        Contender("profiled", f"{reporter}:Reporter"),
        Contender("own", f"{reporter}:Reporter", {"delta_alpha_d": 0.005}),
        Contender("inline", f"{reporter}:Reporter:delta_alpha_d=0.007"),
        Contender("anything", f"{reporter}:Anything")], profile=profile)
    assert answered_x(outcomes["profiled"]) == {20.0}
    assert set(outcomes["profiled"].estimate[:, 1]) == {1.0}  # coverage, speed_noise: not taken
    assert answered_x(outcomes["own"]) == {5.0}
    assert answered_x(outcomes["inline"]) == {7.0}
    assert answered_x(outcomes["anything"]) == {0.0}  # **kwargs names no hyperparameter


def test_the_runner_does_not_import_a_plugin_to_apply_a_profile(cases, reporter, tmp_path):
    marker = tmp_path / "imported"
    path = tmp_path / "loud.py"
    path.write_text(f"open({str(marker)!r}, 'a').write('x')\n" + textwrap.dedent(REPORTER))
    outcome = run_contenders(cases[:2], [Contender("loud", f"{path}:Reporter")],
                             profile=WIDE)["loud"]
    assert answered_x(outcome) == {50.0}
    assert len(marker.read_text()) == 1  # in its one worker, not here


def test_contender_params_merges_the_profile_under_the_spec():
    profile = Profile(vehicle=VehicleProfile(kind="forklift"), sensor=SensorProfile(
        delta_alpha_d=0.03, field_of_view=1.0))
    assert contender_params("ransac", {}, profile) == {"delta_alpha_d": 0.03}
    assert contender_params("ransac-weighted", {"delta_alpha_d": 0.01}, profile) == {
        "delta_alpha_d": 0.01}
    assert contender_params("ransac:delta_alpha_d=0.01", {}, profile) == {}
    assert contender_params("ransac", {"max_iter": 5}, None) == {"max_iter": 5}


@pytest.mark.slow
@pytest.mark.ray
def test_ray_workers_apply_the_profile_as_local_ones(cases, reporter):
    pytest.importorskip("ray", reason="ray is not installed")
    contenders = [Contender("profiled", f"{reporter}:Reporter"), contender("ransac")]
    local = run_contenders(cases[:6], contenders, profile=WIDE)
    on_ray = run_contenders(cases[:6], contenders, profile=WIDE, backend="ray", workers=1)
    assert answered_x(on_ray["profiled"]) == {50.0}
    assert same_answers(on_ray["ransac"], local["ransac"])


def azimuth_residuals(cases):
    """Measured minus true azimuth of every detection of the clean frames [rad]."""
    residuals = []
    for case in cases:
        if case.cause != "clean":
            continue
        beacons = load_scenario(case.scenario).beacons
        index = beacons.index_of(case.measurements.ids)
        x, y, heading = case.pose
        true = np.arctan2(beacons.xyz[index, 1] - y, beacons.xyz[index, 0] - x) - heading
        residuals.append(np.remainder(case.measurements.azimuth - true + np.pi, 2 * np.pi) - np.pi)
    return np.concatenate(residuals)


def test_a_profiled_suite_draws_the_azimuth_noise_it_sets():
    suite = get_suite("warehouse-static")
    half_width = math.radians(2.0)
    profiled = suite.profiled(Profile(sensor=SensorProfile(delta_alpha_d=half_width)))
    residuals = azimuth_residuals(profiled.build(7, True))
    assert residuals.size > 500
    assert abs(residuals.std() / (half_width / math.sqrt(3)) - 1) < 0.05  # uniform on ±Δα_d
    assert half_width * 0.95 < np.abs(residuals).max() <= half_width
    assert azimuth_residuals(suite.build(7, True)).std() < half_width / 4  # as shipped: 0.4°


def motion_figures(cases):
    """(true over read distance, white speed noise, white turn-rate noise) of a route's cases."""
    driven = read = 0.0
    speed, turn = [], []
    for before, case in zip(cases, cases[1:], strict=False):
        if case.motion is None or case.sequence != before.sequence:
            continue
        driven += math.dist(case.pose[:2], before.pose[:2])
        odometry = case.motion.odometry
        read += float(np.sum(odometry.speed * 0.02))  # 50 Hz
        speed.append(odometry.speed)
        turn.append(case.motion.imu.yaw_rate)
    white = [float(np.std(np.diff(np.concatenate(x)))) / math.sqrt(2) for x in (speed, turn)]
    return driven / read, *white


def test_a_profiled_route_suite_draws_the_motion_noise_it_sets():
    suite = get_suite("warehouse-routes")
    plain = motion_figures(suite.build(11, True))
    profile = Profile(motion=MotionProfile(speed_factor=1.25, speed_noise=0.2,
                                           turn_rate_noise=0.05))
    factor, speed_noise, turn_noise = motion_figures(suite.profiled(profile).build(11, True))
    assert abs(factor / plain[0] - 1.25) < 0.02  # the same drive, read 1/1.25 short
    assert abs(speed_noise / 0.2 - 1) < 0.05 and plain[1] < 0.05
    assert abs(turn_noise / 0.05 - 1) < 0.1 and plain[2] < 0.02


def test_simulated_noise_sets_each_model_and_leaves_the_rest_as_shipped():
    noise = SimulatedNoise(Profile(sensor=SensorProfile(coverage=False), motion=MotionProfile(
        speed_factor=2.0, scale_walk=0.01, bias_walk=0.003, speed_scale=0.1)))
    scenario = load_scenario("warehouse-small")
    assert noise.scenario(scenario).error_model.coverage is False
    assert noise.scenario(scenario).error_model.delta_alpha_d == \
        scenario.error_model.delta_alpha_d
    odometry, gyro = noise.odometry(), noise.imu()
    assert (odometry.scale_walk, odometry.speed_noise) == (0.01, 0.04)  # halved when read
    assert (gyro.gyro_bias_walk, gyro.gyro_noise) == (0.003, 0.005)
    robot = noise.differential_odometry(DifferentialOdometryModel())
    assert (robot.speed_factor, robot.speed_scale, robot.speed_noise) == (2.0, 0.1, 0.01)
    time, speed, none = np.array([0.1, 0.2]), np.array([1.0, 1.2]), np.zeros(2)
    imu = ImuSamples(none, none, np.zeros((2, 2)), none)
    steered = Motion(0.2, OdometrySamples(time, speed, none), imu)
    turning = Motion(0.2, OdometrySamples.turning(time, speed, none), imu)
    assert noise.read(steered).odometry.speed.tolist() == [0.5, 0.6]  # true / read = 2
    assert noise.read(turning) is turning  # a differential drive's model applies its own
    as_shipped = SimulatedNoise()
    assert as_shipped.scenario(scenario) is scenario
    assert as_shipped.odometry() is None and as_shipped.imu() is None


def test_every_registered_suite_that_simulates_takes_the_noise():
    for name, suite in SUITES.items():
        if suite.simulates:
            assert "noise" in inspect.signature(suite.build).parameters, name


def test_a_profiled_run_records_its_profile_and_is_not_the_plain_suite(tmp_path, capsys):
    suite = get_suite("warehouse-static")
    shown = []
    result = run_benchmark(suite, [contender("lsq")], quick=True, profile=WIDE,
                           progress=shown.append)
    plain = run_benchmark(suite, [contender("lsq")], quick=True)
    again = run_benchmark(suite.profiled(WIDE), [contender("lsq")], quick=True)
    assert result.summary["profile"] == again.summary["profile"] == {
        "sensor": {"delta_alpha_d": 0.05}}
    assert plain.summary["profile"] == {}
    assert result.summary["cases_sha256"] == again.summary["cases_sha256"] != \
        plain.summary["cases_sha256"]
    assert "  profile: sensor.delta_alpha_d=0.05 (simulated, and the contenders' defaults)" \
        in shown
    result.write(tmp_path / "run", figures=False)
    with pytest.raises(LeaderboardError, match="profile_given: the run was given a profile"):
        submit(tmp_path / "run", "lsq", tmp_path / "entries", name="wide", version="1",
               authors=["A. B."])
    # A forged results.json that hides the profile is caught by its frames.
    summary = json.loads((tmp_path / "run" / "results.json").read_text())
    summary["profile_given"] = {}
    (tmp_path / "run" / "results.json").write_text(json.dumps(summary))
    with pytest.raises(LeaderboardError, match="cases_sha256: the entry was scored on other "
                                               "frames"):
        submit(tmp_path / "run", "lsq", tmp_path / "entries", name="wide", version="1",
               authors=["A. B."])


def test_a_suite_refuses_a_profile_it_cannot_simulate():
    forklift = get_suite("warehouse-routes")
    robot = Profile(vehicle=VehicleProfile(kind="differential-drive"))
    with pytest.raises(InvalidInputError, match="profile: vehicle.kind is 'differential-drive', "
                                                "but warehouse-routes's routes are driven by a "
                                                "forklift"):
        forklift.profiled(robot)
    get_suite("warehouse-static").profiled(robot)  # frames on their own: no vehicle to differ
    with pytest.raises(InvalidInputError, match="drawn with a profile already"):
        forklift.profiled(WIDE).profiled(WIDE)
    with pytest.raises(InvalidInputError, match="static:warehouse-small takes no profile"):
        scenario_suite(load_scenario("warehouse-small")).profiled(WIDE)


def write_profile(folder, text):
    path = folder / "profile.toml"
    path.write_text(textwrap.dedent(text))
    return str(path)


@pytest.fixture
def sensed_log(tmp_path):
    """Roh's log, its [sensor] section set to Δα_d = 0.05 rad without coverage errors."""
    folder = tmp_path / "sensed"
    shutil.copytree(read_log("roh").folder, folder)
    manifest = folder / "log.toml"
    manifest.write_text(re.sub(r"\[sensor\][^\[]*", "", manifest.read_text())
                        + "\n[sensor]\ndelta_alpha_d = 0.05\ncoverage = false\n")
    return folder


def test_bench_on_a_log_applies_the_file_over_the_log_s_own_profile(sensed_log, tmp_path,
                                                                    reporter, capsys):
    log = read_log(sensed_log)
    profile = write_profile(tmp_path, "[sensor]\ncoverage = true\n[motion]\nspeed_noise = 0.1\n")
    out = tmp_path / "out"
    assert main(["bench", "--data", str(sensed_log), "--localizer", f"{reporter}:Reporter",
                 "--workers", "1", "--profile", profile, "--out", str(out)]) == 0
    summary = json.loads((out / "results.json").read_text())
    assert summary["profile"] == {"sensor": {"delta_alpha_d": 0.05, "coverage": True},
                                  "motion": {"speed_noise": 0.1}}
    assert "  profile: sensor.delta_alpha_d=0.05, sensor.coverage=true, motion.speed_noise=0.1 " \
           "(the contenders' defaults)" in capsys.readouterr().out
    override = log_profile(log, Profile(sensor=SensorProfile(delta_alpha_d=0.01)))
    assert override.sensor.delta_alpha_d == 0.01 and override.sensor.coverage is False
    for profile, x in ((None, 50.0), (Profile(sensor=SensorProfile(delta_alpha_d=0.01)), 10.0)):
        result = run_log_benchmark(log, [Contender("reporter", f"{reporter}:Reporter")],
                                   profile=profile)
        assert answered_x(result.outcomes["reporter"]) == {x}
        assert result.summary["profile"]["sensor"]["delta_alpha_d"] == x / 1000


@pytest.mark.parametrize(("argv", "message"), [
    (["--profile", "{bad}"],
     r"profile '.*bad\.toml':\n  sensor\.delta_alpha_d: must be a finite number \[rad\], "
     r"got .wide."),
    (["--profile", "{missing}"], r"profile '.*missing\.toml': no such file"),
    (["--profile", "{bad}", "--data", "roh"],
     r"sensor\.delta_alpha_d: must be a finite number \[rad\], got .wide."),
    (["--profile", "{good}", "--suite", "navigation"], "--profile is not for a navigation suite: "
                                                        "a navigation suite runs each localizer "
                                                        "with its own defaults"),
    (["--profile", "{good}", "--navigator", "ppo"], "--navigator is not for a frame suite"),
    (["--profile", "{robot}", "--suite", "warehouse-routes"], "vehicle.kind is "
                                                               "'differential-drive'"),
    (["--profile", "{edge}"], r"sensor\.delta_alpha_d: must be in \[0, 1\.5708\) rad"),
])
def test_bench_refuses_a_bad_profile_by_file_and_field(argv, message, tmp_path, capsys):
    files = {"bad": "[sensor]\ndelta_alpha_d = \"wide\"\n", "good": "[sensor]\ncoverage = true\n",
             "robot": "[vehicle]\nkind = \"differential-drive\"\n",
             "edge": f"[sensor]\ndelta_alpha_d = {math.pi / 2!r}\n"}  # a profile's, not ransac's
    paths = {"missing": str(tmp_path / "missing.toml")}
    for name, text in files.items():
        (tmp_path / f"{name}.toml").write_text(text)
        paths[name] = str(tmp_path / f"{name}.toml")
    out = tmp_path / "out"
    assert main(["bench", *(a.format(**paths) for a in argv), "--out", str(out)]) == 2
    assert re.search(message, capsys.readouterr().err)
    assert not out.exists()


def test_bench_refuses_an_empty_profile_name(capsys):
    with pytest.raises(SystemExit) as stopped:
        main(["bench", "--profile", ""])
    assert stopped.value.code == 2
    assert "argument --profile: is empty: give a profile file" in capsys.readouterr().err


def test_a_run_given_a_profile_is_no_leaderboard_entry(tmp_path) -> None:
    """A run with --profile is scored with other defaults than the suite's: submit refuses it,
    even where the profile sets nothing the simulator draws (the frames would match)."""
    from azgym.bench.leaderboard.entries import make_entry

    (tmp_path / "results.json").write_text(json.dumps({
        "localizers": {"ransac": {}}, "profile_given": {"sensor": {"field_of_view": 1.0}}}))
    with pytest.raises(LeaderboardError, match="profile_given: the run was given a profile"):
        make_entry(tmp_path, "ransac", tmp_path, name="x", version="1", authors=["a"], link="")


def test_the_summary_says_which_profile_was_given(tmp_path) -> None:
    """profile_given is empty on a plain run, even where the suite gives its own defaults."""
    plain = run_benchmark(SUITES["robot-routes"], [contender("ransac")], quick=True)
    assert plain.summary["profile_given"] == {}
    assert plain.summary["profile"]["vehicle"]["kind"] == "differential-drive"
    given = run_benchmark(SUITES["robot-routes"], [contender("ransac")], quick=True,
                          profile=Profile(sensor=SensorProfile(field_of_view=1.0)))
    assert given.summary["profile_given"] == {"sensor": {"field_of_view": 1.0}}
    assert given.summary["profile"]["sensor"]["field_of_view"] == 1.0
