"""``azgym evaluate navigator``: a policy file that cannot drive the environment is refused by
name before any episode (missing, not a zip, not SB3's, another observation or action space,
no torch); every argument is checked first; the baseline and a trained PPO model are scored."""

from __future__ import annotations

import importlib.util
import json
import re
import zipfile

import gymnasium as gym
import numpy as np
import pytest

from azgym import cli
from azgym.bench.navigation import scoring
from azgym.cli import evaluate as cli_evaluate
from azgym.errors import DependencyNotInstalled, ModelFileError
from azgym.nav.policy_file import SB3Policy, load_policy

ENV_ID = "azgym/Navigate-WarehouseSmall-v2"


@pytest.fixture(scope="module")
def env():
    return gym.make(ENV_ID)


class Dummy(gym.Env):
    """The smallest env SB3 trains on, with the spaces a test asks for."""

    def __init__(self, observation_space, action_space):
        self.observation_space, self.action_space = observation_space, action_space

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        return self.observation_space.sample(), {}

    def step(self, action):
        return self.observation_space.sample(), 0.0, True, False, {}


def sb3_zip(path, algorithm, observation_space, action_space):
    """An untrained SB3 model of ``algorithm`` saved for the given spaces, at ``path``."""
    sb3 = pytest.importorskip("stable_baselines3")
    getattr(sb3, algorithm)("MlpPolicy", Dummy(observation_space, action_space),
                            device="cpu").save(path)
    return path


def written(path, data):
    path.write_bytes(data)
    return path


def write_zip(path, entries):
    with zipfile.ZipFile(path, "w") as archive:
        for name, data in entries.items():
            archive.writestr(name, data)
    return path


V2_OBSERVATION = gym.spaces.Box(-1.0, 1.0, (20,), np.float32)
V1_OBSERVATION = gym.spaces.Box(-1.0, 1.0, (13,), np.float32)
CONTINUOUS = gym.spaces.Box(-1.0, 1.0, (2,), np.float32)


@pytest.mark.parametrize(("make", "message"), [
    (lambda path: path, r"no such file; give a stable-baselines3 \.zip, 'pure-pursuit' or 'ppo'"),
    (lambda path: path.parent, "cannot read the policy file: it is a folder, not a regular file"),
    (lambda path: written(path, b""), "not a readable zip"),
    (lambda path: written(path, np.random.default_rng(0).bytes(4096)), "not a readable zip"),
    (lambda path: write_zip(path, {"policy.pth": b"weights"}),
     "a zip without stable-baselines3's 'data' entry"),
    (lambda path: write_zip(path, {"data": b"{not json \xff"}),
     "its 'data' entry is not stable-baselines3's JSON object"),
    (lambda path: write_zip(path, {"data": b"[1, 2, 3]"}),
     "its 'data' entry is not stable-baselines3's JSON object"),
    (lambda path: write_zip(path, {"data": json.dumps({"policy_class": {
        "__module__": "sb3_contrib.common.recurrent.policies"}})}),
     r"its policy class \(sb3_contrib.common.recurrent.policies\) is not one of PPO"),
], ids=["missing", "folder", "empty", "random-bytes", "zip-without-data", "garbage-json",
        "json-not-an-object", "unknown-algorithm"])
def test_a_file_that_is_not_an_sb3_model_is_refused_by_name(make, message, env, tmp_path):
    path = make(tmp_path / "policy.zip")
    with pytest.raises(ModelFileError, match=message):
        load_policy(path, env)


def test_a_damaged_or_truncated_sb3_zip_is_refused_by_name(env, tmp_path):
    whole = sb3_zip(tmp_path / "whole.zip", "PPO", V2_OBSERVATION, CONTINUOUS).read_bytes()
    damaged = whole.replace(b'"gamma"', b'"GAMMA"', 1)  # the data entry's checksum fails
    with pytest.raises(ModelFileError, match="not a readable zip .*Bad CRC-32 for file 'data'"):
        load_policy(written(tmp_path / "damaged.zip", damaged), env)
    # Cut short, the zip's own directory is lost; zipfile then finds a weight file's inner zip.
    with pytest.raises(ModelFileError, match="without stable-baselines3's 'data' entry.*cut short"):
        load_policy(written(tmp_path / "cut.zip", whole[:len(whole) // 2]), env)


def test_an_sb3_zip_sb3_cannot_load_is_refused_by_name(env, tmp_path):
    whole = sb3_zip(tmp_path / "whole.zip", "PPO", V2_OBSERVATION, CONTINUOUS)
    with zipfile.ZipFile(whole) as archive:
        entries = {name: archive.read(name) for name in archive.namelist()}
    entries["policy.pth"] = b"not torch's"
    with pytest.raises(ModelFileError, match="stable-baselines3 cannot load it as a PPO model"):
        load_policy(write_zip(tmp_path / "broken.zip", entries), env)


def test_a_policy_of_the_old_observation_is_refused_naming_both_spaces(env, tmp_path):
    path = sb3_zip(tmp_path / "v1.zip", "PPO", V1_OBSERVATION, CONTINUOUS)
    message = ("the policy was trained on the observation space Box(-1.0, 1.0, (13,), float32), "
               "the environment has Box(-1.0, 1.0, (20,), float32)")
    with pytest.raises(ModelFileError, match=re.escape(message)):
        load_policy(path, env)


def test_discrete_actions_for_continuous_ones_are_refused_naming_both_spaces(env, tmp_path):
    path = sb3_zip(tmp_path / "dqn.zip", "DQN", V2_OBSERVATION, gym.spaces.Discrete(15))
    message = ("the policy was trained on the action space Discrete(15), the environment has "
               "Box(-1.0, 1.0, (2,), float32)")
    with pytest.raises(ModelFileError, match=re.escape(message)):
        load_policy(path, env)


@pytest.mark.parametrize("algorithm", ["PPO", "A2C", "SAC", "TD3"])
def test_each_sb3_algorithm_is_told_from_its_file_and_acts_in_the_action_space(
        algorithm, env, tmp_path):
    path = sb3_zip(tmp_path / "model.zip", algorithm, V2_OBSERVATION, CONTINUOUS)
    policy = load_policy(path, env)
    assert isinstance(policy, SB3Policy)
    assert type(policy.model).__name__ == algorithm
    observation, _ = env.reset(seed=0)
    assert env.action_space.contains(policy.act(observation))


def test_without_torch_an_sb3_file_asks_for_the_rl_extra(env, tmp_path, monkeypatch):
    path = write_zip(tmp_path / "model.zip", {"data": json.dumps({"policy_class": {
        "__module__": "stable_baselines3.sac.policies"}})})
    find_spec = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *rest: None if name == "torch" else find_spec(name, *rest))
    with pytest.raises(DependencyNotInstalled,
                       match=re.escape('pip install torch==2.13.0 first (the CPU wheel), then '
                                       'pip install "azgym[rl]"')):
        load_policy(path, env)


def test_pure_pursuit_takes_the_environment_s_kind_of_actions(env):
    assert load_policy("pure-pursuit", env).discrete is False
    discrete = gym.make("azgym/NavigateDiscrete-WarehouseSmall-v2")
    assert load_policy("pure-pursuit", discrete).discrete is True


def test_the_command_parses_to_its_handler_with_its_defaults():
    args = cli.build_parser().parse_args(["evaluate", "navigator", "pure-pursuit"])
    assert args.handler is cli_evaluate._evaluate_navigator
    assert {key: getattr(args, key) for key in ("policy", "env", "localizer", "episodes", "seed",
                                               "sensor", "ids", "out")} == {
        "policy": "pure-pursuit", "env": ENV_ID, "localizer": [], "episodes": 100,
        "seed": 1_000_000, "sensor": "geometry", "ids": "oracle", "out": None}


@pytest.mark.parametrize(("argv", "message"), [
    (["--env", "azgym/Navigate-Nowhere-v2"],
     "unknown navigation environment 'azgym/Navigate-Nowhere-v2'"),
    (["--env", "azgym/Localize-WarehouseSmall-v1"],
     "has no planner's map: it is not a navigation environment"),
    (["--localizer", "truth", "--localizer", "ransak"], "unknown localizer 'ransak'"),
    (["--episodes", "0"], "--episodes must be an integer >= 1, got 0"),
    (["--seed", "-1"], "--seed must be an integer >= 0, got -1"),
    (["--out", "{tmp}/file"], "cannot write there"),
    (["{tmp}/missing.zip"], "missing.zip: no such file"),
], ids=["unknown-env", "localize-env", "unknown-localizer", "episodes", "seed", "out", "policy"])
def test_every_argument_is_refused_by_name_before_any_episode(argv, message, tmp_path,
                                                              monkeypatch, capsys):
    monkeypatch.setattr(scoring, "drive", lambda *args, **kwargs: pytest.fail("drove"))
    (tmp_path / "file").write_text("")
    argv = [arg.format(tmp=tmp_path) for arg in argv]
    policy = [] if argv[0].endswith(".zip") else ["pure-pursuit"]  # the last given is used
    assert cli.main(["evaluate", "navigator", *policy, *argv]) == 2
    assert message in capsys.readouterr().err


def test_pure_pursuit_is_scored_through_the_command(tmp_path, capsys):
    assert cli.main(["evaluate", "navigator", "pure-pursuit", "--localizer", "truth",
                     "--episodes", "2", "--out", str(tmp_path)]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].split()[:3] == ["localizer", "success", "%"]
    assert lines[1].split()[0] == "truth"
    report = json.loads((tmp_path / "navigation.json").read_text())
    (row,) = report["results"]
    assert (report["policy"], report["seed"], row["localizer"]) == ("pure-pursuit", 1_000_000,
                                                                     "truth")
    assert len(row["episodes"]) == 2 and "errors" not in row["episodes"][0]
    assert row["summary"]["error_median_cm"] == 0.0 and row["summary"]["answered"] == 1.0
    assert [episode["seed"] for episode in row["episodes"]] == [1_000_000, 1_000_001]


def test_a_ppo_model_trained_on_the_environment_loads_and_is_scored(tmp_path, capsys,
                                                                    monkeypatch):
    monkeypatch.setenv("SB3_LOGDIR", str(tmp_path / "sb3"))  # SB3 makes it even to log nothing
    sb3 = pytest.importorskip("stable_baselines3")
    torch = pytest.importorskip("torch")
    torch.set_num_threads(1)
    model = sb3.PPO("MlpPolicy", gym.make(ENV_ID, localizer="truth", max_steps=100),
                    n_steps=128, batch_size=64, n_epochs=1, seed=0, device="cpu")
    model.learn(total_timesteps=256)
    model.save(tmp_path / "ppo.zip")
    assert cli.main(["evaluate", "navigator", str(tmp_path / "ppo.zip"), "--localizer", "truth",
                     "--episodes", "1", "--out", str(tmp_path)]) == 0
    assert capsys.readouterr().out.splitlines()[1].split()[0] == "truth"
    report = json.loads((tmp_path / "navigation.json").read_text())
    assert len(report["results"][0]["episodes"]) == 1
