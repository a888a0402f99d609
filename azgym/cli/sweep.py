"""``azgym sweep CONFIG``: localizers x hyperparameter grids x suites x seeds, one table.

The config is a TOML file (:mod:`azgym.bench.sweep.config`, docs/scaling.md), checked field by
field before anything runs; the runs go through the benchmark's runner, on worker processes here
or on Ray (``--backend ray [--address ADDR]``).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from azgym.cli.options import (
    add_backend_options,
    add_overwrite,
    check_backend,
    out_folder,
    progress_printer,
    resolve_workers,
    workers_option,
)

__all__ = ["add_sweep"]


def add_sweep(commands: argparse._SubParsersAction) -> None:
    """``azgym sweep CONFIG [--backend local|ray] [--address ADDR] [--workers N] [--out DIR]``."""
    sweep = commands.add_parser("sweep", help="run a parameter sweep from a TOML file")
    sweep.add_argument("config", metavar="CONFIG", help="the sweep's TOML file (docs/scaling.md)")
    add_backend_options(sweep)
    sweep.add_argument("--workers", type=workers_option, default=0,
                       help="workers per localizer at a time (0: one per core, or per CPU of "
                            "the Ray cluster)")
    sweep.add_argument("--out", type=out_folder, default="results/sweep", help="output folder")
    add_overwrite(sweep, "the results in --out")
    sweep.set_defaults(handler=_sweep)


def _sweep(args: argparse.Namespace) -> int:
    from azgym.bench.sweep.config import load_sweep
    from azgym.bench.sweep.run import SWEEP_FILES, run_sweep
    from azgym.files import claim_folder, prepare_folder

    check_backend(args)
    config = load_sweep(Path(args.config))
    # Before the runs: a bad --out, or results it would replace, must not waste them.
    prepare_folder(claim_folder(Path(args.out), SWEEP_FILES, args.overwrite, "--out"))
    print(f"{args.config}: {len(config.points)} grid points, {config.runs} runs", flush=True)
    workers = resolve_workers(args)
    started = time.perf_counter()
    result = run_sweep(config, backend=args.backend, address=args.address, workers=workers,
                       progress=progress_printer())
    written = result.write(Path(args.out))
    print()
    print(result.text())
    print(f"\n{time.perf_counter() - started:.1f} s; wrote {', '.join(map(str, written))}")
    from azgym.site.drawing import figures_skipped

    if (skipped := figures_skipped([name for name in SWEEP_FILES
                                    if name.endswith(".png")])) is not None:
        print(skipped)
    return 0
