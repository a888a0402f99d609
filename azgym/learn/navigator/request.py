"""A navigator's training run, every argument checked.

What :func:`~azgym.learn.navigator.train.run` trains and the model card
(:mod:`azgym.learn.navigator.card`) describes.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

__all__ = ["CARD", "CHECKPOINTS", "CURVE", "EVALUATIONS", "EVAL_SEED", "POLICY", "Request"]

POLICY, EVALUATIONS, CURVE, CARD = ("policy.zip", "evaluations.npz", "learning-curve.png",
                                    "model-card.md")
"""The files a run leaves in its output folder: the final policy, the evaluations (the name
stable-baselines3's ``EvalCallback`` gives its log), the learning curve and the model card."""
CHECKPOINTS = "checkpoints"
"""The folder of a run's checkpoints, inside its output folder."""

EVAL_SEED = 1_000_000
"""The first seed of the evaluation episodes (and of the final scoring); training starts its
environments at the run's seed, which stays far below."""


@dataclass(frozen=True)
class Request:
    """A training run, every argument checked: what :func:`run` trains."""

    env_id: str
    algo: str
    steps: int
    out: Path
    seed: int
    n_envs: int
    threads: int
    policy: str
    policy_kwargs: dict[str, Any]
    env_kwargs: dict[str, Any]
    algo_kwargs: dict[str, Any]
    eval_episodes: int
    eval_every: int
    checkpoint_every: int
    score_episodes: int
    overrides: dict[str, Any] = field(default_factory=dict)

    def command(self) -> str:
        """The ``azgym train navigator`` line that repeats this run."""
        line = (f"azgym train navigator --env {self.env_id} --algo {self.algo} "
                f"--steps {self.steps} --out {self.out} --seed {self.seed} "
                f"--localizer {self.env_kwargs['localizer']} --envs {self.n_envs} "
                f"--threads {self.threads}")
        if self.overrides:  # not on the command line: the Python call's extras
            line += f"  # plus train_navigator(..., overrides={self.overrides!r})"
        return line
