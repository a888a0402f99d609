"""Training counts its batches on the shared meter (azgym.progress) and writes a line per epoch.

An epoch can take several seconds, and a run minutes: piped (a CI log, ``| tee``; pytest's
capture is no terminal), the count is a plain line on standard error with done/total, the rate
and the time left (the meter writes one at least every few seconds and one at the end), while
the epochs' lines go to standard output. A resumed run counts only the batches still to train.
"""

from __future__ import annotations

import math
import re

import pytest

pytest.importorskip("torch", reason="training needs pip install torch==2.13.0 (extra 'train')")

from learn.test_train import HELD_OUT, LAYOUT, TRAIN  # noqa: E402

from azgym.learn import train as T  # noqa: E402


def count_lines(err: str, label: str, total: int) -> list[str]:
    """The meter's plain lines of one count of batches."""
    line = re.compile(rf"  {re.escape(label)}: \d+/{total} batches \[\d\d:\d\d<(\d\d:\d\d|\?), "
                      r"(\?|[\d.]+)(batches/s|s/batches)\]")
    return [text for text in err.splitlines() if line.fullmatch(text)]


def test_piped_training_counts_its_batches_with_the_time_left(tmp_path, capsys):
    steps = math.ceil(len(TRAIN.features) / T.TrainConfig().batch_size)
    T.fit(TRAIN, HELD_OUT, tmp_path, T.TrainConfig(epochs=2), feature_layout=LAYOUT)
    captured = capsys.readouterr()
    assert count_lines(captured.err, "training ng-ransac", 2 * steps)[-1].startswith(
        f"  training ng-ransac: {2 * steps}/{2 * steps} batches [")
    assert [line.split(":")[0] for line in captured.out.splitlines()] == ["epoch 1", "epoch 2"]
    T.fit(TRAIN, HELD_OUT, tmp_path, T.TrainConfig(epochs=3), feature_layout=LAYOUT)
    captured = capsys.readouterr()
    assert count_lines(captured.err, "training ng-ransac", steps)  # only the third epoch's
    assert captured.out.splitlines()[0].startswith("resuming from ")


def test_without_progress_nothing_is_written(tmp_path, capsys):
    T.fit(TRAIN, HELD_OUT, tmp_path, T.TrainConfig(epochs=1), feature_layout=LAYOUT,
          progress=False)
    assert capsys.readouterr() == ("", "")


@pytest.mark.slow
def test_the_learned_model_counts_its_batches_too(tmp_path, capsys):
    from azgym.learn.train_regression import train_learned

    train_learned(tmp_path, layouts=2, frames=10, epochs=2, hidden=8)
    captured = capsys.readouterr()
    assert re.search(r"^  training learned: (\d+)/\1 batches \[", captured.err, re.MULTILINE)
    assert "epoch 2: train" in captured.out
