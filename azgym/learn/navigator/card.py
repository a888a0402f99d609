"""What a navigator's training leaves beside its policy: the learning curve and the model card.

The curve is a PNG of the evaluations stable-baselines3 logged (``evaluations.npz``: the mean
return and the success rate of the fixed evaluation episodes, against the steps trained); the
card is a markdown page of everything needed to judge and redo the run: the command line, the
seeds, the hyperparameters, the time it took, the versions, the final policy's navigation
scores and the policy file's SHA-256.
"""

from __future__ import annotations

import hashlib
import math
import platform
from pathlib import Path

import numpy as np

from azgym._version import __version__
from azgym.files import write_file
from azgym.learn.navigator.request import CURVE, EVAL_SEED, EVALUATIONS, POLICY, Request
from azgym.torch_kernels import describe_kernels

__all__ = ["REPRODUCIBILITY", "write_card", "write_learning_curve"]

REPRODUCIBILITY = (
    "Runs are repeatable on one machine: the same command, with the same versions of azgym, "
    "torch and stable-baselines3 on the CPU, gives a policy with bit-identical parameters "
    "(azgym's tests train twice with one seed and compare every parameter; policy.zip itself "
    "differs, as it records when it was written). torch computes with the CPU kernels every "
    "x86-64 processor computes alike (azgym.torch_kernels), but stable-baselines3 promises no "
    "more than repeatability on one machine: another number of torch threads, other versions of "
    "torch, numpy or numba, or the localizer's compiled kernels on another processor may change "
    "the floating-point sums, and a policy trained on them differs, though it should score "
    "alike.")
"""What the card says of repeating a run (checked by tests/nav/test_train_navigator.py)."""


def write_learning_curve(evaluations: Path, path: Path, title: str) -> Path:
    """Mean evaluation return and success rate against the steps trained; a PNG."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    logged = np.load(evaluations)
    steps = logged["timesteps"]
    figure, (returns, success) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    returns.plot(steps, logged["results"].mean(axis=1), marker="o")
    returns.set_ylabel("mean return")
    if "successes" in logged:
        success.plot(steps, 100 * logged["successes"].mean(axis=1), marker="o")
    success.set_ylim(-2, 102)
    success.set_ylabel("success rate [%]")
    for axis in (returns, success):
        axis.set_xlabel("environment steps")
        axis.grid(alpha=0.3)
    figure.suptitle(f"{title}: deterministic policy on {logged['results'].shape[1]} fixed "
                    "evaluation episodes")
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=110)
    plt.close(figure)
    return write_file(path, buffer.getvalue())


def write_card(request: Request, path: Path, *, wall_time: float,
               score: dict[str, float], kernels: str) -> Path:
    """The model card of a finished run, beside its policy.

    ``kernels`` names the CPU kernels torch computed with (:func:`azgym.torch_kernels.pin_kernels`).
    """
    import stable_baselines3
    import torch
    import yaml

    digest = hashlib.sha256((request.out / POLICY).read_bytes()).hexdigest()
    settings = {"n_envs": request.n_envs, "policy": request.policy,
                "policy_kwargs": request.policy_kwargs, "env_kwargs": request.env_kwargs,
                **request.algo_kwargs}
    scores = [("success rate", _shown(score["success"], ".1%")),
              ("SPL", _shown(score["spl"], ".3f")),
              ("collisions per episode", _shown(score["collisions"], ".2f")),
              ("time to goal [s]", _shown(score["time_to_goal"], ".1f")),
              ("localizer answered", _shown(score["answered"], ".1%")),
              ("localization error median / p95 [cm]", _shown(score["error_median_cm"], ".1f")
               + " / " + _shown(score["error_p95_cm"], ".1f"))]
    lines = [
        f"# {request.algo} navigator on {request.env_id}: model card", "",
        f"A stable-baselines3 {request.algo.upper()} policy driving the forklift along the "
        "planner's path (azgym/envs/navigate.py), trained by `azgym train navigator`.", "",
        "## Reproduce", "", "```", request.command(), "```", "",
        f"- seed: {request.seed} (training environments {request.seed} … "
        f"{request.seed + request.n_envs - 1} on their first episodes, then their own streams)",
        f"- steps: {request.steps}",
        f"- wall time: {wall_time:.1f} s ({request.steps / wall_time:.0f} steps/s, evaluations "
        f"included; {request.threads} torch thread(s))",
        f"- CPU kernels: {describe_kernels(kernels)}",
        f"- versions: azgym {__version__}, torch {torch.__version__}, stable-baselines3 "
        f"{stable_baselines3.__version__}, Python {platform.python_version()}",
        f"- {POLICY} SHA-256: `{digest}`", "", REPRODUCIBILITY, "",
        "## Hyperparameters", "", "```yaml",
        yaml.safe_dump(settings, sort_keys=False, default_flow_style=None).rstrip(), "```", "",
        "## Evaluation", "",
        f"Every {request.eval_every} steps the deterministic policy drove the same "
        f"{request.eval_episodes} episodes (seeds {EVAL_SEED} … "
        f"{EVAL_SEED + request.eval_episodes - 1}); see `{EVALUATIONS}` and "
        f"`{CURVE}`. The final policy (`{POLICY}`, not the best evaluation's), "
        "scored by `azgym.bench.navigation.scoring.drive` on "
        f"{request.score_episodes} episodes (seeds "
        f"{EVAL_SEED} … {EVAL_SEED + request.score_episodes - 1}):", "",
        "| figure | value |", "|---|---:|", *[f"| {name} | {value} |" for name, value in scores],
        ""]
    return write_file(path, "\n".join(lines))



def _shown(value: float, spec: str) -> str:
    """A figure as the card shows it; "—" where there is none (no episode reached the goal)."""
    return "—" if math.isnan(value) else format(value, spec)
