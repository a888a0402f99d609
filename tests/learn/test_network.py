"""The inlier scorer's compiled forward: the formula of the network, for any number of
measurements (0 to 64), the same logits as the torch network it was trained as, and no torch
needed to serve it."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import numpy as np
import pytest

from azgym.errors import InvalidInputError, ModelFileError
from azgym.localize.learned.inlier_network import InlierScorer, inlier_logits, pack
from azgym.localize.learned.weights import array_shapes, save_weights

LAYOUT = "test-features-1"


def random_weights(inputs: int, hidden: int, seed: int = 0) -> tuple[dict, dict]:
    architecture = {"kind": "deepsets-context-1", "inputs": inputs, "hidden": hidden}
    rng = np.random.default_rng(seed)
    arrays = {name: rng.normal(scale=0.7, size=shape)
              for name, shape in array_shapes(architecture).items()}
    return arrays, {"architecture": architecture, "feature_layout": LAYOUT, "training": {}}


def reference_logits(x: np.ndarray, a: dict) -> np.ndarray:
    """The network's formula in plain numpy (the module docstring's four lines)."""
    h1 = np.maximum(x @ a["W1"] + a["b1"], 0.0)
    pooled = (np.concatenate([h1.max(axis=0), h1.mean(axis=0)]) if len(x)
              else np.zeros(2 * h1.shape[1]))
    context = np.broadcast_to(pooled, (len(x), pooled.size))
    h2 = np.maximum(np.concatenate([h1, context], axis=1) @ a["W2"] + a["b2"], 0.0)
    return h2 @ a["w3"] + a["b3"][0]


@pytest.mark.parametrize("hidden", [1, 16, 32])
@pytest.mark.parametrize("count", [0, 1, 2, 12, 64])
def test_the_forward_computes_the_network_for_any_number_of_measurements(count, hidden):
    arrays, manifest = random_weights(7, hidden, seed=count)
    x = np.random.default_rng(count).uniform(-1, 2, size=(count, 7))
    logits = InlierScorer(arrays, manifest).logits(x)
    assert logits.shape == (count,)
    np.testing.assert_allclose(logits, reference_logits(x, arrays), rtol=1e-12, atol=1e-12)


def test_permuting_the_measurements_permutes_the_logits():
    arrays, manifest = random_weights(6, 16)
    scorer = InlierScorer(arrays, manifest)
    x = np.random.default_rng(1).uniform(size=(12, 6))
    order = np.random.default_rng(2).permutation(12)
    np.testing.assert_allclose(scorer.logits(x[order]), scorer.logits(x)[order], rtol=1e-12)
    # ... and a measurement's logit depends on the others (the context round is there)
    assert not np.allclose(scorer.logits(x[:3]), scorer.logits(x)[:3])


def test_float32_and_strided_features_give_the_float64_result():
    arrays, manifest = random_weights(4, 16)
    scorer = InlierScorer(arrays, manifest)
    x = np.random.default_rng(3).uniform(size=(10, 8))
    strided = x[:, ::2]
    np.testing.assert_array_equal(scorer.logits(strided), scorer.logits(strided.copy()))
    np.testing.assert_array_equal(scorer.logits(strided.astype(np.float32)),
                                  scorer.logits(strided.astype(np.float32).astype(np.float64)))


@pytest.mark.parametrize(("features", "message"), [
    (np.zeros((3, 5)), r"features must have shape \(K, 4\), got \(3, 5\)"),
    (np.zeros(4), r"features must have shape \(K, 4\), got \(4,\)"),
    (np.zeros((1, 3, 4)), r"features must have shape \(K, 4\), got \(1, 3, 4\)"),
])
def test_features_of_another_shape_are_refused(features, message):
    scorer = InlierScorer(*random_weights(4, 16))
    with pytest.raises(InvalidInputError, match=message):
        scorer.logits(features)


def test_another_architecture_is_refused_before_any_use():
    arrays, manifest = random_weights(4, 16)
    manifest["architecture"] = {**manifest["architecture"], "kind": "set-transformer"}
    with pytest.raises(ModelFileError, match="kind 'set-transformer': the inlier scorer computes"):
        InlierScorer(arrays, manifest)
    arrays, manifest = random_weights(4, 16)
    arrays["W2"] = arrays["W2"][:32]
    with pytest.raises(ModelFileError, match=r"array 'W2' has shape \(32, 16\), the arch"):
        InlierScorer(arrays, manifest)


def test_the_weights_cannot_be_changed_once_served():
    scorer = InlierScorer(*random_weights(4, 16))
    with pytest.raises(ValueError, match="read-only"):
        scorer.params[0] = 1.0


def test_the_kernel_takes_the_packed_weights_directly():
    arrays, manifest = random_weights(5, 8)
    x = np.random.default_rng(4).uniform(size=(9, 5))
    np.testing.assert_array_equal(inlier_logits(x, pack(arrays), 8),
                                  InlierScorer(arrays, manifest).logits(x))


def test_serving_a_model_file_imports_no_torch(tmp_path):
    path = tmp_path / "model.npz"
    arrays, manifest = random_weights(4, 16)
    save_weights(path, "ng-ransac", arrays, manifest)
    code = textwrap.dedent(f"""
        import sys
        import numpy as np
        import azgym
        from azgym.localize.learned.inlier_network import InlierScorer
        scorer = InlierScorer.load({str(path)!r}, feature_layout={LAYOUT!r})
        scorer.logits(np.zeros((5, 4)))
        print(sorted(m for m in ("torch", "tqdm", "matplotlib") if m in sys.modules))
    """)
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True).stdout.strip()
    assert loaded == "[]"


def test_the_torch_network_and_the_exported_forward_agree(tmp_path):
    torch = pytest.importorskip(
        "torch", reason="the torch network needs pip install torch==2.13.0 (extra 'train')")
    from azgym.learn.torch_net import TorchInlierScorer, export

    torch.manual_seed(0)
    rng = np.random.default_rng(5)
    for inputs, hidden in [(6, 16), (9, 32)]:
        model = TorchInlierScorer(inputs, hidden)
        with torch.no_grad():  # weights wider than the default initialisation, some negative
            for parameter in model.parameters():
                parameter.normal_(0.0, 0.5)
        path = export(model, tmp_path / f"m{hidden}.npz", {"seed": 0}, feature_layout=LAYOUT)
        scorer = InlierScorer.load(path, feature_layout=LAYOUT)
        features = rng.uniform(-1, 2, size=(8, 24, inputs)).astype(np.float32)
        mask = rng.uniform(size=(8, 24)) < 0.6
        mask[0], mask[1] = False, True  # a frame with no measurement, one with no padding
        mask[2] = np.arange(24) == 5  # a single measurement, amid padding
        features[~mask] = 1e3  # padding must not leak into the real measurements' logits
        features[3][~mask[3]] = np.nan
        with torch.no_grad():
            batched = model(torch.from_numpy(features), torch.from_numpy(mask)).numpy()
        for frame in range(8):
            served = scorer.logits(features[frame][mask[frame]])
            np.testing.assert_allclose(served, batched[frame][mask[frame]],
                                       rtol=1e-5, atol=1e-5)
