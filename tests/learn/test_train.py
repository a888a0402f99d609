"""Training the inlier scorer: on a small synthetic set the loss falls and the held-out figures
rise; a run leaves its weight file, learning curve and model card; an interrupted run resumes
to the very weights of an uninterrupted one; a checkpoint of another run is refused."""

from __future__ import annotations

import sys
from dataclasses import dataclass

import numpy as np
import pytest

pytest.importorskip("torch", reason="training needs pip install torch==2.13.0 (extra 'train')")

from azgym.errors import InvalidInputError  # noqa: E402
from azgym.learn import train as T  # noqa: E402
from azgym.localize.learned.inlier_network import InlierScorer  # noqa: E402
from azgym.localize.learned.weights import load_weights  # noqa: E402

LAYOUT = "test-features-1"
FEATURES = 6


@dataclass(frozen=True)
class Frames:
    """A stand-in for azgym.learn.dataset.FrameBatch: the fields training reads."""

    features: np.ndarray  # (N, M, F) float32
    mask: np.ndarray  # (N, M) bool
    inlier: np.ndarray  # (N, M) bool
    layout: np.ndarray  # (N,) int64


def synthetic(frames: int, seed: int, m_max: int = 10) -> Frames:
    """Frames of 3 to m_max measurements; a measurement is an inlier when x0 + x1 > 0.8, or
    when its x2 is the frame's largest (something only the context round can see)."""
    rng = np.random.default_rng(seed)
    mask = np.arange(m_max) < rng.integers(3, m_max + 1, size=(frames, 1))
    features = rng.uniform(size=(frames, m_max, FEATURES)).astype(np.float32)
    features[~mask] = np.nan  # padding: must never matter
    x2 = np.where(mask, features[..., 2], -1)
    largest = x2 == x2.max(axis=1, keepdims=True)
    inlier = ((features[..., 0] + features[..., 1] > 0.8) | largest) & mask
    return Frames(features, mask, inlier, np.full(frames, seed))


TRAIN, HELD_OUT = synthetic(400, 1), synthetic(100, 2)


def fit(out, epochs=3, seed=0, **config):
    return T.fit(TRAIN, HELD_OUT, out, T.TrainConfig(epochs=epochs, seed=seed, **config),
                 feature_layout=LAYOUT, data_info={"data_seed": 1}, progress=False)


def test_training_lowers_the_loss_and_leaves_weights_curve_and_card(tmp_path):
    result = fit(tmp_path, epochs=6, learning_rate=1e-2)
    history = result.history
    assert [row["epoch"] for row in history] == [1, 2, 3, 4, 5, 6]
    assert history[-1]["train_loss"] < 0.6 * history[0]["train_loss"]
    assert history[-1]["held_out_loss"] < history[0]["held_out_loss"]
    assert history[-1]["held_out_auc"] > 0.95
    assert history[-1]["held_out_accuracy"] > 0.85
    # the weight file serves the trained network, and says how it was made
    arrays, manifest = load_weights(result.weights, "ng-ransac", feature_layout=LAYOUT)
    assert manifest["architecture"] == {"kind": "deepsets-context-1", "inputs": FEATURES,
                                        "hidden": 16}
    training = manifest["training"]
    assert training["hyperparameters"]["seed"] == 0
    assert training["hyperparameters"]["pos_weight"] == pytest.approx(
        (~TRAIN.inlier[TRAIN.mask]).sum() / TRAIN.inlier[TRAIN.mask].sum())
    assert training["data"]["train"] == {"frames": 400, "measurements": int(TRAIN.mask.sum()),
                                         "inlier_share": pytest.approx(
                                             TRAIN.inlier[TRAIN.mask].mean())}
    assert training["data"]["data_seed"] == 1
    assert training["history"] == history
    scorer = InlierScorer(arrays, manifest)
    logits = scorer.logits(HELD_OUT.features[0][HELD_OUT.mask[0]])
    assert logits.shape == (int(HELD_OUT.mask[0].sum()),)
    assert result.figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    card = result.card.read_text()
    for text in ("## Data", "data seed: 1", "## Seeds and hyperparameters", "- seed: 0",
                 "learning rate: 0.01", "6 epochs in", "| 6 | ", "![learning curve]"
                 "(learning-curve.png)", "SHA-256"):
        assert text in card


def test_an_interrupted_run_resumes_to_the_weights_of_an_uninterrupted_one(tmp_path):
    whole = fit(tmp_path / "whole", epochs=3)
    fit(tmp_path / "parts", epochs=1)
    resumed = fit(tmp_path / "parts", epochs=3)
    ours, _ = load_weights(resumed.weights, "ng-ransac", feature_layout=LAYOUT)
    theirs, _ = load_weights(whole.weights, "ng-ransac", feature_layout=LAYOUT)
    for name in ours:
        np.testing.assert_array_equal(ours[name], theirs[name])
    assert resumed.history == whole.history
    other, _ = load_weights(fit(tmp_path / "seed1", epochs=1, seed=1).weights, "ng-ransac",
                            feature_layout=LAYOUT)
    assert not np.array_equal(other["W1"], ours["W1"])  # the seed matters


def test_a_checkpoint_of_another_run_or_of_more_epochs_is_refused(tmp_path):
    fit(tmp_path, epochs=2)
    with pytest.raises(InvalidInputError, match="a checkpoint of another run"):
        fit(tmp_path, epochs=2, seed=7)
    with pytest.raises(InvalidInputError, match="a checkpoint of another run"):
        fit(tmp_path, epochs=2, hidden=8)
    with pytest.raises(InvalidInputError, match="holds 2 epochs, more than the 1 asked for"):
        fit(tmp_path, epochs=1)
    (tmp_path / "checkpoint.pt").write_bytes(b"not a checkpoint")
    with pytest.raises(InvalidInputError,
                       match="cannot read the checkpoint .*; --overwrite starts over"):
        fit(tmp_path, epochs=2)


@pytest.mark.parametrize(("changes", "message"), [
    ({"epochs": 0}, "epochs must be an integer >= 1, got 0"),
    ({"epochs": 2.5}, "epochs must be an integer >= 1, got 2.5"),
    ({"seed": -1}, "seed must be an integer >= 0, got -1"),
    ({"hidden": True}, "hidden must be an integer >= 1, got True"),
    ({"learning_rate": float("nan")}, "learning_rate must be a finite number, got nan"),
    ({"pos_weight": 0.0}, "pos_weight must be > 0, got 0.0"),
    ({"threads": 0}, "threads must be an integer >= 1, got 0"),
])
def test_bad_hyperparameters_are_refused_by_name(changes, message):
    with pytest.raises(InvalidInputError, match=message):
        T.TrainConfig(**changes)


def test_frames_of_mismatched_shapes_are_refused(tmp_path):
    bad = Frames(TRAIN.features, TRAIN.mask[:, :5], TRAIN.inlier, TRAIN.layout)
    with pytest.raises(InvalidInputError, match=r"frames: features \(400, 10, 6\), mask "
                                                r"\(400, 5\)"):
        T.fit(bad, HELD_OUT, tmp_path, T.TrainConfig(epochs=1), feature_layout=LAYOUT,
              progress=False)


def test_auc_and_top3_count_what_they_say():
    assert T.auc(np.array([0.1, 0.2, 0.9, 0.8]), np.array([False, False, True, True])) == 1.0
    assert T.auc(np.array([0.9, 0.8, 0.1]), np.array([False, False, True])) == 0.0
    assert T.auc(np.zeros(4), np.array([True, False, True, False])) == 0.5
    assert T.auc(np.arange(3.0), np.ones(3, bool)) is None
    inlier = np.array([[1, 1, 1, 0], [1, 1, 1, 0], [1, 1, 0, 0]], bool)
    scores = np.array([[4, 3, 2, 1], [4, 3, 1, 2], [9, 9, 9, 9]], float)
    assert T._top3(scores, inlier) == 0.5  # the third frame has too few inliers to count


def test_progress_is_plain_lines_without_tqdm(tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "tqdm", None)
    T.fit(TRAIN, HELD_OUT, tmp_path, T.TrainConfig(epochs=2), feature_layout=LAYOUT)
    lines = capsys.readouterr().out.splitlines()
    assert [line.split(":")[0] for line in lines] == ["epoch 1", "epoch 2"]
    assert "held-out" in lines[0] and "AUC" in lines[0]


def test_train_ng_ransac_draws_the_frames_then_trains_and_calibrates(tmp_path, monkeypatch):
    from azgym.learn import dataset

    drawn = []
    real = dataset.make_frames

    def make_frames(layout_seeds, frames_per_layout, seed, progress=None):
        drawn.append((list(layout_seeds), frames_per_layout, seed))
        return real(layout_seeds, frames_per_layout, seed, progress=progress)

    monkeypatch.setattr(dataset, "make_frames", make_frames)
    result = T.train_ng_ransac(tmp_path, layouts=3, frames=4, epochs=1, seed=5,
                               progress=False)
    held_out = [int(x) for x in dataset.HELD_OUT_LAYOUTS]
    assert drawn == [([0, 1, 2], 4, 5), (held_out, 4, 5)]
    _, manifest = load_weights(result.weights, "ng-ransac")
    assert manifest["training"]["data"]["train_layouts"] == [0, 1, 2]
    assert manifest["training"]["data"]["held_out"]["frames"] == 4 * len(held_out)
    assert manifest["calibration"]["frames"] == 4 * len(held_out)
    drawn.clear()
    with pytest.raises(InvalidInputError, match="layouts must be at most 100000"):
        T.train_ng_ransac(tmp_path / "x", layouts=100_001, frames=20, epochs=1)
    with pytest.raises(InvalidInputError, match=rf"layouts: \[{held_out[0]}\] are held-out"):
        T.train_ng_ransac(tmp_path / "x", layouts=[0, held_out[0]], frames=20, epochs=1)
    with pytest.raises(InvalidInputError, match="frames must be an integer >= 1, got 0"):
        T.train_ng_ransac(tmp_path / "x", layouts=3, frames=0, epochs=1)
    assert drawn == []  # refused before any frame was drawn
    assert not (tmp_path / "x").exists()  # ... or the folder made


@pytest.mark.slow
def test_a_small_run_on_generated_warehouses(tmp_path):
    pytest.importorskip("azgym.learn.dataset", reason="needs azgym.learn.dataset")
    result = T.train_ng_ransac(tmp_path, layouts=2, frames=30, epochs=2, progress=False)
    assert len(result.history) == 2
    assert InlierScorer.load(result.weights).inputs > 0


def test_the_training_data_records_its_distribution_for_the_served_model():
    from azgym.localize.learned.distribution import SERVED_NOISE, TrainingDistribution

    train, _, info = T.build_data([0, 1], 20, 0)
    record = info["distribution"]
    served = TrainingDistribution.of_manifest({"training": {"data": info}})
    assert served.to_manifest() == record
    assert served.delta_alpha_d == SERVED_NOISE
    assert served.min_beacons >= 3
    assert 0.0 < served.min_azimuth_spread <= served.view_spread <= 2 * np.pi
