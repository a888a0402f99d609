"""The inlier scorer in torch, for training: the served network, batched.

The network is :mod:`azgym.localize.learned.inlier_network`'s. Frames come padded to the
longest one (:class:`azgym.learn.dataset.FrameBatch`), so the context pools over each frame's
real measurements only: padding is set to 0 (whatever it held, NaN included) before the first
layer and after it, where it cannot win the max (h1 ≥ 0; a frame without measurements pools to
0, as the numpy forward does), and the mean divides by the number of real ones. With that,
a frame's logits do not depend on how much padding it got, and :func:`export` writes weights
that give the numpy forward the same logits (``tests/learn/test_network.py`` checks it).

Only training imports this module (and torch).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from azgym.localize.learned.inlier_network import ARCHITECTURE
from azgym.localize.learned.weights import save_weights

__all__ = ["TorchInlierScorer", "export"]


class TorchInlierScorer(nn.Module):
    """``relu([h1, max h1, mean h1] W2 + b2) w3 + b3`` with ``h1 = relu(x W1 + b1)``.

    Args:
        inputs: Features per measurement (F).
        hidden: Width of both hidden layers (H).
    """

    def __init__(self, inputs: int, hidden: int) -> None:
        super().__init__()
        self.inputs = inputs
        self.hidden = hidden
        self.embed = nn.Linear(inputs, hidden)
        self.combine = nn.Linear(3 * hidden, hidden)
        self.head = nn.Linear(hidden, 1)

    def forward(self, features: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        """(N, M, F) features and (N, M) real-measurement mask to (N, M) logits.

        Padded positions get logits too; the loss leaves them out.
        """
        real = mask.unsqueeze(-1)
        features = torch.where(real, features, 0.0)  # a NaN of padding must not reach a sum
        h1 = torch.where(real, torch.relu(self.embed(features)), 0.0)
        count = real.sum(dim=1).clamp(min=1).to(features.dtype)
        pooled = torch.cat([h1.amax(dim=1), h1.sum(dim=1) / count], dim=-1)
        context = pooled.unsqueeze(1).expand(-1, h1.shape[1], -1)
        h2 = torch.relu(self.combine(torch.cat([h1, context], dim=-1)))
        return self.head(h2).squeeze(-1)

    def architecture(self) -> dict[str, Any]:
        """The manifest's ``architecture``: what ``weights.array_shapes`` reads."""
        return {"kind": ARCHITECTURE, "inputs": self.inputs, "hidden": self.hidden}

    def arrays(self) -> dict[str, np.ndarray]:
        """The weights as the model file names and shapes them (torch's Linear is x Wᵀ + b)."""
        def numpy(tensor: torch.Tensor) -> np.ndarray:
            return tensor.detach().cpu().numpy().astype(np.float64)

        return {"W1": numpy(self.embed.weight.T), "b1": numpy(self.embed.bias),
                "W2": numpy(self.combine.weight.T), "b2": numpy(self.combine.bias),
                "w3": numpy(self.head.weight[0]), "b3": numpy(self.head.bias)}


def export(model: TorchInlierScorer, path: Path | str, training_info: dict[str, Any], *,
           feature_layout: str | None = None, name: str = "ng-ransac") -> Path:
    """Write the model's weight file (:func:`azgym.localize.learned.weights.save_weights`).

    Args:
        model: The trained network.
        path: The ``.npz`` to write.
        training_info: The manifest's ``training`` (data seeds, hyperparameters, time,
            figures): JSON values.
        feature_layout: The features it was trained on (default: the running azgym's
            :data:`azgym.localize.learned.features.FEATURE_LAYOUT`).
        name: The model's name.
    """
    if feature_layout is None:
        from azgym.localize.learned.features import FEATURE_LAYOUT as feature_layout
    manifest = {"architecture": model.architecture(), "feature_layout": feature_layout,
                "training": training_info}
    return save_weights(path, name, model.arrays(), manifest)
