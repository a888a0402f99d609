"""The inlier scorer's forward pass in numpy/numba: a measurement's features to its inlier logit.

The network is a DeepSets model with one round of context (Zaheer et al. 2017), small enough
to cost a few microseconds on a frame's dozen measurements::

    h1    = relu(x W1 + b1)                         (K, H)  each measurement alone
    g     = [max_k h1, mean_k h1]                   (2H)    the frame as a whole
    h2    = relu([h1, g] W2 + b2)                   (K, H)  each measurement in its frame
    logit = h2 w3 + b3                              (K,)

so a measurement's score depends on the others only through g, and permuting the
measurements permutes the logits. The same network in torch (:mod:`azgym.learn.torch_net`)
trains the weights; this module only serves them and never imports torch.

The compiled forward splits ``[h1, g] W2`` into ``h1 W2[:H] + g W2[H:]``: the second term is
the same for every measurement and is computed once, and rows of ``W2[:H]`` meeting a zero of
``h1`` (the relu's) are skipped, which changes no bit of the result.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from azgym.core import FloatArray
from azgym.errors import InvalidInputError
from azgym.jit import jit

__all__ = ["ARCHITECTURE", "InlierScorer", "ORDER", "inlier_logits", "pack"]

ARCHITECTURE = "deepsets-context-1"
"""The ``kind`` of architecture this module computes
(:func:`azgym.localize.learned.weights.array_shapes`)."""
ORDER = ("W1", "b1", "W2", "b2", "w3", "b3")
"""The order the weight arrays are packed in, row-major, for the compiled forward."""


def pack(arrays: dict[str, np.ndarray]) -> FloatArray:
    """The weight arrays flattened into one float64 vector, in :data:`ORDER`."""
    return np.concatenate([np.asarray(arrays[name], dtype=np.float64).ravel() for name in ORDER])


@jit
def inlier_logits(features: FloatArray, params: FloatArray, hidden: int) -> FloatArray:
    """The forward pass: (K, F) features to (K,) logits; ``params`` from :func:`pack`.

    K = 0 gives an empty result. The caller checks shapes (:meth:`InlierScorer.logits`); a
    compiled caller may call this directly.
    """
    inputs = features.shape[1]
    at = inputs * hidden
    w1 = params[:at].reshape((inputs, hidden))
    b1 = params[at:at + hidden]
    at += hidden
    w2 = params[at:at + 3 * hidden * hidden].reshape((3 * hidden, hidden))
    at += 3 * hidden * hidden
    b2 = params[at:at + hidden]
    w3 = params[at + hidden:at + 2 * hidden]
    h1 = _embed(features, w1, b1)
    context = _context(h1, w2, b2)
    logits = np.empty(features.shape[0])
    h2 = np.empty(hidden)
    for k in range(features.shape[0]):
        h2[:] = context
        for i in range(hidden):
            v = h1[k, i]
            if v != 0.0:  # a zero of the relu adds nothing: skip its row of W2
                row = w2[i]
                for j in range(hidden):
                    h2[j] += v * row[j]
        total = params[at + 2 * hidden]
        for j in range(hidden):
            total += max(h2[j], 0.0) * w3[j]
        logits[k] = total
    return logits


@jit
def _embed(features: FloatArray, w1: FloatArray, b1: FloatArray) -> FloatArray:
    """``h1 = relu(x W1 + b1)``, one row per measurement."""
    count, inputs = features.shape
    hidden = b1.shape[0]
    h1 = np.empty((count, hidden))
    for k in range(count):
        row = h1[k]
        row[:] = b1
        for i in range(inputs):
            x = features[k, i]
            weights = w1[i]
            for j in range(hidden):
                row[j] += x * weights[j]
        for j in range(hidden):
            row[j] = max(row[j], 0.0)
    return h1


@jit
def _context(h1: FloatArray, w2: FloatArray, b2: FloatArray) -> FloatArray:
    """``b2 + [max_k h1, mean_k h1] W2[H:]``: the frame's share of every pre-activation of h2.

    The max starts at 0, which h1 (a relu's output) never goes below; with no measurement,
    both poolings are 0.
    """
    count, hidden = h1.shape
    pooled = np.zeros(2 * hidden)
    for k in range(count):
        for j in range(hidden):
            pooled[j] = max(pooled[j], h1[k, j])
            pooled[hidden + j] += h1[k, j]
    if count > 0:
        for j in range(hidden):
            pooled[hidden + j] /= count
    context = b2.copy()
    for i in range(2 * hidden):
        p = pooled[i]
        row = w2[hidden + i]
        for j in range(hidden):
            context[j] += p * row[j]
    return context


class InlierScorer:
    """Scores each measurement of a frame: the logit of its being an inlier.

    Args:
        arrays: The weight arrays, as :func:`azgym.localize.learned.weights.load_weights`
            returns them.
        manifest: The model file's manifest (its ``architecture`` sizes the network).
    """

    def __init__(self, arrays: dict[str, np.ndarray], manifest: dict[str, Any]) -> None:
        from azgym.localize.learned.weights import served

        architecture, self.params = served(arrays, manifest, ARCHITECTURE, "inlier scorer",
                                           ORDER)
        self.inputs: int = architecture["inputs"]
        self.hidden: int = architecture["hidden"]
        self.manifest = manifest

    @classmethod
    def load(cls, path: Path | str, *, model: str = "ng-ransac",
             feature_layout: str | None = None) -> InlierScorer:
        """The scorer of a model file, read and checked by ``weights.load_weights``."""
        from azgym.localize.learned.weights import load_weights

        return cls(*load_weights(path, model, feature_layout=feature_layout))

    def logits(self, features: FloatArray) -> FloatArray:
        """(K, F) features, one row per usable measurement, to (K,) inlier logits.

        Raises:
            InvalidInputError: ``features`` is not a (K, F) array of the model's F columns.
        """
        x = np.asarray(features)
        if x.ndim != 2 or x.shape[1] != self.inputs:
            raise InvalidInputError(f"features must have shape (K, {self.inputs}), "
                                    f"got {x.shape}")
        if x.dtype != np.float64 or not x.flags.c_contiguous:
            x = np.ascontiguousarray(x, dtype=np.float64)
        return inlier_logits(x, self.params, self.hidden)
