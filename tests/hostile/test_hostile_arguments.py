"""Arguments that destroy data or exhaust memory: each refused, named, before any work.

Outputs: no command replaces a log, a file or the results already in its output without
``--overwrite`` (a real camera's recording cannot be made again), with it only the files azgym
writes are replaced, and an empty ``--out`` is refused by every command as it is parsed.
Environments: a flag must be a bool, a reward weight cannot make a reward infinite, and a size
argument cannot ask for more memory than a step may take.
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from helpers import bounded_outcome

import azgym.envs  # noqa: F401  (registers the environments)
from azgym.cli import build_parser, main
from azgym.envs.common import MAX_REWARD_WEIGHT, MAX_SIZE
from azgym.errors import InvalidInputError

LOCALIZE, NAVIGATE = "azgym/Localize-WarehouseSmall-v1", "azgym/Navigate-WarehouseSmall-v2"
SWEEP = Path(__file__).parents[2] / "baselines" / "sweeps" / "ransac-iterations.toml"
LOG = {"log.toml": "format = 2\n", "frames.csv": "frame,time\n1,0.0\n",
       "detections.csv": "frame,id,azimuth\n", "odometry.csv": "time,speed,steer\n",
       "imu.csv": "time,yaw_rate\n"}


def _export(out, *extra):
    return main(["export", "route", "--scenario", "warehouse-small", "--out", str(out), *extra])


def _write(folder, files):
    folder.mkdir(parents=True, exist_ok=True)
    for name, text in files.items():
        (folder / name).write_text(text, encoding="utf-8")
    return {name: (folder / name).read_bytes() for name in files}


def test_export_refuses_to_replace_a_log(tmp_path, capsys):
    before = _write(tmp_path / "log", {**LOG, "notes.txt": "the camera's only recording"})
    assert _export(tmp_path / "log") == 2
    error = capsys.readouterr().err
    assert "frames.csv" in error and "log.toml" in error and "--overwrite" in error
    assert {name: (tmp_path / "log" / name).read_bytes() for name in before} == before


def test_export_with_overwrite_replaces_only_the_log_files(tmp_path):
    _write(tmp_path / "log", {**LOG, "notes.txt": "mine"})
    assert _export(tmp_path / "log", "--overwrite") == 0
    assert (tmp_path / "log" / "notes.txt").read_text() == "mine"
    assert (tmp_path / "log" / "log.toml").read_text() != LOG["log.toml"]


def test_export_with_overwrite_never_mixes_two_logs(tmp_path, capsys):
    before = _write(tmp_path / "log", {**LOG, "frames.parquet": "a real log's frames"})
    assert _export(tmp_path / "log", "--overwrite") == 2
    assert "frames.parquet" in capsys.readouterr().err
    assert {name: (tmp_path / "log" / name).read_bytes() for name in before} == before


def test_generate_refuses_to_replace_a_file(tmp_path, capsys):
    path = tmp_path / "site.toml"
    path.write_text("my hand-made site", encoding="utf-8")
    assert main(["generate", "--seed", "1", "--out", str(path)]) == 2
    assert "already exists" in capsys.readouterr().err
    assert path.read_text() == "my hand-made site"
    assert main(["generate", "--seed", "1", "--out", str(path), "--overwrite"]) == 0
    assert path.read_text().startswith("# Generated")


@pytest.mark.parametrize("argv", [
    ["generate", "--seed", "1"],
    ["export", "route", "--scenario", "warehouse-small"],
    ["calibrate", "warehouse-small-simulated"],
    ["reproduce", "plotter"],
    ["reproduce", "paper"],
    ["study", "error-model"],
    ["evaluate", "navigator", "pure-pursuit"],
    ["train", "navigator", "--env", NAVIGATE, "--algo", "ppo"],
    ["train", "localizer", "--model", "learned"],
    ["sweep", "sweep.toml"],
    ["layout", "analyze", "paper-room"],
])
def test_an_empty_out_is_refused_by_every_command(argv, capsys):
    with pytest.raises(SystemExit) as refused:  # only parsed: were it to pass, nothing runs
        build_parser().parse_args([*argv, "--out", ""])
    assert refused.value.code == 2
    assert "argument --out: is empty" in capsys.readouterr().err


@pytest.mark.parametrize(("argv", "existing"), [
    (["reproduce", "plotter", "--runs", "1"], "results.json"),
    (["reproduce", "paper", "--quick", "--workers", "1"], "results.md"),
    (["reproduce", "paper", "--quick", "--workers", "1"], "error_map_k0.png"),
    (["study", "error-model", "--frames", "1"], "error_model.json"),
    (["evaluate", "navigator", "pure-pursuit", "--episodes", "1"], "navigation.json"),
    (["train", "navigator", "--env", NAVIGATE, "--algo", "ppo", "--steps", "1"], "policy.zip"),
    (["sweep", str(SWEEP)], "sweep.csv"),
    (["layout", "analyze", "paper-room", "--frames", "0"], "layout.json"),
    (["layout", "optimize", "paper-room", "--add", "1"], "paper-room-plus-1.toml"),
])
def test_results_already_in_out_are_refused_before_any_work(argv, existing, tmp_path):
    out = tmp_path / "out"
    before = _write(out, {existing: "an earlier run's results", "mine.txt": "mine"})
    # A child with a time limit: were the refusal to regress, the run must not go on for minutes.
    done = subprocess.run([sys.executable, "-m", "azgym.cli", *argv, "--out", str(out)],
                          capture_output=True, text=True, timeout=90, cwd=tmp_path)
    assert done.returncode == 2
    assert existing in done.stderr and "--overwrite" in done.stderr
    assert {name: (out / name).read_bytes() for name in before} == before


# -- environments ------------------------------------------------------------------------------


@pytest.mark.parametrize("value", ["no", "False", 0, 1, None])
def test_discrete_must_be_a_bool(value):
    with pytest.raises(InvalidInputError, match="discrete must be True or False"):
        gym.make(NAVIGATE, localizer="truth", discrete=value)


def test_a_numpy_bool_is_a_flag():
    env = gym.make(NAVIGATE, localizer="truth", discrete=np.bool_(False))
    assert env.unwrapped.discrete is False


@pytest.mark.parametrize(("env_id", "weight"), [
    (LOCALIZE, "position_error"), (LOCALIZE, "heading_error"),
    (NAVIGATE, "progress"), (NAVIGATE, "collision"), (NAVIGATE, "time"), (NAVIGATE, "success"),
])
@pytest.mark.parametrize("value", [1e308, 10**400, math.inf, math.nan, "1", True])
def test_a_reward_weight_is_finite_and_bounded(env_id, weight, value):
    extra = {"localizer": "truth"} if env_id == NAVIGATE else {}
    with pytest.raises(InvalidInputError, match=f"{weight} weight must be"):
        gym.make(env_id, **extra, **{weight: value})


def test_the_largest_weights_keep_the_reward_finite():
    env = gym.make(LOCALIZE, position_error=MAX_REWARD_WEIGHT, heading_error=MAX_REWARD_WEIGHT)
    env.reset(seed=0)
    _, reward, *_ = env.step(np.array([1.0, 1.0, 1.0], dtype=np.float32))  # a far corner
    assert math.isfinite(reward) and math.isfinite(np.float32(reward))


@pytest.mark.parametrize(("env_id", "argument"), [
    (LOCALIZE, "max_detections"), (LOCALIZE, "episode_length"), (NAVIGATE, "n_rays"),
])
def test_a_huge_size_is_refused_by_name(env_id, argument):
    # In a child limited to 2 GiB and 120 s: a regression fails, never swaps.
    extra = ', localizer="truth"' if env_id == NAVIGATE else ""
    outcome = bounded_outcome(f"""
        import gymnasium as gym, azgym
        gym.make({env_id!r}{extra}, {argument}={10**9})
        """, memory_bytes=2 * 2**30, seconds=120)
    assert outcome.startswith(f"InvalidInputError {argument} must be an integer <= {MAX_SIZE}, "
                              f"got {10**9}")


def test_the_largest_size_is_made():
    env = gym.make(LOCALIZE, max_detections=MAX_SIZE)
    observation, _ = env.reset(seed=0)
    assert observation["ids"].shape == (MAX_SIZE,)
