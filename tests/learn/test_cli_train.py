"""``azgym train localizer``: arguments refused by name (exit 2) before any work, a clear answer
without torch or for a model not trainable yet, and a run that writes the model's files."""

from __future__ import annotations

import sys
import types

import numpy as np
import pytest

from azgym import cli, cli_train


def test_the_command_parses_to_its_handler_with_its_defaults():
    args = cli.build_parser().parse_args(["train", "localizer", "--model", "ng-ransac",
                                          "--out", "runs/a"])
    assert args.handler is cli_train._train_localizer
    assert {key: getattr(args, key) for key in ("model", "out", "layouts", "frames_per_layout",
                                               "epochs", "seed", "hidden", "threads")} == {
        "model": "ng-ransac", "out": "runs/a", "layouts": 64, "frames_per_layout": 100,
        "epochs": 20, "seed": 0, "hidden": 16, "threads": 1}


@pytest.mark.parametrize(("argv", "message"), [
    (["--epochs", "0"], "argument --epochs: must be an integer >= 1, got '0'"),
    (["--layouts", "2.5"], "argument --layouts: must be an integer >= 1, got '2.5'"),
    (["--frames-per-layout", "-3"], "argument --frames-per-layout: must be an integer >= 1"),
    (["--seed", "-1"], "argument --seed: must be an integer >= 0, got '-1'"),
    (["--threads", "x"], "argument --threads: must be an integer >= 1, got 'x'"),
    (["--model", "ransac"], "argument --model: invalid choice: 'ransac'"),
])
def test_bad_arguments_exit_2_naming_the_argument(argv, message, capsys, tmp_path):
    base = {"--model": "ng-ransac", "--out": str(tmp_path / "out")}
    for flag, value in zip(argv[::2], argv[1::2], strict=True):
        base[flag] = value
    with pytest.raises(SystemExit) as stopped:
        cli.main(["train", "localizer", *[x for pair in base.items() for x in pair]])
    assert stopped.value.code == 2
    assert message in capsys.readouterr().err
    assert not (tmp_path / "out").exists()  # refused before any work


def test_the_learned_model_is_announced_as_not_available_yet(capsys, tmp_path):
    code = cli.main(["train", "localizer", "--model", "learned", "--out", str(tmp_path / "o")])
    assert code == 2
    assert ("azgym: error: --model learned: not available yet; trainable models: ng-ransac"
            in capsys.readouterr().err)


def test_without_torch_the_command_says_how_to_install_it(capsys, tmp_path, monkeypatch):
    real = cli_train.importlib.util.find_spec
    monkeypatch.setattr(cli_train.importlib.util, "find_spec",
                        lambda name, *a: None if name == "torch" else real(name, *a))
    code = cli.main(["train", "localizer", "--model", "ng-ransac", "--out", str(tmp_path / "o")])
    assert code == 2
    assert ('torch is not installed: pip install torch==2.13.0 first (the CPU wheel), then pip '
            'install "azgym[train]"' in capsys.readouterr().err)
    assert not (tmp_path / "o").exists()


def test_a_run_writes_the_weights_card_and_curve(capsys, tmp_path, monkeypatch):
    pytest.importorskip("torch", reason="training needs pip install torch==2.13.0")
    rng = np.random.default_rng(0)

    def make_frames(layout_seeds, frames_per_layout, seed):
        n = len(layout_seeds) * frames_per_layout
        mask = np.arange(8) < rng.integers(3, 9, size=(n, 1))
        features = rng.uniform(size=(n, 8, 5)).astype(np.float32)
        return types.SimpleNamespace(features=features, mask=mask,
                                     inlier=(features[..., 0] > 0.3) & mask)

    monkeypatch.setitem(sys.modules, "azgym.learn.dataset", types.SimpleNamespace(
        TRAIN_LAYOUTS=range(100, 200), HELD_OUT_LAYOUTS=(1, 2), make_frames=make_frames))
    monkeypatch.setitem(sys.modules, "azgym.learn.features",
                        types.SimpleNamespace(FEATURE_LAYOUT="test-features-1"))
    code = cli.main(["train", "localizer", "--model", "ng-ransac", "--out", str(tmp_path),
                     "--layouts", "2", "--frames-per-layout", "10", "--epochs", "2"])
    assert code == 0
    out = capsys.readouterr().out
    assert "epoch 2: train" in out and "ng-ransac: 2 epochs" in out
    assert {p.name for p in tmp_path.iterdir()} == {"ng-ransac.npz", "model-card.md",
                                                   "learning-curve.png", "checkpoint.pt"}
    code = cli.main(["train", "localizer", "--model", "ng-ransac", "--out", str(tmp_path),
                     "--layouts", "101"])
    assert code == 2
    assert "layouts must be at most 100" in capsys.readouterr().err
