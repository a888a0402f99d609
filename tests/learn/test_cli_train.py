"""``azgym train localizer``: arguments refused by name (exit 2) before any work, each model's
defaults, a clear answer without torch, and a run that writes the model's files."""

from __future__ import annotations

import hashlib

import pytest

from azgym import cli
from azgym.cli import train as cli_train
from azgym.localize.learned.weights import load_weights

SHIPPED_SETTINGS = {"ng-ransac": {"layouts": 64, "epochs": 20, "hidden": 16},
                    "learned": {"layouts": 1000, "epochs": 60, "hidden": 32}}
"""The defaults the command must pass (``learned``'s are the shipped weights' settings)."""


def test_the_command_parses_to_its_handler_with_its_defaults():
    args = cli.build_parser().parse_args(["train", "localizer", "--model", "ng-ransac",
                                          "--out", "runs/a"])
    assert args.handler is cli_train._train_localizer
    assert {key: getattr(args, key) for key in ("model", "out", "layouts", "frames_per_layout",
                                               "epochs", "seed", "hidden", "threads")} == {
        "model": "ng-ransac", "out": "runs/a", "layouts": None, "frames_per_layout": 100,
        "epochs": None, "seed": 0, "hidden": None, "threads": 1}  # None: the model's default


@pytest.mark.parametrize("model", ["ng-ransac", "learned"])
def test_each_model_trains_with_its_own_defaults_unless_told(model, monkeypatch, tmp_path):
    pytest.importorskip("torch", reason="training needs pip install torch==2.13.0")
    calls = []

    class Result:
        history, weights, card, figure = [], "w", "c", "f"

    def train(out, **settings):
        calls.append(settings)
        return Result()

    from azgym.learn import train as ng_ransac_training
    from azgym.learn import train_regression

    monkeypatch.setattr(ng_ransac_training, "train_ng_ransac", train)
    monkeypatch.setattr(train_regression, "train_learned", train)
    base = ["train", "localizer", "--model", model, "--out", str(tmp_path)]
    assert cli.main(base) == 0
    assert cli.main([*base, "--layouts", "3", "--epochs", "2", "--hidden", "4"]) == 0
    assert calls == [{"frames": 100, "seed": 0, "threads": 1, **SHIPPED_SETTINGS[model]},
                     {"frames": 100, "seed": 0, "threads": 1, "layouts": 3, "epochs": 2,
                      "hidden": 4}]


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


def test_without_torch_the_command_says_how_to_install_it(capsys, tmp_path, monkeypatch):
    real = cli_train.importlib.util.find_spec
    monkeypatch.setattr(cli_train.importlib.util, "find_spec",
                        lambda name, *a: None if name == "torch" else real(name, *a))
    code = cli.main(["train", "localizer", "--model", "ng-ransac", "--out", str(tmp_path / "o")])
    assert code == 2
    assert ('torch is not installed: pip install torch==2.13.0 first (the CPU wheel), then pip '
            'install "azgym[train]"' in capsys.readouterr().err)
    assert not (tmp_path / "o").exists()


def test_a_run_writes_the_weights_card_and_curve(capsys, tmp_path):
    pytest.importorskip("torch", reason="training needs pip install torch==2.13.0")
    code = cli.main(["train", "localizer", "--model", "ng-ransac", "--out", str(tmp_path),
                     "--layouts", "2", "--frames-per-layout", "10", "--epochs", "2"])
    assert code == 0
    out = capsys.readouterr().out
    assert "epoch 2: train" in out and "ng-ransac: 2 epochs" in out
    assert {p.name for p in tmp_path.iterdir()} == {"ng-ransac.npz", "model-card.md",
                                                   "learning-curve.png", "checkpoint.pt"}
    card = (tmp_path / "model-card.md").read_text()
    assert "## Calibration of the answer test" in card
    digest = hashlib.sha256((tmp_path / "ng-ransac.npz").read_bytes()).hexdigest()
    assert digest in card  # the calibrated file's digest, not the one before calibration
    manifest = load_weights(tmp_path / "ng-ransac.npz", "ng-ransac")[1]
    assert manifest["calibration"]["min_support_weight"] >= 0.0
    code = cli.main(["train", "localizer", "--model", "ng-ransac", "--out", str(tmp_path),
                     "--layouts", "100001"])
    assert code == 2
    assert "layouts must be at most 100000" in capsys.readouterr().err
