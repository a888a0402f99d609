"""Forged navigation results files: ``azgym leaderboard build`` refuses each, naming the file, the
contender and the episode's field, before anything is published.

A navigation file's summary is recomputed from its episodes, so the forger redoes that
bookkeeping: every figure agrees with the episodes, and only physics gives the episodes away.
The attacks are made on a genuine quick run of pure pursuit with truth and lsq.
"""

from __future__ import annotations

import json
import math
import re
import shutil
from pathlib import Path

import pytest
from helpers import quick_navigation_run

from azgym import cli
from azgym.bench.navigation.scoring import wilson_interval

SHIPPED_ENTRIES = Path(__file__).resolve().parents[2] / "leaderboard" / "entries"


@pytest.fixture(scope="module")
def genuine(tmp_path_factory):
    return quick_navigation_run(tmp_path_factory.mktemp("genuine"), "truth", "lsq")


def _forge(genuine: Path, *, speed: float, share: float, shrink: float = 1.0) -> dict:
    """lsq's every episode made a success driven at ``speed`` over ``share`` of its shortest
    path, itself shrunk by ``shrink``; its summary recomputed from the forged episodes."""
    data = json.loads(genuine.read_text())
    lsq = next(c for c in data["contenders"] if c["localizer"] == "lsq")
    for episode in lsq["episodes"]:
        key = next(k for k in ("shortest_path_m", "path_length_m") if k in episode)
        episode[key] *= shrink
        travelled = share * episode[key]
        steps = math.ceil(travelled / (speed * 0.1))
        episode.update(success=True, spl=1.0, collisions=0, steps=steps, time_s=0.1 * steps,
                       travelled_m=travelled, answered_steps=steps, error_median_cm=1.0,
                       error_p95_cm=2.0)
    episodes = lsq["episodes"]
    lsq["summary"].update(
        success=1.0, success_interval=wilson_interval(len(episodes), len(episodes)), spl=1.0,
        collisions=0.0, collided=0.0, answered=1.0,
        time_to_goal=sum(e["time_s"] for e in episodes) / len(episodes))
    return data


def _build(tmp_path: Path, files: dict[str, dict | Path], capsys) -> tuple[int, str]:
    """``azgym leaderboard build`` of one borrowed frame entry and these navigation files."""
    entries, navigation = tmp_path / "entries", tmp_path / "navigation"
    entries.mkdir()
    navigation.mkdir()
    for name in ("ransac-paper.json", "ransac-paper.frames.csv.gz"):
        shutil.copy(SHIPPED_ENTRIES / name, entries / name)
    for name, content in files.items():
        target = navigation / name
        if isinstance(content, Path):
            shutil.copy(content, target)
        else:
            target.write_text(json.dumps(content))
    code = cli.main(["leaderboard", "build", "--entries", str(entries), "--out",
                     str(tmp_path / "out"), "--navigation", str(navigation)])
    return code, capsys.readouterr().err


@pytest.mark.slow
def test_a_second_table_with_a_path_driven_faster_than_the_forklift_is_refused(
        genuine, tmp_path, capsys):
    # The attack as found: lsq at 100 % success and SPL 1, each path driven at 18 m/s.
    forged = _forge(genuine, speed=18.0, share=1.0)
    code, err = _build(tmp_path, {"navigation-dev.json": genuine,
                                  "navigation-dev-lsq.json": forged}, capsys)
    assert code == 2
    assert re.search(r"navigation-dev-lsq\.json: contenders/1 \(pure-pursuit \+ lsq\)/"
                     r"episodes/0/travelled_m: [\d.]+ m in [\d.]+ s is more than the forklift "
                     r"can drive from rest in that time", err), err
    assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())


@pytest.mark.slow
def test_a_path_driven_at_top_speed_from_the_first_step_is_refused(genuine, tmp_path, capsys):
    # Under the top speed on average, but only if the forklift needed no time to accelerate:
    # from rest at 1.5 m/s², 3.5 m/s on average is out of reach over a few seconds.
    forged = _forge(genuine, speed=3.5, share=1.01)
    code, err = _build(tmp_path, {"navigation-dev-lsq.json": forged}, capsys)
    assert code == 2
    assert "is more than the forklift can drive from rest in that time" in err, err


def test_a_drive_exactly_as_short_as_the_geodesic_is_refused(genuine, tmp_path, capsys):
    # SPL exactly 1: the path driven equal to the shortest one, which no forklift can match.
    forged = _forge(genuine, speed=2.0, share=1.0)
    code, err = _build(tmp_path, {"navigation-dev-lsq.json": forged}, capsys)
    assert code == 2
    assert re.search(r"episodes/0/travelled_m: [\d.]+ m to the goal is no longer than the "
                     r"geodesic shortest path", err), err


def test_a_path_shorter_than_the_geodesic_is_refused_at_any_speed(genuine, tmp_path, capsys):
    forged = _forge(genuine, speed=2.0, share=0.97)  # cutting corners no drive can cut
    code, err = _build(tmp_path, {"navigation-dev-lsq.json": forged}, capsys)
    assert code == 2
    assert re.search(r"navigation-dev-lsq\.json: contenders/1 \(pure-pursuit \+ lsq\)/"
                     r"episodes/0/travelled_m: [\d.]+ m to the goal is no longer than the "
                     r"geodesic shortest path", err), err


def test_a_shortest_path_forged_down_with_the_drive_is_refused(genuine, tmp_path, capsys):
    forged = _forge(genuine, speed=2.0, share=1.01, shrink=0.9)
    code, err = _build(tmp_path, {"navigation-dev-lsq.json": forged}, capsys)
    assert code == 2
    assert re.search(r"navigation-dev-lsq\.json: contenders/1 \(pure-pursuit \+ lsq\)/"
                     r"episodes/0/shortest_path_m: the geodesic shortest path of seed 2300's "
                     r"start and goal is [\d.]+ m, the file says [\d.]+", err), err


def test_two_files_of_one_suite_split_and_seed_are_refused_naming_both(
        genuine, tmp_path, capsys):
    code, err = _build(tmp_path, {"a.json": genuine, "b.json": genuine}, capsys)
    assert code == 2
    navigation = tmp_path / "navigation"
    assert (f"{navigation / 'a.json'} and {navigation / 'b.json'} share episodes of the "
            "navigation suite (seeds 2300 to 2309): a board shows each episode once") in err


def _shifted(genuine: Path, split: str, seed: int) -> dict:
    """The genuine file's run presented as another split and seed (episodes relabelled)."""
    data = json.loads(genuine.read_text())
    data.update(split=split, seed=seed)
    for contender in data["contenders"]:
        for k, episode in enumerate(contender["episodes"]):
            episode["seed"] = seed + k
    return data


def test_a_test_run_made_of_the_dev_splits_episodes_is_refused(genuine, tmp_path, capsys):
    # Seed 2301: a "test" split that shares all but one episode with the dev split.
    code, err = _build(tmp_path, {"navigation-test.json": _shifted(genuine, "test", 2301)},
                       capsys)
    assert code == 2
    assert "a test run's episodes must not be the dev split's (seeds 2300 to 2399), got " \
           "seed 2301" in err, err


def test_two_test_runs_sharing_episodes_are_refused(genuine, tmp_path, monkeypatch):
    # Each file alone is sound (the per-file checks are stood in for): the board's own rule.
    from azgym.bench.leaderboard.entry_files import LeaderboardError
    from azgym.bench.navigation import board

    for name, seed in (("t1.json", 900_000), ("t2.json", 900_003)):
        (tmp_path / name).write_text(json.dumps(_shifted(genuine, "test", seed)))
    monkeypatch.setattr(board, "load_navigation", lambda path: json.loads(path.read_text()))
    with pytest.raises(LeaderboardError, match=r"t1\.json and .*t2\.json share episodes of "
                       r"the navigation suite \(seeds 900003 to 900009\)"):
        board.navigation_tables(tmp_path)


def test_a_fractional_episode_count_is_a_named_error(genuine, tmp_path, capsys):
    data = json.loads(genuine.read_text())
    data["episodes"] = float(data["episodes"])
    code, err = _build(tmp_path, {"navigation-dev.json": data}, capsys)
    assert code == 2
    assert "episodes must be 10 (the suite's quick size), got 10.0" in err, err
