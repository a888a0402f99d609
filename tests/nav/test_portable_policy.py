"""A stable-baselines3 policy acts through torch's portable CPU kernels (azgym.torch_kernels), so
its episodes, and the navigation board's figures, repeat on every x86-64 processor.

An episode is chaotic: one action that differs in its last bit moves the rest of the episode.
The shipped policy's actions on fixed observations, through the processor's own kernels, hashed
differently on an AVX-512 processor than the portable kernels' (which oneMKL's conditional
numerical reproducibility makes the same on every x86-64 processor).
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

pytest.importorskip("stable_baselines3", reason="the rl extra")

ACTIONS = """
import hashlib, warnings
import numpy as np, gymnasium as gym
import azgym.envs
from azgym.nav.policy_file import load_policy
{before}
env = gym.make("azgym/Navigate-WarehouseSmall-v2")
with warnings.catch_warnings(record=True) as caught:
    warnings.simplefilter("always")
    policy = load_policy("ppo", env)
import torch
space = env.observation_space
observations = np.random.default_rng(0).uniform(-1, 1, (2000, *space.shape)).astype(space.dtype)
actions = np.array([policy.act(observation) for observation in observations])
print(hashlib.sha256(actions.tobytes()).hexdigest()[:16], torch.backends.cpu.get_cpu_capability())
print("|".join(str(warning.message) for warning in caught))
"""

PORTABLE_ACTIONS = "7335ad4a2888ed7c"
"""The first 16 hex digits of the SHA-256 of the shipped policy's actions on the observations
above, through the portable kernels (torch 2.13.0's CPU wheel)."""


def actions(before: str = "") -> list[str]:
    """The hash of the actions and torch's kernels; the warnings, in a fresh process."""
    env = {key: value for key, value in os.environ.items()
           if key not in ("ATEN_CPU_CAPABILITY", "MKL_CBWR", "MKL_ENABLE_INSTRUCTIONS")}
    done = subprocess.run([sys.executable, "-c", ACTIONS.format(before=before)], env=env,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    return done.stdout.splitlines()


@pytest.mark.slow
def test_the_shipped_policy_acts_through_the_portable_kernels():
    digest_and_kernels, warned = actions()
    assert digest_and_kernels == f"{PORTABLE_ACTIONS} DEFAULT"
    assert warned == ""


@pytest.mark.slow
def test_a_policy_loaded_after_torch_ran_warns_that_its_episodes_repeat_on_like_processors():
    digest_and_kernels, warned = actions("import torch; torch.relu(torch.ones(64))")
    if digest_and_kernels.endswith(" DEFAULT"):
        pytest.skip("this processor's own kernels are torch's baseline ones")
    assert "torch already computes with the" in warned
    assert "repeat only on a like processor" in warned
