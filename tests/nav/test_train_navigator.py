"""``azgym train navigator``: every bad argument refused by name before any training, the
hyperparameter file, the evaluation episodes' wrapper, and a tiny run that writes the policy,
evaluations, learning curve and model card, repeatably."""

from __future__ import annotations

import inspect
import re

import gymnasium as gym
import numpy as np
import pytest

from azgym import cli
from azgym.cli import train as cli_train
from azgym.errors import AzgymError, DependencyNotInstalled
from azgym.learn.navigator import card as train_card
from azgym.learn.navigator import train
from azgym.nav.policy_file import load_policy

SMALL = "azgym/Navigate-WarehouseSmall-v2"
TINY = {"n_envs": 2, "eval_episodes": 2, "eval_every": 1024, "score_episodes": 2,
        "overrides": {"n_steps": 256}, "verbose": False}


def needs_rl():
    pytest.importorskip("stable_baselines3", reason='needs pip install "azgym[rl]"')
    pytest.importorskip("yaml", reason='needs pip install "azgym[rl]"')


@pytest.fixture
def no_training(monkeypatch):
    """Fail the test if training starts."""
    def run(*_args, **_kwargs):
        raise AssertionError("training started")

    monkeypatch.setattr(train, "run", run)


@pytest.mark.parametrize(("argv", "message"), [
    (["--env", "azgym/Navigate-WarehouseSmal-v2"],
     "unknown navigation environment 'azgym/Navigate-WarehouseSmal-v2'. Did you mean "
     "'azgym/Navigate-WarehouseSmall-v2'?"),
    (["--env", "azgym/Localize-WarehouseSmall-v1"],
     "env 'azgym/Localize-WarehouseSmall-v1' has no planner's map: it is not a navigation "
     "environment"),
    (["--env", "azgym/NavigateDiscrete-WarehouseSmall-v2", "--algo", "sac"],
     "algo 'sac' needs a continuous (Box) action space"),
    (["--env", "azgym/NavigateDiscrete-WarehouseLarge-v2", "--algo", "sac"],
     "algo 'sac' needs a continuous (Box) action space"),  # an id of the default entry
    (["--localizer", "ransak"], "unknown localizer 'ransak'. Did you mean 'ransac'?"),
    (["--localizer", "ransac:max_iter=0"], "max_iter"),
])
def test_bad_arguments_are_refused_by_name_before_any_training(argv, message, no_training,
                                                               capsys, tmp_path):
    needs_rl()
    base = {"--env": SMALL, "--algo": "ppo", "--steps": "100", "--out": str(tmp_path / "out")}
    for flag, value in zip(argv[::2], argv[1::2], strict=True):
        base[flag] = value
    code = cli.main(["train", "navigator", *[x for pair in base.items() for x in pair]])
    assert code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(("argv", "message"), [
    (["--steps", "0"], "argument --steps: must be an integer >= 1, got '0'"),
    (["--envs", "1.5"], "argument --envs: must be an integer >= 1, got '1.5'"),
    (["--seed", "-1"], "argument --seed: must be an integer >= 0, got '-1'"),
    (["--algo", "dqn"], "argument --algo: invalid choice: 'dqn'"),
])
def test_malformed_numbers_and_algorithms_exit_2_from_the_parser(argv, message, capsys,
                                                                 tmp_path):
    base = {"--env": SMALL, "--algo": "ppo", "--out": str(tmp_path / "out")}
    for flag, value in zip(argv[::2], argv[1::2], strict=True):
        base[flag] = value
    with pytest.raises(SystemExit) as stopped:
        cli.main(["train", "navigator", *[x for pair in base.items() for x in pair]])
    assert stopped.value.code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(("change", "message"), [
    ({"steps": 0}, "steps must be an integer >= 1, got 0"),
    ({"steps": 2.5}, "steps must be an integer >= 1, got 2.5"),
    ({"algo": "a2c"}, "unknown algorithm 'a2c'"),
    ({"n_envs": 0}, "envs must be an integer >= 1, got 0"),
    ({"threads": 0}, "threads must be an integer >= 1, got 0"),
    ({"localizer": 3}, "localizer must be a name or \"truth\", got 3"),
    ({"overrides": {"n_step": 8}}, "overrides: 'n_step' is not a hyperparameter of ppo"),
    ({"overrides": {"seed": 8}}, "overrides: 'seed' is not a hyperparameter of ppo"),
])
def test_the_python_call_checks_its_arguments_too(change, message, no_training, tmp_path):
    needs_rl()
    arguments = {"env_id": SMALL, "algo": "ppo", "steps": 100, "out": tmp_path / "out", **change}
    with pytest.raises(AzgymError, match=re.escape(message)):
        train.train_navigator(**arguments)
    assert not (tmp_path / "out").exists()


def test_an_output_folder_that_cannot_be_written_is_refused_before_training(no_training,
                                                                            capsys, tmp_path):
    needs_rl()
    (tmp_path / "file").write_text("not a folder")
    code = cli.main(["train", "navigator", "--env", SMALL, "--algo", "ppo",
                     "--out", str(tmp_path / "file" / "out")])
    assert code == 2
    assert "cannot write there" in capsys.readouterr().err
    (tmp_path / "real").mkdir()
    (tmp_path / "link").symlink_to(tmp_path / "real")
    code = cli.main(["train", "navigator", "--env", SMALL, "--algo", "ppo",
                     "--out", str(tmp_path / "link")])
    assert code == 2
    assert "is a symbolic link" in capsys.readouterr().err


@pytest.mark.parametrize(("missing", "message"), [
    ("torch", 'torch is not installed: pip install torch==2.13.0 first (the CPU wheel), then '
              'pip install "azgym[rl]"'),
    ("stable_baselines3", 'stable-baselines3 is not installed: pip install "azgym[rl]"'),
    ("yaml", 'PyYAML is not installed: pip install "azgym[rl]"'),
])
def test_without_the_rl_extra_the_command_says_how_to_install_it(missing, message, monkeypatch,
                                                                 no_training, capsys, tmp_path):
    real = train.importlib.util.find_spec
    monkeypatch.setattr(train.importlib.util, "find_spec",
                        lambda name, *a: None if name == missing else real(name, *a))
    with pytest.raises(DependencyNotInstalled):
        train.require_rl()
    code = cli.main(["train", "navigator", "--env", SMALL, "--algo", "ppo",
                     "--out", str(tmp_path / "o")])
    assert code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_the_command_passes_its_arguments_on(monkeypatch, tmp_path):
    needs_rl()
    calls = []
    monkeypatch.setattr(train, "prepare", lambda *a, **k: calls.append((a, k)) or "request")
    monkeypatch.setattr(train, "run", lambda request: calls.append(request) or
                        train.TrainingResult(*"pcue", wall_time=1.0, score={}))
    args = ["train", "navigator", "--env", SMALL, "--algo", "sac", "--out", str(tmp_path)]
    assert cli.build_parser().parse_args(args).handler is cli_train._train_navigator
    assert cli.main(args) == 0
    assert cli.main([*args, "--steps", "5", "--seed", "3", "--localizer", "truth",
                     "--envs", "2", "--threads", "2"]) == 0
    defaults = {"seed": 0, "localizer": None, "n_envs": None, "threads": 1}
    assert calls == [((SMALL, "sac", None, tmp_path), defaults), "request",
                     ((SMALL, "sac", 5, tmp_path),
                      {"seed": 3, "localizer": "truth", "n_envs": 2, "threads": 2}), "request"]


def test_every_entry_of_the_hyperparameters_is_taken_by_its_algorithm():
    needs_rl()
    import yaml

    table = yaml.safe_load(train.HYPERPARAMS.read_text(encoding="utf-8"))
    assert {"default", SMALL, "azgym/NavigateDiscrete-WarehouseSmall-v2"} <= set(table)
    assert "sac" not in table["azgym/NavigateDiscrete-WarehouseSmall-v2"]
    for env_id, entry in table.items():
        assert env_id == "default" or env_id in gym.registry
        for algo, settings in entry.items():
            accepted = inspect.signature(train._algorithm(algo)).parameters
            assert set(settings) - set(train.SETTINGS) <= set(accepted), (env_id, algo)
            assert settings["env_kwargs"]["localizer"] == "ransac"
            assert isinstance(settings["n_timesteps"], int)  # not the string YAML makes of 1e6
    assert train.hyperparameters("azgym/Navigate-WarehouseLarge-v2", "ppo") == table["default"][
        "ppo"]


class Corridor(gym.Env):
    """Three steps to the goal; the observation is the reset's draw."""

    observation_space = gym.spaces.Box(0.0, 1.0, (1,))
    action_space = gym.spaces.Discrete(2)

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.steps = 0
        return self.np_random.random(1).astype(np.float32), {}

    def step(self, action):
        self.steps += 1
        arrived = bool(action) and self.steps == 3
        return np.zeros(1, np.float32), 0.0, arrived, self.steps == 3 and not arrived, {}


def test_evaluation_episodes_are_the_same_each_time_and_report_their_success():
    env = train.EpisodeEnds(Corridor(), first_seed=7)
    first = [env.reset()[0] for _ in range(3)]
    env.rewind()
    assert np.array_equal(first, [env.reset()[0] for _ in range(3)])
    assert not np.array_equal(first[0], first[1])  # each episode its own seed
    assert np.array_equal(env.reset(seed=7)[0], first[0])
    infos = [env.step(1)[4] for _ in range(3)]
    assert [info.get("is_success") for info in infos] == [None, None, True]
    env.reset()
    assert env.step(0)[4] == {} and env.step(0)[4] == {}
    assert env.step(0)[4] == {"is_success": False}  # truncated: a failure


@pytest.mark.slow
def test_a_tiny_run_writes_a_policy_that_loads_and_drives(tmp_path, monkeypatch):
    needs_rl()
    import tempfile

    from azgym.bench.navigation.scoring import drive

    system_temporary = tmp_path.parent / f"{tmp_path.name}-system"
    system_temporary.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(system_temporary))
    result = train.train_navigator(SMALL, "ppo", 2048, tmp_path, **TINY)
    assert {path.name for path in tmp_path.iterdir()} == {
        "policy.zip", "evaluations.npz", "learning-curve.png", "model-card.md", "checkpoints"}
    assert list(system_temporary.glob("SB3-*")) == []  # no log folder of SB3's left behind
    assert any((tmp_path / "checkpoints").glob("ppo_*_steps.zip"))
    evaluations = np.load(result.evaluations)
    assert list(evaluations["timesteps"]) == [1024, 2048]
    assert evaluations["successes"].shape == evaluations["results"].shape == (2, 2)
    card = result.card.read_text()
    assert ("azgym train navigator --env azgym/Navigate-WarehouseSmall-v2 --algo ppo --steps "
            f"2048 --out {tmp_path} --seed 0 --localizer ransac --envs 2 --threads 1") in card
    assert "overrides={'n_steps': 256}" in card and "n_steps: 256" in card
    assert train_card.REPRODUCIBILITY in card
    assert re.search(r"^- CPU kernels: (portable CPU kernels|native \w+ CPU kernels: )", card,
                     re.MULTILINE)  # native when torch ran before in this process
    assert f"| success rate | {result.score['success']:.1%} |" in card
    env = gym.make(SMALL, max_steps=20)
    navigator = load_policy(result.policy, env)
    assert env.action_space.contains(navigator.act(env.reset(seed=1)[0]))
    assert 0.0 <= drive(env, navigator, episodes=1, seed=5)["spl"] <= 1.0


@pytest.mark.slow
def test_sac_trains_on_the_continuous_id_and_its_policy_loads(tmp_path):
    needs_rl()
    result = train.train_navigator(SMALL, "sac", 300, tmp_path, eval_episodes=1, eval_every=300,
                                   score_episodes=1, verbose=False,
                                   overrides={"learning_starts": 100, "buffer_size": 1000})
    assert "buffer_size: 1000" in result.card.read_text()
    if result.score["success"] == 0.0:  # a figure the card cannot show is a dash, not "nan"
        assert "| time to goal [s] | — |" in result.card.read_text()
    env = gym.make(SMALL)
    navigator = load_policy(result.policy, env)
    assert env.action_space.contains(navigator.act(env.reset(seed=2)[0]))


@pytest.mark.slow
def test_one_seed_gives_identical_parameters_and_another_seed_others(tmp_path):
    needs_rl()
    import torch

    def parameters(seed, folder):
        result = train.train_navigator(SMALL, "ppo", 1024, tmp_path / folder, seed=seed,
                                       **{**TINY, "eval_every": 1024})
        return load_policy(result.policy, gym.make(SMALL)).model.policy.state_dict()

    first, again, other = parameters(0, "a"), parameters(0, "b"), parameters(1, "c")
    assert all(torch.equal(first[key], again[key]) for key in first)
    assert not all(torch.equal(first[key], other[key]) for key in first)


def test_the_command_and_the_training_module_import_neither_torch_nor_stable_baselines3():
    import subprocess
    import sys

    code = ("import sys, azgym.cli, azgym.learn.navigator.train, azgym.learn.navigator.card; "
            "print(sorted(m for m in ('torch', 'stable_baselines3', 'matplotlib') "
            "if m in sys.modules))")
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout.strip() == "[]"
