"""stable-baselines3 on azgym: its environment checker, and a PPO smoke run that learns nothing
in particular but proves the training loop runs end to end."""

from __future__ import annotations

import warnings

import gymnasium as gym
import pytest

import azgym

sb3 = pytest.importorskip("stable_baselines3", reason='needs pip install "azgym[rl]"')
torch = pytest.importorskip("torch")


@pytest.mark.parametrize("env_id", azgym.ENV_IDS)
def test_stable_baselines3_check_env_passes_without_warnings(env_id):
    from stable_baselines3.common.env_checker import check_env

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(gym.make(env_id).unwrapped, warn=True, skip_render_check=True)


@pytest.mark.slow
def test_ppo_trains_on_a_navigation_environment(monkeypatch, tmp_path):
    monkeypatch.setenv("SB3_LOGDIR", str(tmp_path))  # SB3 makes its log folder even to log nothing
    torch.set_num_threads(1)  # one core: the other is busy (docs/performance.md)
    env = gym.make("azgym/Navigate-WarehouseSmall-v2", max_steps=200)
    model = sb3.PPO("MlpPolicy", env, n_steps=512, batch_size=128, n_epochs=2, seed=0,
                    verbose=0, device="cpu")
    model.learn(total_timesteps=2048)
    assert model.num_timesteps >= 2048
    observation, _ = env.reset(seed=1)
    action, _ = model.predict(observation, deterministic=True)
    assert env.action_space.contains(action)
