"""Parameter sweeps: every grid point on every suite and seed, through the one runner.

Each (suite, seed) is one :func:`~azgym.bench.run.runner.run_benchmark` of every grid point, locally
or on Ray (one Ray session for the whole sweep). The results merge into one table, a row per
grid point, suite and seed, holding the accuracy figures only: they depend on the config alone,
so the same config gives the same table, whatever the backend or the number of workers.
Runtimes, which depend on the machine, go to a table of their own.

The figure (:func:`write_sweep_figure`, with matplotlib): the headline metric of every grid
point, a panel per suite, a dot per seed. The headline (the p75 position error over every frame,
a refusal infinite) carries its 95 % bootstrap interval from each run, drawn as a bar (an
unbounded side is not drawn); the other metrics are drawn as dots only. A run without a finite
value (every frame failed, or an infinite headline) is left out, and the panel says how many
were; the error axis is logarithmic only when the panel has a positive value to show.
"""

from __future__ import annotations

import contextlib
import csv
import importlib.util
import io
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

from azgym.bench.report.plots import _save
from azgym.bench.run.runner import Progress, run_benchmark
from azgym.bench.sweep.config import GridPoint, SweepConfig
from azgym.files import prepare_folder, write_file
from azgym.metrics import HEADLINE

__all__ = ["FIGURES", "INTERVAL", "LABELS", "SWEEP_FILES", "SweepResult", "run_sweep",
           "write_sweep_figure"]

_TABLE, _RUNTIMES, _FIGURE = "sweep.csv", "runtimes.csv", "sweep.png"
SWEEP_FILES = (_TABLE, _RUNTIMES, _FIGURE)
"""What :meth:`SweepResult.write` writes into its folder: what ``azgym sweep`` claims in
``--out``."""

FIGURES: Final = ("n", HEADLINE, "availability", "failure_rate", "median_cm", "p75_cm", "p95_cm",
           "mean_cm", "rmse_cm")
"""The accuracy figures of each row, from each run's overall figures: the headline (every frame,
a refusal infinite), then the answered frames' figures. The table then adds the headline's 95 %
interval (:data:`INTERVAL`)."""
INTERVAL = (f"{HEADLINE}_lo", f"{HEADLINE}_hi")
"""The columns of the headline's 95 % interval."""


@dataclass
class SweepResult:
    """A sweep's merged table (accuracy figures) and its runtimes, row by row."""

    config: SweepConfig
    columns: list[str]
    rows: list[list[Any]]
    runtimes: list[list[Any]]

    def csv(self) -> str:
        """The table as CSV (numbers to 6 significant digits)."""
        return _csv(self.columns, self.rows)

    def text(self) -> str:
        """The table as printed: one aligned line per row."""
        cells = [self.columns] + [[_cell(v) for v in row] for row in self.rows]
        widths = [max(len(row[k]) for row in cells) for k in range(len(self.columns))]
        return "\n".join("  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip()
                         for row in cells)

    def write(self, out: Path) -> list[Path]:
        """sweep.csv, runtimes.csv and, with matplotlib installed, sweep.png."""
        prepare_folder(out)
        written = [write_file(out / _TABLE, self.csv()),
                   write_file(out / _RUNTIMES,
                              _csv(["label", "suite", "seed", "median_us", "ratio_to_ransac"],
                                   self.runtimes))]
        if importlib.util.find_spec("matplotlib") is not None:
            written.append(write_sweep_figure(self, out / _FIGURE))
        return written


def run_sweep(config: SweepConfig, *, backend: str = "local", address: str | None = None,
              workers: int = 1, progress: Progress | None = None) -> SweepResult:
    """Run every grid point on every suite and seed of a checked config.

    Args:
        config: The sweep (:func:`~azgym.bench.sweep.config.load_sweep`).
        backend: "local" or "ray" (one Ray session serves every run).
        address: The Ray cluster's address (``backend="ray"`` only).
        workers: Workers per contender at a time (with Ray, 0: one per CPU of the cluster).
        progress: Called with text as the sweep advances.
    """
    session: Any = contextlib.nullcontext(workers)
    if backend == "ray":
        from azgym.bench.run.ray_session import ray_session

        session = ray_session(address, workers, progress)
        address = None  # the session joins it; each run then uses the session
    say = progress or (lambda _line: None)
    hyper = list(dict.fromkeys(key for p in config.points for key in p.varied))
    columns = ["suite", "seed", "localizer", *hyper, "label", *FIGURES, *INTERVAL]
    rows: list[list[Any]] = []
    runtimes: list[list[Any]] = []
    with session as slots:
        for suite in config.suites:
            name = suite.name
            for seed in config.seeds or [suite.dev_seed]:
                say(f"{name}, seed {seed}: {len(config.points)} grid points")
                result = run_benchmark(
                    suite, [p.contender for p in config.points], quick=config.quick,
                    split="dev" if seed == suite.dev_seed else "test", seed=seed,
                    workers=slots, time_limit=config.time_limit, progress=progress,
                    backend=backend, address=address, maps=config.maps.get(name))
                figures = result.summary["localizers"]
                for point in config.points:
                    got = figures[point.contender.label]
                    rows.append([name, seed, point.target,
                                 *(point.varied.get(key, "") for key in hyper),
                                 point.contender.label, *(got["all"][f] for f in FIGURES),
                                 *got["ci95"][HEADLINE]])
                    runtimes.append([point.contender.label, name, seed,
                                     got["runtime_us"]["median"],
                                     got["runtime_us"]["ratio_to_ransac"]])
    return SweepResult(config, columns, rows, runtimes)


def _cell(value: Any) -> str:
    """A table cell: numbers to 6 significant digits, booleans as TOML writes them."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:.6g}"
    return str(value)


def _csv(columns: list[str], rows: list[list[Any]]) -> str:
    table = io.StringIO(newline="")
    writer = csv.writer(table)
    writer.writerow(columns)
    writer.writerows([[_cell(v) for v in row] for row in rows])
    return table.getvalue()


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
