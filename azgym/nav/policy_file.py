"""Policies by name or file: the scripted baseline, or a stable-baselines3 model saved as a zip.

:func:`load_policy` checks everything it can before an episode is driven: the file is there, is
a zip, holds SB3's ``data`` entry in JSON, was saved by an algorithm azgym knows how to load,
the optional ``rl`` extra is installed, SB3 can load it, and its observation and action spaces
are the environment's (a policy trained on another version of the observation, or with discrete
actions for continuous ones, is refused by name rather than driven into nonsense). Each failure
is a :class:`azgym.errors.ModelFileError` naming the file and the problem.

An SB3 zip is unpickled when it is loaded, and unpickling runs code: load only files you trust.
"""

from __future__ import annotations

import importlib.util
import json
import warnings
import zipfile
import zlib
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

from azgym.errors import DependencyNotInstalled, ModelFileError
from azgym.nav.controls import Policy
from azgym.nav.pursuit import PurePursuit

__all__ = ["ALGORITHMS", "MODELS", "SB3Policy", "SHIPPED_FILES", "load_policy", "require_rl"]

PURE_PURSUIT = "pure-pursuit"
"""The name of the scripted baseline (:class:`azgym.nav.pursuit.PurePursuit`)."""
SHIPPED_PPO = "ppo"
"""The name of the shipped PPO navigators (``models/``), one per kind of actions; each has a
model card beside it with the command that trained it."""
MODELS = Path(__file__).with_name("models")
SHIPPED_FILES = {False: "ppo-navigate-v2.zip", True: "ppo-navigate-discrete-v2.zip"}
"""The shipped PPO file for continuous (False) and discrete (True) actions."""
ALGORITHMS = {"stable_baselines3.sac.policies": "SAC",
              "stable_baselines3.td3.policies": "TD3",
              "stable_baselines3.dqn.policies": "DQN"}
"""The SB3 algorithm whose policy class lives in each module; ``common.policies`` (the
actor-critic policy) is PPO's or A2C's, told apart by PPO's ``clip_range``. DDPG's policy is
TD3's, and TD3's loader predicts with it alike."""
ACTOR_CRITIC = "stable_baselines3.common.policies"


class SB3Policy:
    """A stable-baselines3 model as a :class:`azgym.nav.controls.Policy`: its deterministic action.

    Args:
        model: A loaded SB3 model (anything with ``predict(observation, deterministic=...)``).
    """

    def __init__(self, model: Any) -> None:
        self.model = model

    def act(self, observation: np.ndarray) -> Any:
        """The model's deterministic action for one observation."""
        action, _ = self.model.predict(observation, deterministic=True)
        return action

    def reset(self) -> None:
        """Nothing to forget: the feed-forward policies SB3 loads keep no state."""


def load_policy(path_or_name: str | Path, env: gym.Env) -> Policy:
    """The policy ``path_or_name`` names, checked against ``env`` before it drives.

    Args:
        path_or_name: ``"pure-pursuit"`` or ``"ppo"`` (the shipped policy; both on the
            environment's kind of actions), or the path of a stable-baselines3 zip (PPO,
            A2C, SAC, TD3, DDPG or DQN). The zip is unpickled: load only files you trust.
        env: The Navigate environment the policy will drive.

    Raises:
        ModelFileError: The file is missing, not an SB3 zip, unreadable, or made for other
            observation or action spaces.
        DependencyNotInstalled: An SB3 file was given without torch or stable-baselines3.
    """
    discrete = isinstance(env.action_space, gym.spaces.Discrete)
    if str(path_or_name) == PURE_PURSUIT:
        return PurePursuit(discrete=discrete)
    path = MODELS / SHIPPED_FILES[discrete] if str(path_or_name) == SHIPPED_PPO else Path(
        path_or_name)
    algorithm = _algorithm_of(path)
    require_rl()
    model = _load_model(path, algorithm)
    for kind in ("observation", "action"):
        saved, wanted = getattr(model, f"{kind}_space"), getattr(env, f"{kind}_space")
        if saved != wanted:
            raise ModelFileError(f"{path}: the policy was trained on the {kind} space {saved}, "
                                 f"the environment has {wanted}")
    return SB3Policy(model)


def _algorithm_of(path: Path) -> str:
    """The SB3 algorithm that saved ``path``, read from its ``data`` entry without unpickling."""
    if not path.exists():
        raise ModelFileError(f"{path}: no such file; give a stable-baselines3 .zip, "
                             f"{PURE_PURSUIT!r} or {SHIPPED_PPO!r}")
    if not path.is_file():
        raise ModelFileError(f"{path}: is not a file; give a stable-baselines3 .zip")
    data = _data_entry(path)
    policy_class = data.get("policy_class")
    module = policy_class.get("__module__") if isinstance(policy_class, dict) else None
    if module == ACTOR_CRITIC:
        return "PPO" if "clip_range" in data else "A2C"
    if module not in ALGORITHMS:
        raise ModelFileError(f"{path}: its policy class ({module or 'none recorded'}) is not one "
                             "of PPO, A2C, SAC, TD3, DDPG or DQN")
    return ALGORITHMS[module]


def _data_entry(path: Path) -> dict[str, Any]:
    """The JSON of SB3's ``data`` entry in the zip at ``path``, as a dict."""
    try:
        with zipfile.ZipFile(path) as archive:
            raw = archive.read("data") if "data" in archive.namelist() else None
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError, OSError) as exc:
        raise ModelFileError(f"{path}: not a readable zip ({exc}); give a stable-baselines3 "
                             ".zip saved by model.save()") from None
    except (zlib.error, NotImplementedError, RuntimeError) as exc:  # a corrupt or odd entry
        raise ModelFileError(f"{path}: its 'data' entry cannot be read ({exc})") from None
    if raw is None:
        raise ModelFileError(f"{path}: a zip without stable-baselines3's 'data' entry; not a "
                             "model saved by model.save(), or cut short")
    try:
        data = json.loads(raw)
    except (ValueError, RecursionError):  # not JSON, not UTF-8, or nested beyond reason
        data = None
    if not isinstance(data, dict):
        raise ModelFileError(f"{path}: its 'data' entry is not stable-baselines3's JSON object")
    return data


def require_rl(also: tuple[tuple[str, str], ...] = ()) -> None:
    """Raise :class:`DependencyNotInstalled` unless torch, stable-baselines3 and ``also`` import.

    ``also`` lists further (module, package name) pairs of the ``rl`` extra that a caller needs
    (training also draws and reads hyperparameter files). torch comes first: its CPU wheel must
    be installed before the extra.
    """
    if importlib.util.find_spec("torch") is None:
        raise DependencyNotInstalled('torch is not installed: pip install torch==2.13.0 first '
                                     '(the CPU wheel), then pip install "azgym[rl]"')
    for module, name in (("stable_baselines3", "stable-baselines3"), *also):
        if importlib.util.find_spec(module) is None:
            raise DependencyNotInstalled(f'{name} is not installed: pip install "azgym[rl]" '
                                         '(after pip install torch==2.13.0, the CPU wheel)')


def _load_model(path: Path, algorithm: str) -> Any:
    """``algorithm.load(path)`` on the CPU; any failure is a :class:`ModelFileError`.

    SB3 warns (and leaves the entry out) when it cannot unpickle an entry; those warnings are
    told with the failure they lead to, and held back when the model loads all the same.
    """
    import stable_baselines3

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            return getattr(stable_baselines3, algorithm).load(path, device="cpu")
        except Exception as exc:  # noqa: BLE001 - an unpickled file can fail in any way
            notes = "".join(f"; {warning.message}" for warning in caught)
            raise ModelFileError(f"{path}: stable-baselines3 cannot load it as a {algorithm} "
                                 f"model ({type(exc).__name__}: {exc}{notes})") from None
