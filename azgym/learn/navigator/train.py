"""Training a navigator with stable-baselines3: ``azgym train navigator``.

:func:`prepare` checks every argument — the environment id (a Navigate one), the algorithm (SAC
needs the continuous ids), the steps, the localizer (built once), the hyperparameters of
``hyperparams.yml`` (rl-baselines3-zoo's layout: one mapping per id, then per algorithm, and
``default`` for the ids without one) and the output folder — before anything is trained, so a
typo costs nothing. :func:`train_navigator` then trains on ``n_envs`` copies of the environment
(seeds seed, seed + 1, ...), evaluates the deterministic policy every ``eval_every`` steps on
the same ``eval_episodes`` episodes (seeds :data:`EVAL_SEED`, :data:`EVAL_SEED` + 1, ..., which
training never draws), keeps checkpoints, and leaves in the output folder the final policy
(``policy.zip``: the reproducible artefact, not the best evaluation's), ``evaluations.npz``,
the learning curve and the model card (:mod:`azgym.learn.navigator.card`), with the final policy
scored by :func:`azgym.bench.navigation.scoring.drive`.

torch, stable-baselines3 and PyYAML (the ``rl`` extra) are imported inside the functions, so
importing this module needs none of them.
"""

from __future__ import annotations

import importlib.util
import inspect
import io
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, SupportsFloat

import gymnasium as gym
import numpy as np

from azgym.arguments import whole_number
from azgym.envs.registration import navigation_spec
from azgym.errors import InvalidInputError, unknown_name
from azgym.files import prepare_folder, write_file
from azgym.learn.navigator.card import write_card, write_learning_curve
from azgym.learn.navigator.request import (
    CARD,
    CHECKPOINTS,
    CURVE,
    EVAL_SEED,
    EVALUATIONS,
    POLICY,
    Request,
)
from azgym.nav import policy_file
from azgym.nav.controls import Policy
from azgym.torch_kernels import pin_kernels

__all__ = ["ALGORITHMS", "EpisodeEnds", "HYPERPARAMS", "NAVIGATOR_FILES", "SETTINGS",
           "TrainingResult", "hyperparameters", "prepare", "require_rl", "run", "train_navigator"]

NAVIGATOR_FILES = (POLICY, EVALUATIONS, CURVE, CARD, f"{CHECKPOINTS}/*")
"""What a run writes into its output folder (glob patterns): what ``azgym train navigator``
claims in ``--out`` (a run there is refused without ``--overwrite``; a navigator run is not
resumed)."""

ALGORITHMS = ("ppo", "sac")
"""The algorithms ``--algo`` names (stable-baselines3's PPO and SAC)."""
HYPERPARAMS = Path(__file__).with_name("hyperparams.yml")
"""Each id's hyperparameters per algorithm, and the ``default`` entry."""
SETTINGS = ("n_envs", "n_timesteps", "policy", "policy_kwargs", "env_kwargs")
"""The keys of a hyperparameter entry that are not arguments of the algorithm itself."""
@dataclass(frozen=True)
class TrainingResult:
    """What a run leaves behind, and its figures."""

    policy: Path
    card: Path
    curve: Path
    evaluations: Path
    wall_time: float
    score: dict[str, float]


def require_rl() -> None:
    """Raise :class:`DependencyNotInstalled` unless what training needs can be imported."""
    policy_file.require_rl(also=(("yaml", "PyYAML"), ("matplotlib", "matplotlib")))


def hyperparameters(env_id: str, algo: str) -> dict[str, Any]:
    """The entry of ``env_id`` (or ``default``) for ``algo`` in :data:`HYPERPARAMS`."""
    import yaml

    table = yaml.safe_load(HYPERPARAMS.read_text(encoding="utf-8"))
    entry = table.get(env_id, table["default"])
    if algo not in entry:
        raise InvalidInputError(f"algo {algo!r}: {HYPERPARAMS.name} has no {algo} entry for "
                                f"{env_id} (it has: {', '.join(entry)})")
    return dict(entry[algo])


def prepare(env_id: str, algo: str, steps: int | None, out: Path | str, *, seed: int = 0,
            localizer: str | None = None, n_envs: int | None = None, threads: int = 1,
            eval_episodes: int = 20, eval_every: int | None = None,
            checkpoint_every: int | None = None, score_episodes: int = 50,
            overrides: dict[str, Any] | None = None) -> Request:
    """Check every argument of :func:`train_navigator` and make the output folder writable.

    Raises:
        DependencyNotInstalled: torch, stable-baselines3, PyYAML or matplotlib is missing.
        UnknownNameError: No such environment id, or localizer.
        InvalidInputError: Any other bad argument, named.
    """
    require_rl()
    spec = navigation_spec(env_id)
    if algo not in ALGORITHMS:
        raise unknown_name("algorithm", algo, ALGORITHMS)
    if algo == "sac" and spec.kwargs.get("discrete", False):
        raise InvalidInputError(
            f"algo 'sac' needs a continuous (Box) action space, and {env_id} has discrete "
            "actions: train it with ppo, or SAC on the continuous azgym/Navigate-... id")
    settings = hyperparameters(env_id, algo)
    env_kwargs = {**settings["env_kwargs"], **({} if localizer is None
                                               else {"localizer": localizer})}
    _check_localizer(env_kwargs["localizer"])
    steps = whole_number("steps", settings["n_timesteps"] if steps is None else steps, 1)
    n_envs = whole_number("envs", settings["n_envs"] if n_envs is None else n_envs, 1)
    algo_kwargs = {key: value for key, value in settings.items() if key not in SETTINGS}
    algo_kwargs.update(_checked_overrides(algo, overrides or {}))
    request = Request(
        env_id=env_id, algo=algo, steps=steps, out=Path(out), n_envs=n_envs,
        seed=whole_number("seed", seed, 0), threads=whole_number("threads", threads, 1),
        policy=settings["policy"], policy_kwargs=dict(settings.get("policy_kwargs") or {}),
        env_kwargs=env_kwargs, algo_kwargs=algo_kwargs,
        eval_episodes=whole_number("eval_episodes", eval_episodes, 1),
        eval_every=whole_number("eval_every", eval_every or max(steps // 25, 1), 1),
        checkpoint_every=whole_number("checkpoint_every",
                                      checkpoint_every or max(steps // 10, 1), 1),
        score_episodes=whole_number("score_episodes", score_episodes, 1),
        overrides=dict(overrides or {}))
    prepare_folder(request.out)
    prepare_folder(request.out / CHECKPOINTS)
    return request


def _check_localizer(name: object) -> None:
    """Build the localizer or tracker once ("truth" needs none): a bad name fails now."""
    from azgym.nav.estimator import resolve_estimator

    if not isinstance(name, str):
        raise InvalidInputError(f"localizer must be a name or \"truth\", got {name!r}")
    resolve_estimator(name)


def _checked_overrides(algo: str, overrides: dict[str, Any]) -> dict[str, Any]:
    """Overrides of the algorithm's hyperparameters, each an argument it takes."""
    accepted = inspect.signature(_algorithm(algo)).parameters
    for key in overrides:
        if key not in accepted or key in ("policy", "env", "seed", "device", "verbose"):
            raise InvalidInputError(
                f"overrides: {key!r} is not a hyperparameter of {algo}")
    return overrides


def _algorithm(algo: str) -> Any:
    from stable_baselines3 import PPO, SAC

    return {"ppo": PPO, "sac": SAC}[algo]


def train_navigator(env_id: str, algo: str, steps: int | None, out: Path | str, *,
                    seed: int = 0, localizer: str | None = None, n_envs: int | None = None,
                    threads: int = 1, eval_episodes: int = 20, eval_every: int | None = None,
                    checkpoint_every: int | None = None, score_episodes: int = 50,
                    overrides: dict[str, Any] | None = None,
                    verbose: bool = True) -> TrainingResult:
    """Train a navigator on ``env_id`` with ``algo``; write its policy, curve and card to ``out``.

    Args:
        env_id: A registered Navigate or NavigateDiscrete id.
        algo: ``"ppo"`` or ``"sac"`` (continuous ids only).
        steps: Environment steps to train for (None: the entry's ``n_timesteps``).
        out: The output folder (created; checkpoints in ``out/checkpoints``).
        seed: Seeds the training environments (seed + i for copy i) and the algorithm.
        localizer: The environment's localizer (a name, a spec or "truth"; None: the entry's).
        n_envs: Copies of the environment stepped together (None: the entry's).
        threads: torch's CPU threads.
        eval_episodes: Episodes of each evaluation (seeds from :data:`EVAL_SEED`).
        eval_every: Steps between evaluations (None: a 25th of the run).
        checkpoint_every: Steps between checkpoints (None: a tenth of the run).
        score_episodes: Episodes the final policy is scored on with
            :func:`azgym.bench.navigation.scoring.drive` (seeds from :data:`EVAL_SEED`).
        overrides: Hyperparameters of the algorithm replacing the entry's.
        verbose: Print each evaluation (and a progress bar when tqdm and rich are installed).
    """
    request = prepare(env_id, algo, steps, out, seed=seed, localizer=localizer, n_envs=n_envs,
                      threads=threads, eval_episodes=eval_episodes, eval_every=eval_every,
                      checkpoint_every=checkpoint_every, score_episodes=score_episodes,
                      overrides=overrides)
    return run(request, verbose=verbose)


class EpisodeEnds(gym.Wrapper):
    """``info["is_success"]`` at an episode's end; given ``first_seed``, fixed episode seeds.

    The last step of an episode says whether it was a success (terminated: the goal reached),
    which stable-baselines3's evaluation counts. Given ``first_seed``, episodes are seeded
    first_seed, first_seed + 1, ... until :meth:`rewind`, so every evaluation drives the very
    same episodes and the learning curve compares like with like.
    """

    def __init__(self, env: gym.Env, first_seed: int | None = None) -> None:
        super().__init__(env)
        self.first_seed = first_seed
        self.episodes = 0

    def reset(self, *, seed: int | None = None,
              options: dict[str, Any] | None = None) -> tuple[Any, dict]:
        """Reset, with the next of the fixed seeds when there are some and none is given."""
        if seed is None and self.first_seed is not None:
            seed = self.first_seed + self.episodes
            self.episodes += 1
        return self.env.reset(seed=seed, options=options)

    def rewind(self) -> None:
        """Start the fixed seeds over."""
        self.episodes = 0

    def step(self, action: Any) -> tuple[Any, SupportsFloat, bool, bool, dict]:
        """Step; mark the last step of an episode with ``is_success``."""
        observation, reward, terminated, truncated, info = self.env.step(action)
        if terminated or truncated:
            info = {**info, "is_success": bool(terminated)}
        return observation, reward, terminated, truncated, info


def run(request: Request, verbose: bool = True) -> TrainingResult:
    """Train what ``request`` says (checked by :func:`prepare`); write the output files."""
    kernels = pin_kernels()  # before torch's first operation
    import torch
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.logger import Logger

    torch.set_num_threads(request.threads)
    envs = make_vec_env(request.env_id, n_envs=request.n_envs, seed=request.seed,
                        env_kwargs=request.env_kwargs, wrapper_class=EpisodeEnds)
    model = _algorithm(request.algo)(
        request.policy, envs, seed=request.seed, device="cpu", verbose=0,
        policy_kwargs=request.policy_kwargs, **request.algo_kwargs)
    # SB3 would otherwise make an empty folder in the system's temporary one on every run
    model.set_logger(Logger(folder=None, output_formats=[]))
    started = time.perf_counter()
    model.learn(total_timesteps=request.steps, callback=_callbacks(request, verbose),
                progress_bar=verbose and _can_draw_a_bar())
    wall_time = time.perf_counter() - started
    buffer = io.BytesIO()
    model.save(buffer)
    policy = write_file(request.out / POLICY, buffer.getvalue())
    score = _score(request, policy_file.SB3Policy(model))
    evaluations = request.out / EVALUATIONS  # written by the evaluations' callback
    curve = write_learning_curve(evaluations, request.out / CURVE,
                                 f"{request.algo} on {request.env_id}")
    card = write_card(request, request.out / CARD, wall_time=wall_time, score=score,
                      kernels=kernels)
    envs.close()
    if verbose:
        print(f"{request.algo} on {request.env_id}: {request.steps} steps in {wall_time:.0f} s; "
              f"success {score['success']:.0%}, SPL {score['spl']:.2f} on "
              f"{request.score_episodes} episodes")
    return TrainingResult(policy=policy, card=card, curve=curve, evaluations=evaluations,
                          wall_time=wall_time, score=score)


def _callbacks(request: Request, verbose: bool) -> Any:
    """The evaluations (fixed episodes, deterministic actions) and the checkpoints."""
    from stable_baselines3.common.callbacks import (
        CallbackList,
        CheckpointCallback,
        ConvertCallback,
        EvalCallback,
    )
    from stable_baselines3.common.env_util import make_vec_env

    evaluation_env = make_vec_env(request.env_id, n_envs=1, env_kwargs=request.env_kwargs,
                                  wrapper_class=EpisodeEnds,
                                  wrapper_kwargs={"first_seed": EVAL_SEED})
    evaluation: Any = None

    def after_evaluation(_locals: dict, _globals: dict) -> bool:
        evaluation_env.env_method("rewind")  # the next evaluation drives the same episodes
        if verbose:
            successes = evaluation.evaluations_successes[-1]
            print(f"{evaluation.num_timesteps} steps: mean return "
                  f"{evaluation.last_mean_reward:.2f}, success {np.mean(successes):.0%} on "
                  f"{len(successes)} evaluation episodes", flush=True)
        return True

    evaluation = EvalCallback(
        evaluation_env, callback_after_eval=ConvertCallback(after_evaluation),
        n_eval_episodes=request.eval_episodes, log_path=str(request.out),
        eval_freq=max(request.eval_every // request.n_envs, 1), deterministic=True,
        verbose=0)
    checkpoints = CheckpointCallback(
        save_freq=max(request.checkpoint_every // request.n_envs, 1),
        save_path=str(request.out / CHECKPOINTS), name_prefix=request.algo)
    return CallbackList([evaluation, checkpoints])


def _can_draw_a_bar() -> bool:
    """stable-baselines3's progress bar needs both tqdm and rich."""
    return all(importlib.util.find_spec(name) is not None for name in ("tqdm", "rich"))


def _score(request: Request, navigator: Policy) -> dict[str, float]:
    """The final policy's navigation scores on the evaluation seeds."""
    from azgym.bench.navigation.scoring import drive

    env = gym.make(request.env_id, **request.env_kwargs)
    try:
        summary = drive(env, navigator, request.score_episodes, seed=EVAL_SEED)
    finally:
        env.close()
    return {key: value for key, value in summary.items() if key != "episodes"}
