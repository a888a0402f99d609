"""The navigation suites: ``azgym bench --suite navigation`` runs navigators × localizers in closed
loop, the same figures whatever the workers; a results file is checked as an adversary's edit
would be (each tampering refused by name), reruns reproduce it, and the board shows it."""

from __future__ import annotations

import json
from pathlib import Path

import gymnasium as gym
import pytest
from helpers import quick_navigation_run

from azgym import cli
from azgym.bench.leaderboard import board
from azgym.bench.leaderboard.entry_files import LeaderboardError
from azgym.bench.navigation.benchmark import contenders_of, drive_all, navigation_contenders
from azgym.bench.navigation.board import verify_navigation
from azgym.bench.navigation.results_file import load_navigation
from azgym.bench.navigation.scoring import wilson_interval
from azgym.bench.navigation.suites import NAVIGATION_SUITES, NAVIGATORS, get_navigation_suite

SUITE = NAVIGATION_SUITES["navigation"]
SHIPPED_ENTRIES = Path(__file__).parents[2] / "leaderboard" / "entries"


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A quick dev run of pure pursuit with truth and ransac, through the command."""
    return quick_navigation_run(tmp_path_factory.mktemp("nav"), "truth", "ransac")


def _edited(tmp_path, run, edit):
    data = json.loads(run.read_text())
    edit(data)
    path = tmp_path / "navigation.json"
    path.write_text(json.dumps(data))
    return path


def test_a_quick_run_drives_each_contender_on_the_suites_episodes(run, capsys):
    data = load_navigation(run)
    assert (data["suite"], data["split"], data["seed"], data["episodes"]) == (
        "navigation", "dev", SUITE.dev_seed, SUITE.quick_episodes)
    truth, ransac = data["contenders"]
    assert (truth["localizer"], ransac["localizer"]) == ("truth", "ransac")
    assert [e["seed"] for e in truth["episodes"]] == list(range(2300, 2310))
    assert truth["summary"]["success"] >= 0.9 and truth["summary"]["error_median_cm"] == 0.0
    assert 0.5 < ransac["summary"]["answered"] < 1.0  # ransac abstains on some frames
    # both drove the same start and goal spots, so their shortest paths are the same
    assert [e["shortest_path_m"] for e in truth["episodes"]] == [
        e["shortest_path_m"] for e in ransac["episodes"]]


def test_workers_do_not_change_the_figures(run):
    data = json.loads(run.read_text())
    parallel = drive_all(SUITE, [("pure-pursuit", "truth"), ("pure-pursuit", "ransac")],
                         data["seed"], data["episodes"], workers=2)
    for claimed, fresh in zip(data["contenders"], parallel, strict=True):
        assert claimed["episodes"] == fresh["episodes"]


def test_a_rerun_reproduces_the_file_and_finds_an_edited_error_figure(run, tmp_path):
    assert verify_navigation(run) == {}
    p95 = json.loads(run.read_text())["contenders"][1]["summary"]["error_p95_cm"]
    path = _edited(tmp_path, run, lambda d: d["contenders"][1]["summary"].update(
        error_p95_cm=p95 + 100.0))  # not recomputable from the episodes: only a rerun finds it
    assert verify_navigation(path) == {"contenders/1/summary/error_p95_cm": (p95 + 100.0, p95)}


def _fail(episode, spl=0.0):
    """An episode made a failure, by the environment's rules but for ``spl``."""
    episode.update(success=False, steps=600, time_s=60.0, spl=spl)


def _set_success(data):
    data["contenders"][0]["summary"]["success"] = 1.0
    _fail(data["contenders"][0]["episodes"][0])


@pytest.mark.parametrize(("edit", "message"), [
    (lambda d: d.update(kind="frames"), "not a navigation results file"),
    (lambda d: d.update(format=1), "format must be 2"),
    (lambda d: d.update(suite="stress"), "'stress' is not a navigation suite"),
    (lambda d: d.update(suite_version=2), "suite_version 2: navigation is at version 3"),
    (lambda d: d.update(env_kwargs={"sensor": "image"}), "env and env_kwargs must be the suite"),
    (lambda d: d.update(seed=5), "a dev run uses the suite's seed 2300"),
    (lambda d: d.update(seed=-1), r"seed must be an integer in \[0, 2147483648\), got -1"),
    (lambda d: d.update(seed=2300.0), r"seed must be an integer in \[0, 2147483648\), got 2300.0"),
    (lambda d: d.update(split="test"), "a dev run uses the suite's seed 2300"),
    (lambda d: d.update(quick=False), "episodes must be 100"),
    (lambda d: d.update(contenders=[]), "contenders must be a list of 1 to 64"),
    (lambda d: d["contenders"][0].update(navigator="mine.zip"),
     "'mine.zip' is not a built-in navigator"),
    (lambda d: d["contenders"][0].update(localizer="mine.py:Mine"),
     "'mine.py:Mine' is not a built-in localizer"),
    (lambda d: d["contenders"][0]["episodes"].pop(), "must be the suite's 10 episodes"),
    (lambda d: d["contenders"][0]["episodes"].reverse(), "seeds 2300 to 2309 in order"),
    (lambda d: d["contenders"][0]["summary"].update(spl=0.999), "summary/spl: the file says"),
    (lambda d: d["contenders"][1]["summary"].update(success_interval=[0.9, 1.0]),
     "summary/success_interval"),
    (_set_success, "summary/success: the file says 1.0, its episodes give 0.9"),
    (lambda d: _fail(d["contenders"][0]["episodes"][3], spl=0.5),
     r"episodes/3/spl: must be 0.0: .*a failed episode has SPL 0"),
    (lambda d: d["contenders"][0]["episodes"][3].update(answered_steps=10**6),
     "answered_steps: more than its steps"),
    (lambda d: d["contenders"][0]["episodes"][3].update(collisions=-1),
     "collisions: must be a whole number"),
    (lambda d: d["contenders"][0]["episodes"][3].update(spl="1"), "episodes/3/spl: must be"),
    (lambda d: d.update(extra=1), r"unknown keys \['extra'\]"),
    (lambda d: d["contenders"][0].pop("runtime_s"), r"contenders/0: missing keys \['runtime_s'\]"),
    (lambda d: d["contenders"][0]["episodes"][0].update(note="x"), r"episodes/0: unknown keys"),
    (lambda d: d["contenders"].append(d["contenders"][0]),
     r"pure-pursuit \+ truth is in the file twice"),
    (lambda d: d["contenders"][0].update(runtime_s=-1), "runtime_s: must be a number"),
    (lambda d: d["contenders"][0].update(localizer="ransac:pr_hit=7"), "does not build"),
    (lambda d: d["contenders"][0]["episodes"][2].update(time_s=0.1),
     "episodes/2/time_s: must be its steps times 0.1 s"),
    (lambda d: d["contenders"][0]["episodes"][2].update(success=False, spl=0.0),
     "episodes/2/steps: an episode lasts 1 to 600 steps, and a failed one all 600"),
    (lambda d: d["contenders"][0]["episodes"][2].update(spl=1.0),
     r"pure-pursuit \+ truth\)/episodes/2/spl: must be 0\.8822"),
    (lambda d: d["contenders"][0]["episodes"][2].update(shortest_path_m=0),
     "shortest_path_m must be a number > 0"),
    (lambda d: d["contenders"][0]["episodes"][2].update(shortest_path_m=5.0),
     r"contenders/0 \(pure-pursuit \+ truth\)/episodes/2/shortest_path_m: the geodesic "
     r"shortest path of seed 2302's start and goal is 25\.8603"),
    (lambda d: d["contenders"][1]["episodes"][2].update(travelled_m=100.0),
     r"contenders/1 \(pure-pursuit \+ ransac\)/episodes/2/travelled_m: 100 m in [\d.]+ s is "
     r"more than the forklift can drive from rest in that time \([\d.]+ m at full throttle, "
     r"1\.5 m/s² up to 3\.97 m/s\)"),
    (lambda d: d["contenders"][0]["episodes"][2].update(
        travelled_m=0.9 * d["contenders"][0]["episodes"][2]["shortest_path_m"], spl=1.0),
     r"episodes/2/travelled_m: [\d.]+ m to the goal is no longer than the geodesic shortest "
     r"path, [\d.]+ m, which a drive cannot match"),
    (lambda d: d["contenders"][1]["summary"].update(error_median_cm=-5.0),
     "summary: error_median_cm and error_p95_cm must be numbers"),
    (lambda d: d["contenders"][1]["summary"].update(error_median_cm="1"),
     "summary: error_median_cm and error_p95_cm must be numbers"),
    (lambda d: d["contenders"][1]["episodes"][0].update(error_p95_cm=None),
     "episodes/0: error_median_cm and error_p95_cm must be numbers"),
    (lambda d: d["contenders"][0]["summary"].update(success=True),
     "summary/success: the file says True"),
    (lambda d: d.update(timestamp="x" * 65), "timestamp: must be a text of at most 64"),
])
def test_an_edited_file_is_refused_by_name(run, tmp_path, edit, message):
    with pytest.raises(LeaderboardError, match=message):
        load_navigation(_edited(tmp_path, run, edit))


def test_a_file_with_nan_is_refused(run, tmp_path):
    path = _edited(tmp_path, run, lambda d: d["contenders"][0]["episodes"][0].update(
        spl=float("nan")))  # json writes NaN, which is no JSON number
    with pytest.raises(LeaderboardError, match="NaN is not a JSON number"):
        load_navigation(path)


def test_the_board_shows_the_navigation_tables(run, tmp_path):
    entries = tmp_path / "entries"
    entries.mkdir()
    navigation = tmp_path / "navigation"
    navigation.mkdir()
    (navigation / "navigation-dev-quick.json").write_text(run.read_text())
    # a frame entry is needed for a board; borrow one of the shipped ones
    for name in ("ransac-paper.json", "ransac-paper.frames.csv.gz"):
        (entries / name).write_bytes((SHIPPED_ENTRIES / name).read_bytes())
    readme, page = board.build(entries, tmp_path / "out", navigation)
    text = readme.read_text()
    assert "## navigation — closed loop" in text
    assert "### dev split (seed 2300), quick size, 10 episodes per contender" in text
    row = next(line for line in text.splitlines() if "| pure-pursuit | truth |" in line)
    assert row.startswith("| 1 | pure-pursuit | truth | 100 [72, 100] |")
    assert 'id="board-navigation-dev-2300-quick"' in page.read_text()


def test_the_board_refuses_an_unsound_navigation_file(run, tmp_path):
    navigation = tmp_path / "navigation"
    navigation.mkdir()
    data = json.loads(run.read_text())
    data["contenders"][0]["localizer"] = "evil.py:Cheat"
    (navigation / "x.json").write_text(json.dumps(data))
    entries = tmp_path / "entries"  # the navigation file is what is refused: one frame entry
    entries.mkdir()
    for name in ("ransac-paper.json", "ransac-paper.frames.csv.gz"):
        (entries / name).write_bytes((SHIPPED_ENTRIES / name).read_bytes())
    with pytest.raises(LeaderboardError, match="evil.py:Cheat"):
        board.build(entries, tmp_path / "out", navigation)


def test_wilson_interval_matches_hand_worked_values():
    # 10/10: centre (1 + z²/20) / (1 + z²/10), half z·sqrt(z²/400) / (1 + z²/10)
    low, high = wilson_interval(10, 10)
    assert high == pytest.approx(1.0) and low == pytest.approx(0.7225, abs=1e-4)
    low, high = wilson_interval(5, 10)
    assert (low, high) == (pytest.approx(0.2366, abs=1e-4), pytest.approx(0.7634, abs=1e-4))


@pytest.mark.parametrize(("argv", "message"), [
    (["--suite", "navigation", "--time-limit", "3"],
     "--time-limit, --backend, --address or --profile"),
    (["--suite", "navigation", "--backend", "ray"],
     "in the loop that drives the forklift: it takes no"),
    (["--suite", "stress", "--navigator", "ppo"], "--navigator is for the navigation suites"),
    (["--suite", "navigatoin"], "Did you mean 'navigation'"),
    (["--suite", "navigation", "--navigator", "nope.zip"], "nope.zip: no such file"),
    (["--suite", "navigation", "--localizer", "nope"], "unknown localizer 'nope'"),
])
def test_bad_navigation_bench_arguments_are_refused_by_name(argv, message, tmp_path, capsys):
    assert cli.main(["bench", *argv, "--out", str(tmp_path)]) == 2
    assert message in capsys.readouterr().err


def test_a_navigation_suite_chooses_its_localizers_by_the_frame_suites_rule():
    """Each localizer once by its canonical label, the suite's first with --with-builtins, and
    every navigator with every localizer when none is named."""
    assert navigation_contenders(SUITE, ["ppo", "ppo"], [
        "ransac:weighted=true", "ransac-weighted"]) == [("ppo", "ransac-weighted")]
    both = navigation_contenders(SUITE, ["ppo"], ["mex", "truth"], with_builtins=True)
    assert both == [("ppo", name) for name in (*SUITE.localizers, "mex")]
    assert navigation_contenders(SUITE, [], []) == contenders_of(NAVIGATORS, SUITE.localizers)


@pytest.mark.parametrize("env_id", ["azgym/Navigate-WarehouseSmall-v2",
                                    "azgym/NavigateDiscrete-WarehouseSmall-v2"])
def test_the_shipped_ppo_drives_to_the_goal(env_id):
    pytest.importorskip("stable_baselines3")
    from azgym.bench.navigation.scoring import drive
    from azgym.nav.policy_file import load_policy

    env = gym.make(env_id, localizer="truth")
    result = drive(env, load_policy("ppo", env), 10, get_navigation_suite("navigation").dev_seed)
    assert result["success"] >= 0.9 and result["spl"] >= 0.8



def test_a_contender_that_never_arrives_nor_answers_prints_dashes():
    from azgym.bench.navigation.report import score_table

    summary = {"success": 0.0, "spl": 0.0, "collisions": 1.0, "collided": 1.0,
               "time_to_goal": None, "answered": 0.0, "error_median_cm": None,
               "error_p95_cm": float("nan")}
    row = score_table([{"navigator": "ppo", "localizer": "dead-reckoning", "summary": summary,
                        "runtime_s": 1.0}], ["navigator", "localizer"]).splitlines()[1]
    assert row.split()[:9] == ["ppo", "dead-reckoning", "0.0", "0.000", "1.00", "100.0", "–",
                               "0.0", "–"]
