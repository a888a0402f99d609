"""What a training run shows and leaves behind: its progress, learning curve and model card.

The progress is the run's batches counted on the shared meter (:mod:`azgym.progress`: a bar with
the time left in a terminal, a plain line every few seconds when piped) with a line per epoch;
the learning curve is a PNG of the training and held-out loss and the held-out figures per
epoch; the model card is a markdown page of everything needed to judge and redo the run: the
data and its seeds, the hyperparameters, the CPU kernels and the time it took, the figures and
the weight file's SHA-256.
"""

from __future__ import annotations

import hashlib
import io
import json
from pathlib import Path
from types import TracebackType
from typing import Any

from azgym.files import write_file
from azgym.learn.distribution import card_section
from azgym.progress import Meter, Progress, counter
from azgym.torch_kernels import describe_kernels

__all__ = ["FIGURES", "Batches", "bullets", "run_setup", "show", "write_card",
           "write_learning_curve"]

FIGURES = (("held_out_accuracy", "accuracy"), ("held_out_auc", "AUC"),
           ("held_out_top3", "top-3 all inliers"))
"""The held-out figures plotted and tabled, each with its label."""


class Batches:
    """A run's progress: its batches counted with the time left, and the lines it writes.

    A context manager: the count of the batches still to train (a resumed run counts only
    those) is drawn on a :class:`azgym.progress.Meter` while it is open, and ends when it
    closes.

    Args:
        model: The model trained (the count's label says it).
        total: The batches the run will train.
        enabled: Whether anything is shown (off: nothing is counted or written).
    """

    def __init__(self, model: str, total: int, enabled: bool) -> None:
        meter = Meter() if enabled else None
        self.say: Progress = meter if meter is not None else _silent
        """Write a line (between the count's redraws)."""
        self.count = counter(meter, f"training {model}", total, "batches")
        self.done = 0

    def step(self) -> None:
        """One more batch trained."""
        self.done += 1
        self.count(self.done)

    def __enter__(self) -> Batches:
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None,
                 trace: TracebackType | None) -> None:
        self.count.close()


def _silent(_text: str) -> None:
    """A run without progress writes nothing."""


def run_setup(info: dict[str, Any]) -> str:
    """How a run computed, for its card: ``torch 2.13.0+cpu, portable CPU kernels, 1 thread(s)``.

    A run on the processor's own kernels says that its weights repeat only on a like one
    (:mod:`azgym.torch_kernels`).
    """
    return (f"torch {info['torch_version']}, {describe_kernels(info['kernels'])}, "
            f"{info['hyperparameters']['threads']} thread(s)")


def write_learning_curve(history: list[dict[str, Any]], path: Path,
                         figures: tuple[tuple[str, str], ...] = FIGURES,
                         loss_label: str = "masked BCE (inliers weighted)") -> Path:
    """Loss per epoch (training, held-out) beside the held-out ``figures``; a PNG.

    ``figures`` are (key, label) pairs of each epoch's row, drawn on an axis fitted to their
    values (shares of 0.976-0.994 on [0, 1] would be one flat line).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    epochs = [row["epoch"] for row in history]
    figure, (losses, panel) = plt.subplots(1, 2, figsize=(10, 4), constrained_layout=True)
    losses.plot(epochs, [row["train_loss"] for row in history], marker="o", label="training")
    losses.plot(epochs, [_nan(row["held_out_loss"]) for row in history], marker="o",
                label="held-out")
    losses.set_xlabel("epoch")
    losses.set_ylabel(loss_label)
    losses.set_title("loss")
    losses.legend()
    for key, label in figures:
        panel.plot(epochs, [_nan(row[key]) for row in history], marker="o", label=label)
    panel.set_xlabel("epoch")
    panel.set_title("held-out layouts")
    panel.legend(loc="best")
    for axes in (losses, panel):
        axes.grid(True, alpha=0.3)
        axes.xaxis.set_major_locator(MaxNLocator(integer=True))
    image = io.BytesIO()
    figure.savefig(image, format="png", dpi=110)
    plt.close(figure)
    return write_file(path, image.getvalue())


def _nan(value: float | None) -> float:
    return float("nan") if value is None else value


def write_card(path: Path, info: dict[str, Any], weights: Path, figure: Path) -> Path:
    """The model card: data, seeds, hyperparameters, time, figures, files (markdown)."""
    data, settings = info["data"], info["hyperparameters"]
    digest = hashlib.sha256(weights.read_bytes()).hexdigest()
    lines = ["# ng-ransac inlier scorer: model card", "",
             "Scores each measurement of a frame with the logit of its being an inlier; the "
             "ng-ransac localizer tries triplets in that order.", "",
             "## Data", "",
             *bullets(data, ("train", "held_out", "distribution")),
             *[f"- {name}: {data[key]['frames']} frames, {data[key]['measurements']} "
               f"measurements, inlier share {show(data[key]['inlier_share'])}"
               for key, name in (("train", "training set"), ("held_out", "held-out set"))],
             "", "## Seeds and hyperparameters", "", *bullets(settings, ()), "",
             "## Training", "",
             f"- {len(info['history'])} epochs in {info['seconds']:.1f} s ({run_setup(info)})",
             "",
             "| epoch | train loss | held-out loss | "
             + " | ".join(label for _, label in FIGURES) + " |",
             "|---:|---:|---:|" + "---:|" * len(FIGURES),
             *[f"| {row['epoch']} | {show(row['train_loss'])} | {show(row['held_out_loss'])} "
               f"| " + " | ".join(show(row[key]) for key, _ in FIGURES) + " |"
               for row in info["history"]],
             "", f"![learning curve]({figure.name})", "",
             *card_section(data.get("distribution")),
             "## Files", "",
             f"- `{weights.name}` (SHA-256 `{digest}`): load with "
             "`azgym.localize.learned.inlier_network.InlierScorer.load`",
             f"- `{figure.name}`: the learning curve", ""]
    return write_file(path, "\n".join(lines))


def bullets(values: dict[str, Any], skip: tuple[str, ...]) -> list[str]:
    """One ``- key: value`` line per entry (lists of seeds shortened to first … last)."""
    lines = []
    for key, value in values.items():
        if key in skip:
            continue
        if isinstance(value, list) and len(value) > 6:
            value = f"{len(value)} seeds, {value[0]} … {value[-1]}"
        shown = json.dumps(value) if isinstance(value, list) else value
        lines.append(f"- {key.replace('_', ' ')}: {shown}")
    return lines


def show(value: float | None) -> str:
    """A figure with four decimals, or ``n/a``."""
    return "n/a" if value is None else f"{value:.4f}"
