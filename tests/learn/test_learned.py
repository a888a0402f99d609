"""The pose regressor: its tokens, its compiled forward (the formula, permutation invariance, the
torch network's outputs), its weight files, and its training (deterministic, resumable files)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from azgym.errors import ModelFileError
from azgym.localize.base import FLOAT_ROWS, ROW_BX, ROW_BY, ROW_COS_AZ, ROW_SIN_AZ
from azgym.localize.learned.features import N_FEATURES
from azgym.localize.learned.pose_network import (
    LOG_VARIANCE_RANGE,
    N_TOKENS,
    OUTPUTS,
    PoseRegressor,
    frame_tokens,
    pack,
    regress,
)
from azgym.localize.learned.weights import array_shapes, load_weights, save_weights

LAYOUT = "test-features-1"


def random_weights(hidden: int, seed: int = 0, inputs: int = N_TOKENS) -> tuple[dict, dict]:
    architecture = {"kind": "deepsets-regression-1", "inputs": inputs, "hidden": hidden}
    rng = np.random.default_rng(seed)
    arrays = {name: rng.normal(scale=0.5, size=shape)
              for name, shape in array_shapes(architecture).items()}
    return arrays, {"architecture": architecture, "feature_layout": LAYOUT, "training": {}}


def reference(x: np.ndarray, a: dict) -> tuple[np.ndarray, np.ndarray]:
    """The module docstring's network in plain numpy."""
    hidden = a["b1"].size
    h1 = np.maximum(x @ a["W1"] + a["b1"], 0.0)
    pooled = np.concatenate([h1.max(axis=0), h1.mean(axis=0)]) if len(x) else np.zeros(
        2 * hidden)
    h2 = np.maximum(np.concatenate([h1, np.broadcast_to(pooled, (len(x), 2 * hidden))], axis=1)
                    @ a["W2"] + a["b2"], 0.0)
    trust = h2 @ a["w3"] + a["b3"][0]
    if len(x):
        share = np.exp(trust - trust.max())
        share /= share.sum()
        frame = np.concatenate([h2.max(axis=0), h2.mean(axis=0), share @ h2])
    else:
        frame = np.zeros(3 * hidden)
    z = np.maximum(np.maximum(frame @ a["W4"] + a["b4"], 0.0) @ a["W5"] + a["b5"], 0.0)
    head = z @ a["W6"] + a["b6"]
    head[2:] = np.clip(head[2:], *LOG_VARIANCE_RANGE)
    return trust, head


def forward(x: np.ndarray, arrays: dict, hidden: int) -> tuple[np.ndarray, np.ndarray]:
    trust, head = np.empty(len(x)), np.empty(OUTPUTS)
    regress(np.ascontiguousarray(x, dtype=np.float64), pack(arrays), hidden, trust, head)
    return trust, head


@pytest.mark.parametrize("hidden", [1, 8, 32])
@pytest.mark.parametrize("count", [0, 1, 3, 12, 40])
def test_the_forward_computes_the_network(count, hidden):
    arrays, _ = random_weights(hidden, seed=count)
    x = np.random.default_rng(count).uniform(-1, 1.5, size=(count, N_TOKENS))
    trust, head = forward(x, arrays, hidden)
    want_trust, want_head = reference(x, arrays)
    np.testing.assert_allclose(trust, want_trust, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(head, want_head, rtol=1e-12, atol=1e-12)


def test_permuting_the_tokens_permutes_the_trust_and_keeps_the_position():
    arrays, _ = random_weights(16)
    x = np.random.default_rng(1).uniform(size=(12, N_TOKENS))
    order = np.random.default_rng(2).permutation(12)
    trust, head = forward(x, arrays, 16)
    trust_p, head_p = forward(x[order], arrays, 16)
    np.testing.assert_allclose(trust_p, trust[order], rtol=1e-12)
    np.testing.assert_allclose(head_p, head, rtol=1e-12)
    assert not np.allclose(forward(x[:3], arrays, 16)[1], head)  # the others matter


def floats_of(xy: np.ndarray, azimuth: np.ndarray) -> np.ndarray:
    floats = np.zeros((FLOAT_ROWS, len(xy)))
    floats[ROW_BX], floats[ROW_BY] = xy.T
    floats[ROW_COS_AZ], floats[ROW_SIN_AZ] = np.cos(azimuth), np.sin(azimuth)
    return floats


def test_tokens_are_centred_and_scaled_per_frame_so_the_map_size_and_place_do_not_matter():
    rng = np.random.default_rng(3)
    xy, azimuth = rng.uniform(0, 10, size=(7, 2)), rng.uniform(-3, 3, size=7)
    features = rng.uniform(size=(7, N_FEATURES))
    tokens, moved = np.empty((7, N_TOKENS)), np.empty((7, N_TOKENS))
    cx, cy, s = frame_tokens(floats_of(xy, azimuth), features, tokens)
    assert np.allclose(tokens[:, 2:4].mean(axis=0), 0.0)
    assert math.isclose(np.sqrt((tokens[:, 2:4] ** 2).sum(axis=1).mean()), 1.0)
    np.testing.assert_allclose(tokens[:, 4:], features)
    norm = frame_tokens(floats_of(3.0 * xy + [100.0, -40.0], azimuth), features, moved)
    np.testing.assert_allclose(moved, tokens, atol=1e-12)
    np.testing.assert_allclose(norm, (3 * cx + 100, 3 * cy - 40, 3 * s))


def test_a_regression_file_round_trips_and_its_errors_are_named(tmp_path):
    arrays, manifest = random_weights(8)
    path = save_weights(tmp_path / "learned.npz", "learned", arrays, manifest)
    regressor = PoseRegressor.load(path, feature_layout=LAYOUT)
    assert regressor.hidden == 8 and regressor.params.size == sum(a.size for a in arrays.values())
    with pytest.raises(ModelFileError, match="holds a 'learned' model, not 'ng-ransac'"):
        load_weights(path, "ng-ransac", feature_layout=LAYOUT)
    short = {**arrays, "W6": arrays["W6"][:, :3]}
    with pytest.raises(ModelFileError, match=r"array 'W6' has shape \(8, 3\), but the "
                                             r"architecture .* needs \(8, 4\)"):
        save_weights(tmp_path / "bad.npz", "learned", short, manifest)
    missing = {k: v for k, v in arrays.items() if k != "b5"}
    with pytest.raises(ModelFileError, match="missing arrays: b5"):
        save_weights(tmp_path / "bad.npz", "learned", missing, manifest)
    with pytest.raises(ModelFileError, match="computes 'deepsets-regression-1'"):
        PoseRegressor(*random_weights(8)[:1], {"architecture": {
            "kind": "deepsets-context-1", "inputs": N_TOKENS, "hidden": 8}})
    narrow, narrow_manifest = random_weights(8, inputs=N_TOKENS - 1)
    with pytest.raises(ModelFileError, match=f"tokens have {N_TOKENS} columns"):
        PoseRegressor(narrow, narrow_manifest)


def test_the_torch_network_gives_the_compiled_forward_its_outputs():
    torch = pytest.importorskip("torch", reason="training needs pip install torch==2.13.0")
    from azgym.learn.torch_regression import TorchPoseRegressor

    torch.manual_seed(0)
    model = TorchPoseRegressor(N_TOKENS, 16).double()
    sizes = [3, 9, 1, 14]
    tokens = torch.rand(len(sizes), 14, N_TOKENS, dtype=torch.float64)
    mask = torch.arange(14)[None, :] < torch.tensor(sizes)[:, None]
    tokens[~mask] = float("nan")  # padding must never matter
    with torch.no_grad():
        trust, head = model(tokens, mask)
    arrays = model.arrays()
    for n, size in enumerate(sizes):
        want_trust, want_head = forward(tokens[n, :size].numpy(), arrays, 16)
        np.testing.assert_allclose(trust[n, :size].numpy(), want_trust, rtol=1e-10, atol=1e-10)
        np.testing.assert_allclose(head[n].numpy(), want_head, rtol=1e-10, atol=1e-10)


@pytest.mark.slow
def test_training_is_deterministic_and_leaves_weights_curve_and_card(tmp_path):
    pytest.importorskip("torch", reason="training needs pip install torch==2.13.0")
    from azgym.learn.train_regression import train_learned

    runs = [train_learned(tmp_path / name, layouts=2, frames=10, epochs=2, hidden=8,
                          progress=False) for name in ("a", "b")]
    first, second = (load_weights(run.weights, "learned")[0] for run in runs)
    assert all(np.array_equal(first[key], second[key]) for key in first)
    assert {p.name for p in (tmp_path / "a").iterdir()} == {
        "learned.npz", "learned-model-card.md", "learned-learning-curve.png", "checkpoint.pt"}
    card = runs[0].card.read_text(encoding="utf-8")
    assert "## Generalization" in card and "refined, held-out layouts" in card
    assert runs[0].history[-1]["held_out_p75_m"] > 0.0
