"""Training the ng-ransac inlier scorer: supervised, masked binary cross-entropy on ``inlier``.

Each measurement of a generated frame is labelled an inlier (a direct or partly covered view of
the right beacon at its mapped position) or not (mirror ghosts, misread ids, moved beacons,
injected outliers), and :class:`~azgym.learn.torch_net.TorchInlierScorer` learns to tell them
apart from the features alone. The loss is taken over real measurements only (the padding of
a batch is masked out), with positives weighted by negatives / positives of the training set,
so that both classes count alike whatever the frames' outlier share; what NG-RANSAC needs
from the scores is their order, which the held-out AUC and top-3 figures measure.

Runs are reproducible: seeded initialisation and shuffling, one torch thread by default, and
the CPU kernels every x86-64 processor computes alike (:mod:`azgym.torch_kernels`). Batches are
counted on the shared meter (:mod:`azgym.progress`). A checkpoint after every epoch is resumed
by a run with the same data and settings (ending with the very weights of one never
interrupted). At the end: ``ng-ransac.npz``, the learning curve and the model card
(:mod:`azgym.learn.train_report`).
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from scipy.stats import rankdata

from azgym.arguments import positive_number, whole_number
from azgym.errors import InvalidInputError
from azgym.files import prepare_folder, write_file
from azgym.learn.defaults import FRAMES_PER_LAYOUT, MODEL_DEFAULTS
from azgym.learn.torch_net import TorchInlierScorer, export
from azgym.learn.train_report import Batches, write_card, write_learning_curve
from azgym.progress import Meter, Progress
from azgym.torch_kernels import pin_kernels

__all__ = ["CHECKPOINT_NAME", "EVAL_BATCH", "MODEL", "TrainConfig", "TrainResult", "WEIGHTS_NAME",
           "auc", "build_data", "evaluate", "fingerprint", "finite", "fit", "prepared_data",
           "resume", "resuming", "save_checkpoint", "train_ng_ransac"]

MODEL = "ng-ransac"
"""The model this module trains (the name in its weight file)."""
_DEFAULTS = MODEL_DEFAULTS[MODEL]
WEIGHTS_NAME, CHECKPOINT_NAME = "ng-ransac.npz", "checkpoint.pt"
EVAL_BATCH = 1024
"""Frames per forward pass when scoring the held-out set (bounds the memory it takes)."""


@dataclass(frozen=True)
class TrainConfig:
    """The hyperparameters of a run; each is checked when the config is made.

    Attributes:
        epochs: Passes over the training frames.
        seed: Seeds torch's initialisation and the batches' order.
        hidden: Width H of the network's hidden layers.
        batch_size: Frames per optimisation step.
        learning_rate: Adam's step size.
        pos_weight: Weight of an inlier in the loss (None: negatives / positives of the
            training set, so both classes weigh alike).
        threads: torch's CPU threads.
    """

    epochs: int = _DEFAULTS.epochs
    seed: int = 0
    hidden: int = _DEFAULTS.hidden
    batch_size: int = 64
    learning_rate: float = 1e-3
    pos_weight: float | None = None
    threads: int = 1

    def __post_init__(self) -> None:
        for name in ("epochs", "hidden", "batch_size", "threads"):
            whole_number(name, getattr(self, name))
        whole_number("seed", self.seed, minimum=0)
        positive_number("learning_rate", self.learning_rate, "")
        if self.pos_weight is not None:
            positive_number("pos_weight", self.pos_weight, "")


@dataclass
class TrainResult:
    """What a run wrote and measured: its files, and per epoch the figures of each."""

    weights: Path
    card: Path
    figure: Path
    checkpoint: Path
    history: list[dict[str, Any]] = field(default_factory=list)
    seconds: float = 0.0


def build_data(layouts: Sequence[int], frames_per_layout: int, seed: int,
               progress: Progress | None = None) -> tuple[Any, Any, dict[str, Any]]:
    """The training and held-out frames (:func:`azgym.learn.dataset.make_frames`).

    Args:
        layouts: The generator seeds to train on (:func:`azgym.learn.dataset.layout_seeds`).
        frames_per_layout: Frames drawn in each warehouse (held-out ones too).
        seed: Seeds the frames.
        progress: Hears the count of layouts drawn, training then held-out.

    Returns:
        The training FrameBatch, the held-out one (every held-out layout), and what the model
        card says of them (with the training frames' distribution, which the served model
        checks its frames against: :mod:`azgym.localize.learned.distribution`).
    """
    from azgym.learn.dataset import HELD_OUT_LAYOUTS, make_frames
    from azgym.learn.distribution import batch_distribution

    train = make_frames(layouts, frames_per_layout, seed, progress=progress)
    held_out = make_frames(HELD_OUT_LAYOUTS, frames_per_layout, seed, progress=progress)
    info = {"train_layouts": list(layouts),
            "held_out_layouts": [int(x) for x in HELD_OUT_LAYOUTS],
            "frames_per_layout": frames_per_layout, "data_seed": seed,
            "distribution": batch_distribution(train.floats, train.beacon_index,
                                               train.mask).to_manifest()}
    return train, held_out, info


def train_ng_ransac(out_dir: Path | str, *, layouts: int | Sequence[int] = _DEFAULTS.layouts,
                    frames: int = FRAMES_PER_LAYOUT, epochs: int = _DEFAULTS.epochs,
                    seed: int = 0, hidden: int = _DEFAULTS.hidden,
                    threads: int = 1, progress: bool = True) -> TrainResult:
    """Draw the frames, train the inlier scorer on them, write everything to ``out_dir``.

    Every argument is checked, and the folder made writable, before any frame is drawn.
    ``frames`` is per layout. See :class:`TrainConfig` for the others.
    """
    from azgym.learn.calibrate import calibrate_weights, card_section
    from azgym.localize.learned.features import FEATURE_LAYOUT

    config = TrainConfig(epochs=epochs, seed=seed, hidden=hidden, threads=threads)
    out, train, held_out, info = prepared_data(out_dir, layouts, frames, seed, progress)
    result = fit(train, held_out, out, config, feature_layout=FEATURE_LAYOUT, data_info=info,
                 progress=progress)
    uncalibrated = hashlib.sha256(result.weights.read_bytes()).hexdigest()
    calibration = calibrate_weights(result.weights, held_out)
    calibrated = hashlib.sha256(result.weights.read_bytes()).hexdigest()
    card = result.card.read_text(encoding="utf-8").replace(uncalibrated, calibrated)
    write_file(result.card, card + "\n" + card_section(calibration))
    return result


def prepared_data(out_dir: Path | str, layouts: int | Sequence[int], frames: int, seed: int,
                  progress: bool = False) -> tuple[Path, Any, Any, dict[str, Any]]:
    """The output folder, made writable, and the frames drawn, once every argument is checked.

    With ``progress`` the drawing shows its count of layouts (:class:`azgym.progress.Meter`).

    Returns the folder, the training frames, the held-out ones and what the model card says of
    them (``draw_seconds`` included).
    """
    from azgym.learn.dataset import layout_seeds

    whole_number("frames", frames)
    seeds = layout_seeds(layouts)
    out = prepare_folder(Path(out_dir))
    started = time.perf_counter()
    train, held_out, info = build_data(seeds, frames, seed, Meter() if progress else None)
    info["draw_seconds"] = round(time.perf_counter() - started, 1)
    return out, train, held_out, info


def fit(train: Any, held_out: Any, out_dir: Path, config: TrainConfig, *,
        feature_layout: str, data_info: dict[str, Any] | None = None,
        progress: bool = True) -> TrainResult:
    """Train on FrameBatch-like data (``features``, ``mask``, ``inlier``), resuming if it can.

    Args:
        train: The training frames.
        held_out: The held-out frames, scored after every epoch.
        out_dir: Where the checkpoint, weights, learning curve and model card go.
        config: The hyperparameters.
        feature_layout: The layout of ``features`` (goes into the weight file).
        data_info: What the model card says of the data (seeds, layouts).
        progress: Count the batches on the meter and write a line per epoch.
    """
    kernels = pin_kernels()
    out_dir = prepare_folder(Path(out_dir))
    torch.set_num_threads(config.threads)
    torch.manual_seed(config.seed)
    data = _tensors(train), _tensors(held_out)
    model = TorchInlierScorer(data[0][0].shape[-1], config.hidden)
    optimizer = torch.optim.Adam(model.parameters(), lr=config.learning_rate)
    pos_weight = torch.tensor(config.pos_weight or _balanced_weight(data[0][2], data[0][1]))
    stamp = fingerprint(data, config, feature_layout, kernels)
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
            loss = _train_epoch(model, optimizer, data[0], config, epoch, pos_weight, batches)
            history.append({"epoch": epoch + 1, "train_loss": loss,
                            **evaluate(model, data[1], pos_weight)})
            seconds += time.perf_counter() - started
            save_checkpoint(checkpoint, model, optimizer, history, seconds, stamp)
            batches.say(_epoch_line(history[-1]))
    info = _training_info(config, float(pos_weight), data, data_info, history, seconds, kernels)
    weights = export(model, out_dir / WEIGHTS_NAME, info, feature_layout=feature_layout,
                     name=MODEL)
    figure = write_learning_curve(history, out_dir / "learning-curve.png")
    card = write_card(out_dir / "model-card.md", info, weights, figure)
    return TrainResult(weights, card, figure, checkpoint, history, seconds)


def _tensors(batch: Any) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    """A FrameBatch's features (float32), mask and inlier labels (float32) as tensors."""
    features = np.asarray(batch.features, dtype=np.float32)
    mask = np.asarray(batch.mask, dtype=bool)
    inlier = np.asarray(batch.inlier, dtype=bool)
    if features.ndim != 3 or mask.shape != features.shape[:2] or inlier.shape != mask.shape:
        raise InvalidInputError(f"frames: features {features.shape}, mask {mask.shape} and "
                                f"inlier {inlier.shape} must be (N, M, F), (N, M), (N, M)")
    inlier = inlier & mask  # (never in place: the caller's frames stay as they were)
    if not np.isfinite(features[mask]).all():
        raise InvalidInputError("frames: features of real measurements must be finite")
    return (torch.from_numpy(features), torch.from_numpy(mask),
            torch.from_numpy(inlier.astype(np.float32)))


def _balanced_weight(inlier: torch.Tensor, mask: torch.Tensor) -> float:
    """Negatives / positives among real measurements, clipped to [0.05, 20]."""
    positives = float(inlier[mask].sum())
    negatives = float(mask.sum()) - positives
    return float(np.clip(negatives / max(positives, 1.0), 0.05, 20.0))


def _loss(model: TorchInlierScorer, batch: tuple[torch.Tensor, ...],
          pos_weight: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Mean BCE over the real measurements of a batch, and their logits."""
    features, mask, inlier = batch
    logits = model(features, mask)[mask]
    loss = torch.nn.functional.binary_cross_entropy_with_logits(
        logits, inlier[mask], pos_weight=pos_weight)
    return loss, logits


def _train_epoch(model: TorchInlierScorer, optimizer: torch.optim.Optimizer,
                 data: tuple[torch.Tensor, ...], config: TrainConfig, epoch: int,
                 pos_weight: torch.Tensor, batches: Batches) -> float:
    """One pass over the training frames in a (seed, epoch)-seeded order; the mean loss."""
    model.train()
    order = np.random.default_rng([config.seed, epoch]).permutation(len(data[0]))
    total, count = 0.0, 0
    for start in range(0, len(order), config.batch_size):
        index = torch.from_numpy(order[start:start + config.batch_size])
        batch = tuple(tensor[index] for tensor in data)
        optimizer.zero_grad()
        loss, logits = _loss(model, batch, pos_weight)
        if len(logits):
            loss.backward()
            optimizer.step()
            total += float(loss.detach()) * len(logits)
            count += len(logits)
        batches.step()
    return total / max(count, 1)


def evaluate(model: TorchInlierScorer, data: tuple[torch.Tensor, ...],
             pos_weight: torch.Tensor) -> dict[str, float | None]:
    """Held-out figures: loss, accuracy (logit > 0), AUC, and top-3.

    ``top3`` is the share of frames with at least three inliers whose three best-scored
    measurements are all inliers: how often NG-RANSAC's first hypothesis is a clean triplet.
    """
    model.eval()
    with torch.no_grad():
        logits = torch.cat([model(data[0][i:i + EVAL_BATCH], data[1][i:i + EVAL_BATCH])
                            for i in range(0, max(len(data[0]), 1), EVAL_BATCH)])
    mask, inlier = data[1].numpy(), data[2].numpy() > 0.5
    scores = logits.numpy().astype(np.float64)
    real = scores[mask]
    loss = torch.nn.functional.binary_cross_entropy_with_logits(
        logits[data[1]], data[2][data[1]], pos_weight=pos_weight)
    correct = (real > 0) == inlier[mask]
    return {"held_out_loss": finite(float(loss)),
            "held_out_accuracy": float(correct.mean()) if correct.size else None,
            "held_out_auc": auc(real, inlier[mask]),
            "held_out_top3": _top3(np.where(mask, scores, -np.inf), inlier)}


def auc(scores: np.ndarray, labels: np.ndarray) -> float | None:
    """Area under the ROC curve (Mann-Whitney, ties counted half); None with one class."""
    positives = int(labels.sum())
    negatives = labels.size - positives
    if positives == 0 or negatives == 0:
        return None
    ranks = rankdata(scores)
    return float((ranks[labels].sum() - positives * (positives + 1) / 2)
                 / (positives * negatives))


def _top3(scores: np.ndarray, inlier: np.ndarray) -> float | None:
    """The share of frames (with ≥ 3 inliers) whose 3 best scores are all inliers."""
    eligible = inlier.sum(axis=1) >= 3
    if not eligible.any():
        return None
    best = np.argsort(-scores[eligible], axis=1, kind="stable")[:, :3]
    return float(np.take_along_axis(inlier[eligible], best, axis=1).all(axis=1).mean())


def finite(value: float) -> float | None:
    """The value, or None (JSON's null) when it is not finite."""
    return value if math.isfinite(value) else None


def fingerprint(data: tuple[tuple[torch.Tensor, ...], ...], config: Any,
                feature_layout: str, kernels: str) -> str:
    """SHA-256 of the data and every setting a resumed run must share (not epochs, threads).

    ``config`` is a dataclass of the run's hyperparameters (any model's); ``kernels`` the CPU
    kernels torch computes with (:func:`azgym.torch_kernels.pin_kernels`): a run resumed on
    other kernels would not end with the weights of one never interrupted.
    """
    digest = hashlib.sha256(feature_layout.encode())
    digest.update(kernels.encode())
    settings = {k: v for k, v in asdict(config).items() if k not in ("epochs", "threads")}
    digest.update(json.dumps(settings, sort_keys=True).encode())
    for split in data:
        for tensor in split:
            digest.update(str(tuple(tensor.shape)).encode())
            digest.update(tensor.numpy().tobytes())
    return digest.hexdigest()


def resume(path: Path, model: torch.nn.Module, optimizer: torch.optim.Optimizer,
           fingerprint: str) -> tuple[list[dict[str, Any]], float]:
    """Load the checkpoint of this very run, if there is one: (history, seconds so far)."""
    if not path.exists():
        return [], 0.0
    try:
        state = torch.load(io.BytesIO(path.read_bytes()), weights_only=True)
        found = state["fingerprint"]
    except Exception as exc:  # any unreadable checkpoint is refused alike
        reason = (str(exc).splitlines() or [type(exc).__name__])[0][:120]
        raise InvalidInputError(f"{path}: cannot read the checkpoint ({reason}); "
                                "--overwrite starts over") from None
    if found != fingerprint:
        raise InvalidInputError(f"{path}: a checkpoint of another run (other data, settings "
                                "or CPU kernels); --overwrite starts over, or use another "
                                "folder")
    model.load_state_dict(state["model"])
    optimizer.load_state_dict(state["optimizer"])
    return list(state["history"]), float(state["seconds"])


def resuming(checkpoint: Path, done: int, epochs: int) -> str:
    """What a resumed run says first: ``resuming from out/checkpoint.pt (epoch 3 of 8 done)``."""
    return f"resuming from {checkpoint} (epoch {done} of {epochs} done)"


def save_checkpoint(path: Path, model: torch.nn.Module, optimizer: torch.optim.Optimizer,
                    history: list[dict[str, Any]], seconds: float, fingerprint: str) -> None:
    """The run's state after an epoch, written atomically (an interruption keeps the last)."""
    buffer = io.BytesIO()
    torch.save({"model": model.state_dict(), "optimizer": optimizer.state_dict(),
                "history": history, "seconds": seconds, "fingerprint": fingerprint}, buffer)
    write_file(path, buffer.getvalue())


def _epoch_line(figures: dict[str, Any]) -> str:
    """``epoch 3: train 0.4121, held-out 0.4410, accuracy 0.871, AUC 0.934, top-3 0.802``."""
    def show(value: float | None, digits: int) -> str:
        return "n/a" if value is None else f"{value:.{digits}f}"

    return (f"epoch {figures['epoch']}: train {figures['train_loss']:.4f}, held-out "
            f"{show(figures['held_out_loss'], 4)}, accuracy "
            f"{show(figures['held_out_accuracy'], 3)}, AUC {show(figures['held_out_auc'], 3)}, "
            f"top-3 {show(figures['held_out_top3'], 3)}")


def _training_info(config: TrainConfig, pos_weight: float,
                   data: tuple[tuple[torch.Tensor, ...], ...],
                   data_info: dict[str, Any] | None, history: list[dict[str, Any]],
                   seconds: float, kernels: str) -> dict[str, Any]:
    """The weight file's ``training``: data, seeds, hyperparameters, kernels, time, figures."""
    counts = {}
    for name, (_, mask, inlier) in zip(("train", "held_out"), data, strict=True):
        counts[name] = {"frames": len(mask), "measurements": int(mask.sum()),
                        "inlier_share": finite(float(inlier[mask].mean()))}
    return {"data": {**(data_info or {}), **counts},
            "hyperparameters": {**asdict(config), "pos_weight": pos_weight,
                                "optimizer": "Adam", "loss": "masked BCE on inlier"},
            "torch_version": torch.__version__, "kernels": kernels,
            "seconds": round(seconds, 3), "history": history,
            "final": history[-1] if history else {}}
