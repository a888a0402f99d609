"""A resumed training run says so first: where from and how far the run had gone."""

from __future__ import annotations

import pytest

pytest.importorskip("torch", reason="training needs pip install torch==2.13.0 (extra 'train')")

from learn.test_train import HELD_OUT, LAYOUT, TRAIN  # noqa: E402

from azgym.learn import train as T  # noqa: E402


def test_a_resumed_run_says_where_from_and_at_which_epoch(tmp_path, capsys):
    for epochs in (1, 2):
        T.fit(TRAIN, HELD_OUT, tmp_path, T.TrainConfig(epochs=epochs), feature_layout=LAYOUT,
              progress=True)
    printed = capsys.readouterr().out.splitlines()
    assert f"resuming from {tmp_path / T.CHECKPOINT_NAME} (epoch 1 of 2 done)" in printed
    assert printed.index(f"resuming from {tmp_path / T.CHECKPOINT_NAME} (epoch 1 of 2 done)") \
        < printed.index(next(line for line in printed if line.startswith("epoch 2:")))
