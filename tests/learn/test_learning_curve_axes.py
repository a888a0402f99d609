"""A learning curve's panels are fitted to their data: 0.976-0.994 is not drawn on 0-1."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from azgym.learn.train_report import write_learning_curve  # noqa: E402


def test_the_held_out_panel_spans_its_values_not_zero_to_one(monkeypatch, tmp_path):
    history = [{"epoch": k + 1, "train_loss": 0.07 - 0.002 * k, "held_out_loss": 0.04 - 0.001 * k,
                "held_out_accuracy": 0.978 + 0.001 * k, "held_out_auc": 0.989 + 0.0005 * k,
                "held_out_top3": 0.976 + 0.0002 * k} for k in range(10)]
    closed = []
    monkeypatch.setattr(plt, "close", closed.append)
    path = write_learning_curve(history, tmp_path / "curve.png")
    assert path.read_bytes().startswith(b"\x89PNG")
    low, high = closed[0].axes[1].get_ylim()
    assert 0.95 < low < 0.976 and 0.9935 < high < 1.0
