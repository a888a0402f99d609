"""Policies by name or file: the scripted baseline, or a stable-baselines3 model saved as a zip.

:func:`load_policy` checks everything it can before an episode is driven: the file is there, is
a zip, holds SB3's ``data`` entry in JSON, was saved by an algorithm azgym knows how to load,
the optional ``rl`` extra is installed, SB3 can load it, and its observation and action spaces
are the environment's (a policy trained on another version of the observation, or with discrete
actions for continuous ones, is refused by name rather than driven into nonsense). Each failure
is a :class:`azgym.errors.ModelFileError` naming the file and the problem.

The file is read once, as every model file is
(:func:`azgym.untrusted.read_regular_file`: a regular file, without blocking, up to
:data:`MAX_FILE_BYTES`), and SB3 loads those very bytes.
Before anything is unpickled, each member's compression and declared size are checked and the
``data`` entry is inflated in chunks up to :data:`MAX_DATA_BYTES` (a zip's declared sizes can
lie), so a zip bomb is refused by name rather than exhausting memory.

An SB3 zip is unpickled when it is loaded, and unpickling runs code: load only files you trust.
"""

from __future__ import annotations

import importlib.util
import io
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
from azgym.untrusted import check_member, open_archive, read_member, read_regular_file

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
MAX_FILE_BYTES = 256 * 2**20
"""A policy file larger than this is refused (the shipped ones are under 200 kB; a large
convolutional policy with its optimizer's state, tens of MB)."""
MAX_MEMBER_BYTES = 512 * 2**20
"""A member of a policy file may inflate to this much (stable-baselines3 reads each whole)."""
MAX_DATA_BYTES = 64 * 2**20
"""The ``data`` entry may inflate to this much (SB3's JSON; the shipped ones' are 16 kB)."""
WHAT = "policy file"


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
    data = _read(path)
    algorithm = _algorithm_of(path, data)
    require_rl()
    _pin_kernels(path)
    model = _load_model(path, data, algorithm)
    for kind in ("observation", "action"):
        saved, wanted = getattr(model, f"{kind}_space"), getattr(env, f"{kind}_space")
        if saved != wanted:
            raise ModelFileError(f"{path}: the policy was trained on the {kind} space {saved}, "
                                 f"the environment has {wanted}")
    return SB3Policy(model)


def _read(path: Path) -> bytes:
    """The policy file's bytes (:func:`~azgym.untrusted.read_regular_file`)."""
    try:
        return read_regular_file(path, MAX_FILE_BYTES, WHAT, ModelFileError)
    except ModelFileError:
        if not path.exists() and not path.is_symlink():
            raise ModelFileError(f"{path}: no such file; give a stable-baselines3 .zip, "
                                 f"{PURE_PURSUIT!r} or {SHIPPED_PPO!r}") from None
        raise


def _algorithm_of(path: Path, raw: bytes) -> str:
    """The SB3 algorithm that saved the file, read from its ``data`` entry without unpickling."""
    data = _data_entry(path, raw)
    policy_class = data.get("policy_class")
    module = policy_class.get("__module__") if isinstance(policy_class, dict) else None
    if module == ACTOR_CRITIC:
        return "PPO" if "clip_range" in data else "A2C"
    if module not in ALGORITHMS:
        raise ModelFileError(f"{path}: its policy class ({module or 'none recorded'}) is not one "
                             "of PPO, A2C, SAC, TD3, DDPG or DQN")
    return ALGORITHMS[module]


def _data_entry(path: Path, raw: bytes) -> dict[str, Any]:
    """The JSON of SB3's ``data`` entry in the zip ``raw``, as a dict; every member checked.

    Every member's compression and declared size are checked (SB3 reads each whole, and
    Python's zip reader stops a member at its declared size); the ``data`` entry is inflated in
    chunks, counted.
    """
    try:
        with open_archive(path, raw, WHAT, ModelFileError) as archive:
            for info in archive.infolist():
                check_member(path, info, MAX_MEMBER_BYTES, WHAT, ModelFileError)
            infos = {info.filename: info for info in archive.infolist()}
            data = None if "data" not in infos else read_member(
                path, archive, infos["data"], MAX_DATA_BYTES, WHAT, ModelFileError)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError, OSError) as exc:
        raise ModelFileError(f"{path}: not a readable zip ({exc}); give a stable-baselines3 "
                             ".zip saved by model.save()") from None
    except (zlib.error, NotImplementedError, RuntimeError) as exc:  # a corrupt or odd entry
        raise ModelFileError(f"{path}: its 'data' entry cannot be read ({exc})") from None
    if data is None:
        raise ModelFileError(f"{path}: a zip without stable-baselines3's 'data' entry; not a "
                             "model saved by model.save(), or cut short")
    try:
        parsed = json.loads(data)
    except (ValueError, RecursionError):  # not JSON, not UTF-8, or nested beyond reason
        parsed = None
    if not isinstance(parsed, dict):
        raise ModelFileError(f"{path}: its 'data' entry is not stable-baselines3's JSON object")
    return parsed


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


def _pin_kernels(path: Path) -> None:
    """Ask for torch's portable CPU kernels before the policy acts (:mod:`azgym.torch_kernels`).

    Episodes are chaotic: an action that differs in its last bit on another processor moves
    the whole episode. With the portable kernels a policy's actions, and so its scores, repeat
    on every x86-64 processor; in a process where torch already chose the processor's own, they
    repeat only on a like one, which a warning says.
    """
    from azgym.torch_kernels import PORTABLE, pin_kernels

    kernels = pin_kernels()
    if kernels != PORTABLE:
        warnings.warn(f"{path}: torch already computes with the {kernels.removeprefix('native ')} "
                      "CPU kernels in this process (it ran before the policy was loaded), so the "
                      "policy's episodes repeat only on a like processor; load policies before "
                      "anything else runs torch for scores that repeat on any x86-64 processor",
                      RuntimeWarning, stacklevel=3)


def _load_model(path: Path, raw: bytes, algorithm: str) -> Any:
    """``algorithm.load`` of the file's bytes ``raw``, on the CPU; a failure is a ModelFileError.

    The bytes checked are the bytes loaded: the file is not opened again.

    SB3 warns (and leaves the entry out) when it cannot unpickle an entry; those warnings are
    told with the failure they lead to, and held back when the model loads all the same.
    """
    import stable_baselines3

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            return getattr(stable_baselines3, algorithm).load(io.BytesIO(raw), device="cpu")
        except Exception as exc:  # noqa: BLE001 - an unpickled file can fail in any way
            notes = "".join(f"; {warning.message}" for warning in caught)
            raise ModelFileError(f"{path}: stable-baselines3 cannot load it as a {algorithm} "
                                 f"model ({type(exc).__name__}: {exc}{notes})") from None
