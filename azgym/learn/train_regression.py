"""Training the ``learned`` pose regressor: Gaussian NLL on the position, BCE on the trust.

Each frame of generated warehouses (:func:`azgym.learn.dataset.make_frames`, the frames ng-ransac
trains on) becomes its tokens (:func:`azgym.localize.learned.pose_network.frame_tokens`) and its
target, the true position in the frame's normalised coordinates. The loss is

    ½ Σ_axis (log σ² + (u − û)² / σ²)  +  trust_weight · BCE(t, inlier)

per frame: the Gaussian negative log-likelihood teaches the position and an honest variance
together (the localizer's covariance), the masked binary cross-entropy (inliers weighted as in
:mod:`azgym.learn.train`) teaches the trust logits that the pooling, the heading and the
refinement lean on. Every batch's world is turned by a random angle per frame (the tokens'
beacon positions and the target alike; the camera-frame azimuths stay), since a map may face any
way and the network must not learn the generated warehouses' axes. The learning rate follows a
cosine from ``learning_rate`` to 5 % of it, a function of the epoch, so a resumed run needs no
scheduler state.

Reproducible and resumable as the inlier scorer's training is (seeds, one thread, the portable
CPU kernels of :mod:`azgym.torch_kernels`, a checkpoint per epoch, the same fingerprint rule:
:func:`azgym.learn.train.fingerprint`), with the same progress. Batches group
frames of similar size (shuffled within groups of 16 batches, the batches then shuffled), so
little padding is computed.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch

from azgym.arguments import positive_number, whole_number
from azgym.errors import InvalidInputError
from azgym.files import prepare_folder
from azgym.learn.defaults import FRAMES_PER_LAYOUT, MODEL_DEFAULTS
from azgym.learn.torch_regression import TorchPoseRegressor, export
from azgym.learn.train import (
    EVAL_BATCH,
    TrainResult,
    auc,
    finite,
    prepared_data,
    resume,
    resuming,
    save_checkpoint,
)
from azgym.learn.train import fingerprint as run_fingerprint
from azgym.learn.train_report import Batches
from azgym.localize.learned.pose_network import N_TOKENS, frame_tokens
from azgym.torch_kernels import pin_kernels

__all__ = ["CHECKPOINT_NAME", "MODEL", "RegressionConfig", "WEIGHTS_NAME", "epoch_line", "evaluate",
           "fit_regression", "frame_arrays", "learning_rate", "loss_terms", "tensors",
           "train_learned"]

_DEFAULTS = MODEL_DEFAULTS["learned"]

MODEL = "learned"
"""The model this module trains (the name in its weight file)."""
WEIGHTS_NAME = "learned.npz"
CARD_NAME = "learned-model-card.md"
CURVE_NAME = "learned-learning-curve.png"
"""The files are named after the model, as they ship (beside ng-ransac's in the package)."""
CHECKPOINT_NAME = "checkpoint.pt"
GROUP = 16
"""Batches per group of frames sorted by size (module docstring)."""


@dataclass(frozen=True)
class RegressionConfig:
    """The hyperparameters of a run; each is checked when the config is made.

    Attributes:
        epochs: Passes over the training frames.
        seed: Seeds torch's initialisation, the batches' order and the rotations.
        hidden: Width H of the network's hidden layers.
        batch_size: Frames per optimisation step.
        learning_rate: Adam's first step size (cosine-decayed to 5 % of it).
        trust_weight: Weight of the trust BCE beside the position NLL.
        threads: torch's CPU threads.
    """

    epochs: int = _DEFAULTS.epochs
    seed: int = 0
    hidden: int = _DEFAULTS.hidden
    batch_size: int = 64
    learning_rate: float = 3e-3
    trust_weight: float = 1.0
    threads: int = 1

    def __post_init__(self) -> None:
        for name in ("epochs", "hidden", "batch_size", "threads"):
            whole_number(name, getattr(self, name))
        whole_number("seed", self.seed, minimum=0)
        positive_number("learning_rate", self.learning_rate, "")
        positive_number("trust_weight", self.trust_weight, "")


def frame_arrays(batch: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A FrameBatch's tokens (N, M, N_TOKENS) float32, normalised targets (N, 2) and (c_x, c_y, s).

    Tokens come from the serving kernel itself, frame by frame, so training sees exactly what
    the localizer computes.
    """
    count, width = batch.mask.shape
    tokens = np.zeros((count, width, N_TOKENS))
    norm = np.empty((count, 3))
    for n in range(count):
        size = int(batch.mask[n].sum())
        norm[n] = frame_tokens(np.ascontiguousarray(batch.floats[n][:, :size]),
                               np.ascontiguousarray(batch.features[n, :size], dtype=np.float64),
                               tokens[n, :size])
    target = (batch.pose[:, :2] - norm[:, :2]) / norm[:, 2:]
    return tokens.astype(np.float32), target, norm


def tensors(batch: Any) -> tuple[torch.Tensor, ...]:
    """(tokens, mask, inlier, target, scale) of a FrameBatch, as training reads them."""
    tokens, target, norm = frame_arrays(batch)
    mask = np.asarray(batch.mask, dtype=bool)
    if not np.isfinite(tokens[mask]).all():
        raise InvalidInputError("frames: tokens of real measurements must be finite")
    inlier = (np.asarray(batch.inlier, dtype=bool) & mask).astype(np.float32)
    return (torch.from_numpy(tokens), torch.from_numpy(mask), torch.from_numpy(inlier),
            torch.from_numpy(target.astype(np.float32)),
            torch.from_numpy(norm[:, 2].astype(np.float32)))


def train_learned(out_dir: Path | str, *, layouts: int | Sequence[int] = _DEFAULTS.layouts,
                  frames: int = FRAMES_PER_LAYOUT, epochs: int = _DEFAULTS.epochs,
                  seed: int = 0, hidden: int = _DEFAULTS.hidden,
                  threads: int = 1, progress: bool = True) -> TrainResult:
    """Draw the frames, train the pose regressor on them, write everything to ``out_dir``.

    Every argument is checked, and the folder made writable, before any frame is drawn.
    ``frames`` is per layout. See :class:`RegressionConfig` for the others.
    """
    from azgym.learn.regression_report import write_regression_card
    from azgym.localize.learned.features import FEATURE_LAYOUT

    config = RegressionConfig(epochs=epochs, seed=seed, hidden=hidden, threads=threads)
    out, train, held_out, info = prepared_data(out_dir, layouts, frames, seed, progress)
    seeds = info["train_layouts"]
    result = fit_regression(train, held_out, out, config, feature_layout=FEATURE_LAYOUT,
                            data_info=info, progress=progress)
    write_regression_card(result, seeds, frames, seed)
    return result


def fit_regression(train: Any, held_out: Any, out_dir: Path, config: RegressionConfig, *,
                   feature_layout: str, data_info: dict[str, Any] | None = None,
                   progress: bool = True) -> TrainResult:
    """Train on FrameBatch-like data, resuming from a checkpoint of the same run if there is one.

    Writes the checkpoint, the weight file and the learning curve to ``out_dir``; the model card
    is the caller's (it scores the localizer, which needs the weight file).
    """
    from azgym.learn.train_report import write_learning_curve

    kernels = pin_kernels()
    out_dir = prepare_folder(Path(out_dir))
    torch.set_num_threads(config.threads)
    torch.manual_seed(config.seed)
    data = tensors(train), tensors(held_out)
    model = TorchPoseRegressor(N_TOKENS, config.hidden)
    optimizer = torch.optim.Adam(model.parameters(), lr=config.learning_rate)
    positives = float(data[0][2].sum())
    pos_weight = torch.tensor(float(np.clip((float(data[0][1].sum()) - positives)
                                            / max(positives, 1.0), 0.05, 20.0)))
    stamp = run_fingerprint(data, config, feature_layout, kernels)
    checkpoint = out_dir / CHECKPOINT_NAME
    history, seconds = resume(checkpoint, model, optimizer, stamp)
    if len(history) > config.epochs:
        raise InvalidInputError(f"{checkpoint}: holds {len(history)} epochs, more than the "
                                f"{config.epochs} asked for; --overwrite starts over")
    steps = math.ceil(len(data[0][0]) / config.batch_size)
    with Batches(MODEL, (config.epochs - len(history)) * steps, progress) as batches:
        if history:
            batches.say(resuming(checkpoint, len(history), config.epochs))
        for epoch in range(len(history), config.epochs):
            started = time.perf_counter()
            for group in optimizer.param_groups:
                group["lr"] = learning_rate(config, epoch)
            loss = _train_epoch(model, optimizer, data[0], config, epoch, pos_weight, batches)
            history.append({"epoch": epoch + 1, "train_loss": loss,
                            **evaluate(model, data[1], pos_weight, config.trust_weight)})
            seconds += time.perf_counter() - started
            save_checkpoint(checkpoint, model, optimizer, history, seconds, stamp)
            batches.say(epoch_line(history[-1]))
    info = {"data": {**(data_info or {}), "train": _counts(data[0]),
                     "held_out": _counts(data[1])},
            "hyperparameters": {**asdict(config), "pos_weight": float(pos_weight),
                                "optimizer": "Adam, cosine learning rate",
                                "loss": "Gaussian NLL of the position + BCE of the trust",
                                "augmentation": "a random world rotation per frame"},
            "torch_version": torch.__version__, "kernels": kernels,
            "seconds": round(seconds, 3),
            "history": history, "final": history[-1] if history else {}}
    weights = export(model, out_dir / WEIGHTS_NAME, info, feature_layout=feature_layout,
                     name=MODEL)
    figure = write_learning_curve(history, out_dir / CURVE_NAME, figures=CURVES,
                                  loss_label="position NLL + trust BCE")
    return TrainResult(weights, out_dir / CARD_NAME, figure, checkpoint, history, seconds)


CURVES = (("held_out_median_m", "median error [m]"), ("held_out_p75_m", "p75 error [m]"),
          ("held_out_trust_auc", "trust AUC"))
"""The held-out figures plotted per epoch, each with its label."""


def learning_rate(config: RegressionConfig, epoch: int) -> float:
    """The cosine schedule: ``learning_rate`` at epoch 0, 5 % of it after the last."""
    share = epoch / max(config.epochs - 1, 1)
    return config.learning_rate * (0.05 + 0.95 * 0.5 * (1.0 + math.cos(math.pi * share)))


def _batches(sizes: np.ndarray, config: RegressionConfig, epoch: int) -> list[np.ndarray]:
    """The epoch's batches: shuffled, grouped by size, the batches shuffled again."""
    rng = np.random.default_rng([config.seed, epoch])
    order = rng.permutation(sizes.size)
    span = config.batch_size * GROUP
    batches = []
    for start in range(0, order.size, span):
        chunk = order[start:start + span]
        chunk = chunk[np.argsort(sizes[chunk], kind="stable")]
        batches += [chunk[i:i + config.batch_size] for i in range(0, chunk.size,
                                                                  config.batch_size)]
    return [batches[i] for i in rng.permutation(len(batches))]


def _rotated(tokens: torch.Tensor, target: torch.Tensor, angle: torch.Tensor
             ) -> tuple[torch.Tensor, torch.Tensor]:
    """The frames' worlds turned by ``angle`` (one per frame): beacon positions and target."""
    c, s = torch.cos(angle), torch.sin(angle)
    u, v = tokens[..., 2], tokens[..., 3]
    c3, s3 = c[:, None], s[:, None]
    turned = torch.stack([c3 * u - s3 * v, s3 * u + c3 * v], dim=-1)
    tokens = torch.cat([tokens[..., :2], turned, tokens[..., 4:]], dim=-1)
    target = torch.stack([c * target[:, 0] - s * target[:, 1],
                          s * target[:, 0] + c * target[:, 1]], dim=-1)
    return tokens, target


def loss_terms(model: TorchPoseRegressor, batch: tuple[torch.Tensor, ...],
               pos_weight: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """Mean NLL of the position, mean BCE of the trust, and the heads of a batch."""
    tokens, mask, inlier, target = batch[:4]
    trust, head = model(tokens, mask)
    log_var = head[:, 2:]
    nll = 0.5 * (log_var + (target - head[:, :2]) ** 2 * torch.exp(-log_var)).sum(dim=1).mean()
    bce = torch.nn.functional.binary_cross_entropy_with_logits(
        trust[mask], inlier[mask], pos_weight=pos_weight)
    return nll, bce, head


def _train_epoch(model: TorchPoseRegressor, optimizer: torch.optim.Optimizer,
                 data: tuple[torch.Tensor, ...], config: RegressionConfig, epoch: int,
                 pos_weight: torch.Tensor, batches: Batches) -> float:
    """One pass over the training frames; the mean loss over its batches."""
    model.train()
    sizes = data[1].sum(dim=1).numpy()
    generator = torch.Generator().manual_seed(config.seed * 100_003 + epoch)
    total, count = 0.0, 0
    for index in _batches(sizes, config, epoch):
        rows = torch.from_numpy(index)
        width = int(sizes[index].max())
        tokens, mask = data[0][rows, :width], data[1][rows, :width]
        angle = torch.rand(len(index), generator=generator) * (2 * math.pi)
        tokens, target = _rotated(tokens, data[3][rows], angle)
        nll, bce, _ = loss_terms(model, (tokens, mask, data[2][rows, :width], target),
                                 pos_weight)
        loss = nll + config.trust_weight * bce
        optimizer.zero_grad()
        loss.backward()
        optimizer.step()
        total += loss.item()
        count += 1
        batches.step()
    return total / max(count, 1)


@torch.no_grad()
def evaluate(model: TorchPoseRegressor, data: tuple[torch.Tensor, ...],
             pos_weight: torch.Tensor, trust_weight: float) -> dict[str, Any]:
    """Held-out loss, the regressed position's median and p75 error [m], the trust's AUC."""
    model.eval()
    losses, errors, trusts = [], [], []
    for start in range(0, len(data[0]), EVAL_BATCH):
        part = tuple(tensor[start:start + EVAL_BATCH] for tensor in data)
        nll, bce, head = loss_terms(model, part, pos_weight)
        losses.append((float(nll + trust_weight * bce), len(part[0])))
        errors.append((torch.linalg.norm(head[:, :2] - part[3], dim=1) * part[4]).numpy())
        trusts.append(model(part[0], part[1])[0].numpy())
    error = np.concatenate(errors)
    mask = data[1].numpy()
    trust = np.concatenate(trusts)[mask]
    loss = sum(value * n for value, n in losses) / max(sum(n for _, n in losses), 1)
    return {"held_out_loss": finite(loss),
            "held_out_median_m": float(np.median(error)) if error.size else None,
            "held_out_p75_m": float(np.percentile(error, 75)) if error.size else None,
            "held_out_trust_auc": auc(trust, data[2].numpy()[mask] > 0.5)}


def epoch_line(figures: dict[str, Any]) -> str:
    """``epoch 3: train 0.4121, held-out 0.4410, median 0.52 m, p75 0.98 m, trust AUC 0.934``."""
    def show(value: float | None, digits: int) -> str:
        return "n/a" if value is None else f"{value:.{digits}f}"

    return (f"epoch {figures['epoch']}: train {figures['train_loss']:.4f}, held-out "
            f"{show(figures['held_out_loss'], 4)}, median "
            f"{show(figures['held_out_median_m'], 2)} m, p75 "
            f"{show(figures['held_out_p75_m'], 2)} m, trust AUC "
            f"{show(figures['held_out_trust_auc'], 3)}")


def _counts(split: tuple[torch.Tensor, ...]) -> dict[str, Any]:
    """Frames, measurements and inlier share of a split (for the card)."""
    mask, inlier = split[1], split[2]
    return {"frames": len(mask), "measurements": int(mask.sum()),
            "inlier_share": finite(float(inlier[mask].mean()))}
