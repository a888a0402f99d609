"""``azgym bench --suite navigation``: the closed-loop suites, run from the bench command.

A navigation suite (:mod:`azgym.bench.navigation.suites`) is run like a frame suite —
``--localizer``, ``--with-builtins``, ``--split``, ``--quick``, ``--workers``, ``--out`` mean the
same — with ``--navigator`` naming who drives. :mod:`azgym.cli` hands the run over here when the
suite is a navigation suite.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from azgym.errors import InvalidInputError


def bench_navigation(args: argparse.Namespace, progress) -> int:
    """Run the navigation suite ``args.suite``; print the table and write ``navigation.json``."""
    from azgym.bench.navigation.benchmark import check_contenders, contenders_of, run_navigation
    from azgym.bench.navigation.report import score_table
    from azgym.bench.navigation.suites import NAVIGATORS, get_navigation_suite
    from azgym.cli_options import resolve_workers
    from azgym.files import prepare_folder, write_file

    if args.time_limit is not None or args.backend != "local" or args.address is not None:
        raise InvalidInputError("--time-limit, --backend and --address are for the frame "
                                "suites: a navigation suite runs each localizer in the loop "
                                "that drives the forklift, in local processes")
    suite = get_navigation_suite(args.suite)
    localizers = list(dict.fromkeys(args.localizer)) or list(suite.localizers)
    if args.localizer and args.with_builtins:
        localizers += [name for name in suite.localizers if name not in localizers]
    contenders = contenders_of(list(dict.fromkeys(args.navigator)) or list(NAVIGATORS),
                               localizers)
    workers = resolve_workers(args)
    out = prepare_folder(Path(args.out))  # before the run: a bad --out must not waste it
    check_contenders(suite, contenders)
    started = time.perf_counter()
    result = run_navigation(suite, contenders, split=args.split, quick=args.quick,
                            workers=workers, progress=progress)
    path = write_file(out / "navigation.json", json.dumps(result, indent=1) + "\n")
    print()
    print(score_table(result["contenders"], ["navigator", "localizer"]))
    print(f"\n{suite.name} v{suite.version}, {result['split']} split (seed {result['seed']}), "
          f"{result['episodes']} episodes each; {time.perf_counter() - started:.1f} s; "
          f"wrote {path}")
    return 0
