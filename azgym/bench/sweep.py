"""Parameter sweeps: every grid point on every suite and seed, through the one runner.

Each (suite, seed) is one :func:`~azgym.bench.runner.run_benchmark` of every grid point, locally
or on Ray (one Ray session for the whole sweep). The results merge into one table, a row per
grid point, suite and seed, holding the accuracy figures only: they depend on the config alone,
so the same config gives the same table, whatever the backend or the number of workers.
Runtimes, which depend on the machine, go to a table of their own.
"""

from __future__ import annotations

import contextlib
import csv
import io
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from azgym.bench.metrics import HEADLINE
from azgym.bench.runner import Progress, run_benchmark
from azgym.bench.sweep_config import SweepConfig
from azgym.files import prepare_folder, write_file

FIGURES = ("n", HEADLINE, "availability", "failure_rate", "median_cm", "p75_cm", "p95_cm",
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
        written = [write_file(out / "sweep.csv", self.csv()),
                   write_file(out / "runtimes.csv",
                              _csv(["label", "suite", "seed", "median_us", "ratio_to_ransac"],
                                   self.runtimes))]
        with contextlib.suppress(ImportError):
            from azgym.bench.sweep_plot import write_sweep_figure

            written.append(write_sweep_figure(self, out / "sweep.png"))
        return written


def run_sweep(config: SweepConfig, *, backend: str = "local", address: str | None = None,
              workers: int = 1, progress: Progress | None = None) -> SweepResult:
    """Run every grid point on every suite and seed of a checked config.

    Args:
        config: The sweep (:func:`~azgym.bench.sweep_config.load_sweep`).
        backend: "local" or "ray" (one Ray session serves every run).
        address: The Ray cluster's address (``backend="ray"`` only).
        workers: Workers per contender at a time (with Ray, 0: one per CPU of the cluster).
        progress: Called with text as the sweep advances.
    """
    session: Any = contextlib.nullcontext(workers)
    if backend == "ray":
        from azgym.bench.ray_backend import ray_session

        session = ray_session(address, workers)
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

