"""The pose regressor in torch, for training: the served network, batched.

The network is :mod:`azgym.localize.learned.pose_network`'s. Frames come padded to the longest
one, so every pooling runs over a frame's real tokens only, as
:class:`~azgym.learn.torch_net.TorchInlierScorer` does it: padding is set to 0 before the
first layer and after each (where it cannot win a max over relu outputs), means divide by the
number of real tokens, and the trust softmax gives padding no weight. :func:`export` writes
weights that give the numpy forward the same outputs (``tests/learn/test_regression.py``).

Only training imports this module (and torch).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from azgym.localize.learned.pose_network import ARCHITECTURE, LOG_VARIANCE_RANGE, OUTPUTS
from azgym.localize.learned.weights import save_weights

__all__ = ["TorchPoseRegressor", "export"]


class TorchPoseRegressor(nn.Module):
    """Tokens to trust logits and (u, v, log σ_u², log σ_v²) (the module docstring's network).

    Args:
        inputs: Token columns (:data:`azgym.localize.learned.pose_network.N_TOKENS`).
        hidden: Width H of every hidden layer.
    """

    def __init__(self, inputs: int, hidden: int) -> None:
        super().__init__()
        self.inputs = inputs
        self.hidden = hidden
        self.embed = nn.Linear(inputs, hidden)
        self.combine = nn.Linear(3 * hidden, hidden)
        self.trust = nn.Linear(hidden, 1)
        self.head1 = nn.Linear(3 * hidden, hidden)
        self.head2 = nn.Linear(hidden, hidden)
        self.out = nn.Linear(hidden, OUTPUTS)

    def forward(self, tokens: torch.Tensor, mask: torch.Tensor
                ) -> tuple[torch.Tensor, torch.Tensor]:
        """(N, M, T) tokens and (N, M) mask to (N, M) trust logits and (N, 4) heads."""
        real = mask.unsqueeze(-1)
        tokens = torch.where(real, tokens, 0.0)  # a NaN of padding must not reach a sum
        h1 = torch.where(real, torch.relu(self.embed(tokens)), 0.0)
        count = real.sum(dim=1).clamp(min=1).to(tokens.dtype)
        pooled = torch.cat([h1.amax(dim=1), h1.sum(dim=1) / count], dim=-1)
        context = pooled.unsqueeze(1).expand(-1, h1.shape[1], -1)
        h2 = torch.relu(self.combine(torch.cat([h1, context], dim=-1)))
        h2 = torch.where(real, h2, 0.0)
        trust = self.trust(h2).squeeze(-1)
        share = torch.softmax(trust.masked_fill(~mask, -torch.inf), dim=1)
        share = torch.nan_to_num(share)  # a frame without tokens pools to 0
        frame = torch.cat([h2.amax(dim=1), h2.sum(dim=1) / count,
                           (share.unsqueeze(-1) * h2).sum(dim=1)], dim=-1)
        head = self.out(torch.relu(self.head2(torch.relu(self.head1(frame)))))
        low, high = LOG_VARIANCE_RANGE
        head = torch.cat([head[:, :2], head[:, 2:].clamp(low, high)], dim=-1)
        return trust, head

    def architecture(self) -> dict[str, Any]:
        """The manifest's ``architecture``: what ``weights.array_shapes`` reads."""
        return {"kind": ARCHITECTURE, "inputs": self.inputs, "hidden": self.hidden}

    def arrays(self) -> dict[str, np.ndarray]:
        """The weights as the model file names and shapes them (torch's Linear is x Wᵀ + b)."""
        def numpy(tensor: torch.Tensor) -> np.ndarray:
            return tensor.detach().cpu().numpy().astype(np.float64)

        return {"W1": numpy(self.embed.weight.T), "b1": numpy(self.embed.bias),
                "W2": numpy(self.combine.weight.T), "b2": numpy(self.combine.bias),
                "w3": numpy(self.trust.weight[0]), "b3": numpy(self.trust.bias),
                "W4": numpy(self.head1.weight.T), "b4": numpy(self.head1.bias),
                "W5": numpy(self.head2.weight.T), "b5": numpy(self.head2.bias),
                "W6": numpy(self.out.weight.T), "b6": numpy(self.out.bias)}


def export(model: TorchPoseRegressor, path: Path | str, training_info: dict[str, Any], *,
           feature_layout: str, name: str = "learned") -> Path:
    """Write the model's weight file (:func:`azgym.localize.learned.weights.save_weights`)."""
    manifest = {"architecture": model.architecture(), "feature_layout": feature_layout,
                "training": training_info}
    return save_weights(path, name, model.arrays(), manifest)
