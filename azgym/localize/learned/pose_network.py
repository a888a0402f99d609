"""The pose regressor's forward pass in numpy/numba: a frame's measurement tokens to its position.

The ``learned`` localizer (:mod:`azgym.localize.learned.pose_regression`) regresses the camera's
position directly from the set of a frame's usable measurements. Each measurement is one token
(:func:`frame_tokens`)::

    [cos α, sin α, (b_x − c_x) / s, (b_y − c_y) / s, features…]

α the measured azimuth in the camera frame, b the beacon's mapped position, c the centroid of
the frame's measured beacons and s their RMS distance to it, and the measurement features of
:mod:`azgym.localize.learned.features` (quality ranks, duplicates, consensus residual and
support: what tells a token to trust from one to ignore). Centring and scaling per frame let one
network serve a 6 m room and a 60 m warehouse alike; the position is predicted in that frame and
mapped back (x = c + s u). The beacon's height is left out: an azimuth is a horizontal direction
that the height does not change, so the position follows from the horizontal geometry alone (a
height token was not tried).
Rotation is not canonicalised (a frame's world heading is unknown): training rotates every
frame's world at random, so the network learns to compose camera-frame azimuths with world
positions whatever the map's orientation.

The network is a DeepSets model (Zaheer et al. 2017) with one context round, as the inlier
scorer's (:mod:`azgym.localize.learned.inlier_network`, whose compiled helpers it reuses), and a
pooled head::

    h1    = relu(x W1 + b1)                              (K, H)  each token alone
    h2    = relu([h1, max_k h1, mean_k h1] W2 + b2)      (K, H)  each token in its frame
    t     = h2 w3 + b3                                   (K,)    trust: the logit of an inlier
    p     = [max_k h2, mean_k h2, Σ_k softmax(t)_k h2]   (3H)    the frame, the trusted first
    z     = relu(relu(p W4 + b4) W5 + b5)                (H)
    out   = z W6 + b6                                    (4)     u, v, log σ_u², log σ_v²

so permuting the tokens permutes t and leaves ``out`` alone. The trust logits are trained on
the inlier labels beside the position (Gaussian NLL with the predicted log-variances), and the
localizer uses them for the heading and its refinement. The same network in torch
(:mod:`azgym.learn.torch_regression`) trains the weights; this module never imports torch.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from azgym.core import FloatArray
from azgym.errors import ModelFileError
from azgym.jit import jit
from azgym.localize.base import ROW_BX, ROW_BY, ROW_COS_AZ, ROW_SIN_AZ
from azgym.localize.learned.features import FEATURE_NAMES, N_FEATURES
from azgym.localize.learned.inlier_network import _context, _embed

__all__ = ["ARCHITECTURE", "LOG_VARIANCE_RANGE", "N_TOKENS", "ORDER", "OUTPUTS", "PoseRegressor",
           "frame_tokens", "pack", "regress"]

ARCHITECTURE = "deepsets-regression-1"
"""The ``kind`` of architecture this module computes
(:func:`azgym.localize.learned.weights.array_shapes`)."""
ORDER = ("W1", "b1", "W2", "b2", "w3", "b3", "W4", "b4", "W5", "b5", "W6", "b6")
"""The order the weight arrays are packed in, row-major, for the compiled forward."""
TOKEN_NAMES = ("cos_azimuth", "sin_azimuth", "beacon_u", "beacon_v", *FEATURE_NAMES)
"""One name per token column, in column order (module docstring)."""
N_TOKENS = len(TOKEN_NAMES)
N_GEOMETRY = N_TOKENS - N_FEATURES
"""Token columns before the measurement features: the azimuth and the normalised position."""
OUTPUTS = 4
"""The head's outputs: u, v (the normalised position) and their log-variances."""
MIN_SPREAD = 1e-3
"""Least RMS spread of a frame's beacons [m] the normalisation divides by."""
LOG_VARIANCE_RANGE = (-14.0, 4.0)
"""The log-variances (of u and v, in the frame's scale) are clipped to this range: a variance
below ~1e-6 s² claims more than any azimuth can give, one above e⁴ s² knows nothing."""


def pack(arrays: dict[str, np.ndarray]) -> FloatArray:
    """The weight arrays flattened into one float64 vector, in :data:`ORDER`."""
    return np.concatenate([np.asarray(arrays[name], dtype=np.float64).ravel() for name in ORDER])


@jit
def frame_tokens(floats, features, tokens):
    """Fill ``tokens`` (K, N_TOKENS) from a frame's ``Problem.floats`` and features.

    Returns the normalisation (c_x, c_y, s): the centroid of the measured beacons (a beacon
    measured twice counts twice) and their RMS distance to it, at least MIN_SPREAD.
    """
    k = floats.shape[1]
    cx, cy = 0.0, 0.0
    for u in range(k):
        cx += floats[ROW_BX, u]
        cy += floats[ROW_BY, u]
    cx /= max(k, 1)
    cy /= max(k, 1)
    spread = 0.0
    for u in range(k):
        spread += (floats[ROW_BX, u] - cx) ** 2 + (floats[ROW_BY, u] - cy) ** 2
    scale = max(math.sqrt(spread / max(k, 1)), MIN_SPREAD)
    for u in range(k):
        tokens[u, 0] = floats[ROW_COS_AZ, u]
        tokens[u, 1] = floats[ROW_SIN_AZ, u]
        tokens[u, 2] = (floats[ROW_BX, u] - cx) / scale
        tokens[u, 3] = (floats[ROW_BY, u] - cy) / scale
        for f in range(features.shape[1]):
            tokens[u, N_GEOMETRY + f] = features[u, f]
    return cx, cy, scale


@jit
def regress(tokens, params, hidden, trust, head):
    """The forward pass: (K, N_TOKENS) tokens to trust logits ``trust`` (K,) and ``head`` (4,).

    ``params`` from :func:`pack`; ``head`` holds u, v and their log-variances, clipped to
    LOG_VARIANCE_RANGE. K = 0 pools to zeros.
    """
    inputs, h = tokens.shape[1], hidden
    sizes = (inputs * h, h, 3 * h * h, h, h, 1, 3 * h * h, h, h * h, h, h * OUTPUTS, OUTPUTS)
    starts = np.zeros(len(sizes) + 1, dtype=np.int64)
    for i in range(len(sizes)):
        starts[i + 1] = starts[i] + sizes[i]
    w1 = params[starts[0]:starts[1]].reshape((inputs, h))
    w2 = params[starts[2]:starts[3]].reshape((3 * h, h))
    w3 = params[starts[4]:starts[5]]
    h1 = _embed(tokens, w1, params[starts[1]:starts[2]])
    context = _context(h1, w2, params[starts[3]:starts[4]])
    h2 = _tokens_in_context(h1, w2, context)
    count = tokens.shape[0]
    for k in range(count):
        total = params[starts[5]]
        for j in range(h):
            total += h2[k, j] * w3[j]
        trust[k] = total
    pooled = _trusted_pool(h2, trust)
    z1 = _dense_relu(pooled, params[starts[6]:starts[7]].reshape((3 * h, h)),
                     params[starts[7]:starts[8]])
    z2 = _dense_relu(z1, params[starts[8]:starts[9]].reshape((h, h)),
                     params[starts[9]:starts[10]])
    w6 = params[starts[10]:starts[11]].reshape((h, OUTPUTS))
    for o in range(OUTPUTS):
        total = params[starts[11] + o]
        for j in range(h):
            total += z2[j] * w6[j, o]
        head[o] = total
    for o in range(2, OUTPUTS):
        head[o] = min(max(head[o], LOG_VARIANCE_RANGE[0]), LOG_VARIANCE_RANGE[1])


@jit
def _tokens_in_context(h1, w2, context):
    """``h2 = relu(h1 W2[:H] + context)``; rows of W2 meeting a zero of h1 are skipped."""
    count, hidden = h1.shape
    h2 = np.empty((count, hidden))
    for k in range(count):
        row = h2[k]
        row[:] = context
        for i in range(hidden):
            v = h1[k, i]
            if v != 0.0:
                weights = w2[i]
                for j in range(hidden):
                    row[j] += v * weights[j]
        for j in range(hidden):
            row[j] = max(row[j], 0.0)
    return h2


@jit
def _trusted_pool(h2, trust):
    """``[max_k h2, mean_k h2, Σ_k softmax(trust)_k h2]`` (3H); zeros without tokens."""
    count, hidden = h2.shape
    pooled = np.zeros(3 * hidden)
    if count == 0:
        return pooled
    top = trust.max()
    total = 0.0
    for k in range(count):
        share = math.exp(trust[k] - top)
        total += share
        for j in range(hidden):
            pooled[j] = max(pooled[j], h2[k, j])
            pooled[hidden + j] += h2[k, j]
            pooled[2 * hidden + j] += share * h2[k, j]
    for j in range(hidden):
        pooled[hidden + j] /= count
        pooled[2 * hidden + j] /= total
    return pooled


@jit
def _dense_relu(x, weights, bias):
    """``relu(x W + b)`` for one vector."""
    out = bias.copy()
    for i in range(x.size):
        v = x[i]
        if v != 0.0:
            for j in range(out.size):
                out[j] += v * weights[i, j]
    for j in range(out.size):
        out[j] = max(out[j], 0.0)
    return out


class PoseRegressor:
    """The regression network of a model file, ready to serve.

    Args:
        arrays: The weight arrays, as :func:`azgym.localize.learned.weights.load_weights`
            returns them.
        manifest: The model file's manifest (its ``architecture`` sizes the network).
    """

    def __init__(self, arrays: dict[str, np.ndarray], manifest: dict[str, Any]) -> None:
        from azgym.localize.learned.weights import served

        architecture, self.params = served(arrays, manifest, ARCHITECTURE, "pose regressor",
                                           ORDER)
        if architecture.get("inputs") != N_TOKENS:
            raise ModelFileError(f"architecture inputs {architecture.get('inputs')!r}: the "
                                 f"pose regressor's tokens have {N_TOKENS} columns")
        self.hidden: int = architecture["hidden"]
        self.manifest = manifest

    @classmethod
    def load(cls, path: Path | str, *, model: str = "learned",
             feature_layout: str | None = None) -> PoseRegressor:
        """The regressor of a model file, read and checked by ``weights.load_weights``."""
        from azgym.localize.learned.weights import load_weights

        return cls(*load_weights(path, model, feature_layout=feature_layout))

    def predict(self, floats: FloatArray, features: FloatArray
                ) -> tuple[FloatArray, FloatArray, tuple[float, float, float]]:
        """A frame's trust logits (K,), head (4,) and normalisation (c_x, c_y, s).

        ``floats`` is the frame's ``Problem.floats``, ``features`` its (K, N_FEATURES).
        """
        count = floats.shape[1]
        tokens = np.empty((count, N_TOKENS))
        norm = frame_tokens(np.ascontiguousarray(floats, dtype=np.float64),
                            np.ascontiguousarray(features, dtype=np.float64), tokens)
        trust, head = np.empty(count), np.empty(OUTPUTS)
        regress(tokens, self.params, self.hidden, trust, head)
        return trust, head, norm
