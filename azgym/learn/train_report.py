"""What a training run shows and leaves behind: its progress, learning curve and model card.

The progress is a tqdm bar when tqdm is installed (plain lines, one per epoch, otherwise); the
learning curve is a PNG of the training and held-out loss and the held-out figures per epoch;
the model card is a markdown page of everything needed to judge and redo the run: the data
and its seeds, the hyperparameters, the time it took, the figures and the weight file's
SHA-256.
"""

from __future__ import annotations

import hashlib
import io
import json
from pathlib import Path
from typing import Any

from azgym.files import write_file
from azgym.learn.distribution import card_section

__all__ = ["FIGURES", "bullets", "progress_bar", "show", "write_card", "write_learning_curve"]

FIGURES = (("held_out_accuracy", "accuracy"), ("held_out_auc", "AUC"),
           ("held_out_top3", "top-3 all inliers"))
"""The held-out figures plotted and tabled, each with its label."""


class _Lines:
    """The progress of a run without tqdm: only the lines it writes (one per epoch)."""

    def __init__(self, enabled: bool) -> None:
        self.enabled = enabled

    def update(self, _steps: int) -> None:
        """Nothing to draw between epochs."""

    def set_postfix(self, **_values: Any) -> None:
        """Nothing to draw between epochs."""

    def write(self, text: str) -> None:
        """Print a finished line."""
        if self.enabled:
            print(text, flush=True)

    def close(self) -> None:
        """Nothing to close."""


def progress_bar(total: int, initial: int, enabled: bool, desc: str = "ng-ransac") -> Any:
    """A tqdm bar of ``total`` steps starting at ``initial``, or plain lines without tqdm."""
    try:
        from tqdm import tqdm
    except ImportError:
        return _Lines(enabled)
    if not enabled:
        return _Lines(False)
    # disable=None: no bar where it cannot redraw in place (a log file); the lines still show
    return tqdm(total=total, initial=initial, unit="batch", desc=desc, leave=False,
                disable=None, mininterval=0.5)


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
             f"- {len(info['history'])} epochs in {info['seconds']:.1f} s "
             f"(torch {info['torch_version']}, {settings['threads']} thread(s))", "",
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
