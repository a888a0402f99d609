"""The ``learned`` model's card, and the figures it reports: the localizer on generated frames.

:func:`localize_frames` runs the localizer's compiled solver
(:func:`azgym.localize.learned.pose_regression.solve_regressed`, the very code that serves) on every
frame of a :class:`~azgym.learn.dataset.FrameBatch`; :func:`generalization` does so on frames of
training layouts and of held-out layouts, both drawn with a data seed no training run uses by
default, for the pure regression and for the refined variant: the held-out p75 within 20 % of the
training layouts' says the network learned warehouses, not these warehouses.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any, TypedDict, Unpack

import numpy as np

from azgym.files import write_file
from azgym.learn.distribution import card_section
from azgym.learn.train_report import bullets, run_setup, show
from azgym.localize.learned.pose_network import PoseRegressor

__all__ = ["GENERALIZATION_SEED", "SolverSettings", "VARIANTS", "generalization", "localize_frames",
           "write_regression_card"]

GENERALIZATION_SEED = 99
"""The data seed of the generalization frames (training uses 0 unless told)."""
GENERALIZATION_LAYOUTS = 20
"""Layouts per side: the first training layouts, and every held-out one (there are 20)."""
VARIANTS = (("regression", 0), ("refined", 3))
"""The localizer's variants reported: name and ``refine_rounds``."""


class SolverSettings(TypedDict, total=False):
    """Settings of the localizer's compiled solver besides ``refine_rounds`` (defaults if left out).

    The keyword arguments of :func:`azgym.localize.learned.pose_regression.settings_array`.
    """

    gate: float
    min_trust: float
    delta_alpha_d: float
    coverage: bool
    max_iter: int
    tolerance: float


def localize_frames(batch: Any, regressor: PoseRegressor, refine_rounds: int,
                    **settings_given: Unpack[SolverSettings]) -> np.ndarray:
    """Each frame's position error [m] under the localizer (its other settings the defaults)."""
    from azgym.localize.base import INT_ROWS, ROW_BEACON_INDEX, ROW_SOURCE
    from azgym.localize.learned.pose_regression import OUT_SIZE, settings_array, solve_regressed

    settings = settings_array(refine_rounds=refine_rounds, **settings_given)
    errors = np.empty(len(batch))
    out, cov = np.empty(OUT_SIZE), np.empty((3, 3))
    for n in range(len(batch)):
        size = int(batch.mask[n].sum())
        ints = np.empty((INT_ROWS, size), dtype=np.int64)
        ints[ROW_SOURCE] = np.arange(size)
        ints[ROW_BEACON_INDEX] = batch.beacon_index[n, :size]
        solve_regressed(np.ascontiguousarray(batch.floats[n][:, :size]), ints,
                        np.ascontiguousarray(batch.features[n, :size], dtype=np.float64),
                        regressor.params, regressor.hidden, settings, out, cov,
                        np.zeros(size, dtype=np.bool_))
        errors[n] = np.hypot(out[0] - batch.pose[n, 0], out[1] - batch.pose[n, 1])
    return errors


def generalization(weights: Path, frames: int = 100,
                   seed: int = GENERALIZATION_SEED) -> dict[str, Any]:
    """p50 / p75 [m] and the share beyond 1 m, per variant, on training and held-out layouts."""
    from azgym.learn.dataset import HELD_OUT_LAYOUTS, TRAIN_LAYOUTS, make_frames

    regressor = PoseRegressor.load(weights)
    sides = {"training layouts": list(TRAIN_LAYOUTS[:GENERALIZATION_LAYOUTS]),
             "held-out layouts": list(HELD_OUT_LAYOUTS[:GENERALIZATION_LAYOUTS])}
    result: dict[str, Any] = {"data_seed": seed, "frames_per_layout": frames}
    for side, layouts in sides.items():
        batch = make_frames(layouts, frames, seed)
        for variant, rounds in VARIANTS:
            error = localize_frames(batch, regressor, rounds)
            result[f"{variant}, {side}"] = {
                "median_m": float(np.median(error)), "p75_m": float(np.percentile(error, 75)),
                "beyond_1m": float(np.mean(error > 1.0)), "frames": int(error.size)}
    for variant, _ in VARIANTS:
        train = result[f"{variant}, training layouts"]["p75_m"]
        result[f"{variant}, held-out p75 / training p75"] = \
            result[f"{variant}, held-out layouts"]["p75_m"] / train
    return result


def write_regression_card(result: Any, seeds: list[int], frames: int, seed: int) -> Path:
    """The model card of a run (:class:`azgym.learn.train.TrainResult`), with its figures."""
    from azgym.localize.learned.weights import load_weights

    info = load_weights(result.weights, "learned")[1]["training"]
    data, settings = info["data"], info["hyperparameters"]
    figures = generalization(result.weights, frames)
    digest = hashlib.sha256(result.weights.read_bytes()).hexdigest()
    lines = [
        "# learned pose regressor: model card", "",
        "A set network regresses the camera's position (and its variance) from one token per "
        "usable measurement, with a trust logit per token; the `learned` localizer takes the "
        "heading in closed form and, by default, refines the pose on the trusted measurements "
        "(azgym/localize/learned/pose_regression.py).", "",
        "## Data", "", *bullets(data, ("train", "held_out", "distribution")),
        *[f"- {name}: {data[key]['frames']} frames, {data[key]['measurements']} measurements, "
          f"inlier share {show(data[key]['inlier_share'])}"
          for key, name in (("train", "training set"), ("held_out", "held-out set"))],
        "", "## Seeds and hyperparameters", "", *bullets(settings, ()), "",
        "## Training", "",
        f"- {len(info['history'])} epochs in {info['seconds']:.1f} s ({run_setup(info)}); "
        "command: `azgym train "
        f"localizer --model learned --out DIR --layouts {len(seeds)} --frames-per-layout "
        f"{frames} --epochs {len(info['history'])} --seed {seed} --hidden {settings['hidden']}`",
        "", "| epoch | train loss | held-out loss | median [m] | p75 [m] | trust AUC |",
        "|---:|---:|---:|---:|---:|---:|",
        *[f"| {row['epoch']} | {show(row['train_loss'])} | {show(row['held_out_loss'])} | "
          f"{show(row['held_out_median_m'])} | {show(row['held_out_p75_m'])} | "
          f"{show(row['held_out_trust_auc'])} |" for row in info["history"]],
        "", f"![learning curve]({result.figure.name})", "",
        "## Generalization (the localizer, data seed "
        f"{figures['data_seed']}, {figures['frames_per_layout']} frames per layout)", "",
        "| variant, layouts | median [m] | p75 [m] | beyond 1 m |", "|---|---:|---:|---:|",
        *[f"| {key} | {row['median_m']:.3f} | {row['p75_m']:.3f} | {row['beyond_1m']:.3f} |"
          for key, row in figures.items() if isinstance(row, dict)],
        "", *[f"- {key}: {value:.3f}" for key, value in figures.items()
              if key.endswith("training p75")], "",
        *card_section(data.get("distribution")),
        "## Files", "",
        f"- `{result.weights.name}` (SHA-256 `{digest}`): load with "
        "`azgym.localize.learned.pose_network.PoseRegressor.load`",
        f"- `{result.figure.name}`: the learning curve", ""]
    return write_file(result.card, "\n".join(lines))
