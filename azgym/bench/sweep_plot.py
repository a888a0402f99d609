"""A sweep's figure: the headline metric of every grid point, a panel per suite, a dot per seed.

The headline (the p75 position error over every frame, a refusal infinite) carries its 95 %
bootstrap interval from each run, drawn as a bar (an unbounded side is not drawn); the other
metrics are drawn as dots only. A run without a finite value (every frame failed, or an infinite
headline) is left out, and the panel says how many were; the error axis is
logarithmic only when the panel has a positive value to show.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

from azgym.bench.metrics import HEADLINE
from azgym.bench.plots import _save
from azgym.bench.sweep import INTERVAL

if TYPE_CHECKING:
    from azgym.bench.sweep import SweepResult
    from azgym.bench.sweep_config import GridPoint, SweepConfig

LABELS = {HEADLINE: "p75 position error, every frame [cm]",
          "p75_cm": "p75 position error, answered frames [cm]",
          "median_cm": "median position error [cm]", "mean_cm": "mean position error [cm]",
          "p95_cm": "p95 position error [cm]",
          "rmse_cm": "RMS position error [cm]", "availability": "availability",
          "failure_rate": "failure rate"}


def write_sweep_figure(result: SweepResult, path: Path) -> Path:
    """sweep.png: the config's metric per grid point (x), one panel per suite (needs matplotlib).

    Raises:
        ImportError: matplotlib is not installed.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    config, columns = result.config, result.columns
    at = {name: k for k, name in enumerate(columns)}
    labels = [p.contender.label for p in config.points]
    figure, panels = plt.subplots(1, len(config.suites), squeeze=False, sharey=True,
                                  figsize=(max(5.0, 0.5 * len(labels) + 2) * len(config.suites),
                                           4.2), constrained_layout=True)
    seeds = list(dict.fromkeys(row[at["seed"]] for row in result.rows))
    for axes, suite in zip(panels[0], [suite.name for suite in config.suites], strict=True):
        shown: list[float] = []
        missing = 0
        for j, seed in enumerate(seeds):
            rows = [r for r in result.rows if r[at["suite"]] == suite and r[at["seed"]] == seed]
            missing += sum(not _finite(r[at[config.metric]]) for r in rows)
            rows = [r for r in rows if _finite(r[at[config.metric]])]
            if not rows:
                continue
            x = [labels.index(r[at["label"]]) + 0.1 * (j - (len(seeds) - 1) / 2) for r in rows]
            y = [r[at[config.metric]] for r in rows]
            shown += y
            if config.metric == HEADLINE:
                low = [_bar(v - r[at[INTERVAL[0]]]) for v, r in zip(y, rows, strict=True)]
                high = [_bar(r[at[INTERVAL[1]]] - v) for v, r in zip(y, rows, strict=True)]
                axes.errorbar(x, y, yerr=[low, high], fmt="o", capsize=3, label=f"seed {seed}")
            else:
                axes.plot(x, y, "o", label=f"seed {seed}")
        _finish(axes, suite, config, labels, shown, missing)
    panels[0][0].set_ylabel(LABELS[config.metric])
    if panels[0][-1].get_legend_handles_labels()[0]:
        panels[0][-1].legend(fontsize=7)
    return _save(figure, path, plt)


def _finish(axes: Any, suite: str, config: SweepConfig, labels: list[str], shown: list[float],
            missing: int) -> None:
    """A panel's ticks, title and scale, and a note of the runs it could not show."""
    axes.set_xticks(range(len(labels)), [_tick(p) for p in config.points], rotation=60,
                    ha="right", fontsize=7)
    axes.set_xlim(-0.5, len(labels) - 0.5)
    if config.metric.endswith("_cm") and any(v > 0 for v in shown):
        axes.set_yscale("log")
    if missing:
        axes.text(0.5, 0.98, f"{missing} run(s) without a value (every frame failed): not shown",
                  transform=axes.transAxes, ha="center", va="top", fontsize=7)
    axes.set_title(suite, fontsize=10)
    axes.grid(axis="y", alpha=0.3)


def _finite(value: Any) -> bool:
    """Whether a table cell is a number to draw (not NaN, not infinite)."""
    return isinstance(value, int | float) and math.isfinite(value)


def _bar(length: float) -> float:
    """One side of an interval's bar: 0 where the interval is unknown or unbounded."""
    return length if math.isfinite(length) else 0.0


def _tick(point: GridPoint) -> str:
    """A grid point as the axis names it: the localizer and the values the grid varies."""
    varied = ",".join(f"{key}={value}" for key, value in point.varied.items())
    return f"{point.target} {varied}".strip()
