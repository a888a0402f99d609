"""``azgym sweep CONFIG``: localizers x hyperparameter grids x suites x seeds, one table.

The config is a TOML file (:mod:`azgym.bench.sweep.config`, docs/scaling.md), checked field by
field before anything runs; the runs go through the benchmark's runner, on worker processes here
or on Ray (``--backend ray [--address ADDR]``).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from azgym.bench.run.isolation import BACKENDS
from azgym.cli_options import check_backend, out_folder, resolve_workers, workers_option


def add_backend_options(parser: argparse.ArgumentParser, note: str = "") -> None:
    """``--backend local|ray`` and ``--address ADDR``: one definition for bench and sweep."""
    parser.add_argument("--backend", choices=BACKENDS, default="local",
                        help="local: worker processes here; ray: Ray actors (pip install "
                             f"\"azgym[ray]\"), on --address or a local instance{note}")
    parser.add_argument("--address", metavar="ADDR", type=_address,
                        help="--backend ray: a Ray cluster's head, HOST:PORT (see `ray start "
                             "--head`), ray://HOST:PORT or auto (default: a local instance)")


def _address(text: str) -> str:
    """``--address``: checked for its form (HOST:PORT, a port in 1-65535) as it is parsed."""
    from azgym.bench.run.ray_backend import check_address
    from azgym.errors import InvalidInputError

    try:
        check_address(text)
    except InvalidInputError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix(f"--address {text}: ")) from None
    return text


def add_sweep(commands: argparse._SubParsersAction) -> None:
    """``azgym sweep CONFIG [--backend local|ray] [--address ADDR] [--workers N] [--out DIR]``."""
    sweep = commands.add_parser("sweep", help="run a parameter sweep from a TOML file")
    sweep.add_argument("config", metavar="CONFIG", help="the sweep's TOML file (docs/scaling.md)")
    add_backend_options(sweep)
    sweep.add_argument("--workers", type=workers_option, default=0,
                       help="workers per localizer at a time (0: one per core, or per CPU of "
                            "the Ray cluster)")
    sweep.add_argument("--out", type=out_folder, default="results/sweep", help="output folder")
    sweep.set_defaults(handler=_sweep)


def _sweep(args: argparse.Namespace) -> int:
    from azgym.bench.sweep.config import load_sweep
    from azgym.bench.sweep.run import run_sweep
    from azgym.cli import _progress_printer
    from azgym.files import prepare_folder

    check_backend(args)
    config = load_sweep(Path(args.config))
    prepare_folder(Path(args.out))  # before the runs: a bad --out must not waste them
    print(f"{args.config}: {len(config.points)} grid points, {config.runs} runs", flush=True)
    workers = resolve_workers(args)
    started = time.perf_counter()
    result = run_sweep(config, backend=args.backend, address=args.address, workers=workers,
                       progress=_progress_printer())
    written = result.write(Path(args.out))
    print()
    print(result.text())
    print(f"\n{time.perf_counter() - started:.1f} s; wrote {', '.join(map(str, written))}")
    return 0
