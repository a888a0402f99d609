"""Reference leaderboard entries: built-in localizers on every suite, trackers on the routes.

The default built-in localizers and the learned ones run on every suite, and every built-in
tracker on the suites of driven routes (dev split, full size). ``--data NAME`` runs them on a
log instead (a shipped log's name, or a folder ``leaderboard/datasets/NAME/``; the trackers
too when it has odometry or IMU), each contender with its defaults from the log's profile (its
``[vehicle]``, ``[sensor]`` and ``[motion]`` sections), and then only the suites named by
``--suite``; ``--real`` runs them on every shipped log of real data (docs/datasets.md).
``--localizer SPEC`` runs only the contenders named (with ``ransac``, the runtime reference)
and rewrites only their entries: after a change to one method, its entries are brought up to
date without the others'.

    python baselines/leaderboard_entries.py [--workers 2] [--suite NAME ...] [--data NAME ...]
        [--real] [--localizer SPEC ...]

Writes ``leaderboard/entries/<localizer>-<suite>.json`` (``<localizer>-data-<dataset>.json`` for
a log) and the per-frame results beside each, then (unless ``--no-board``) rebuilds
``leaderboard/README.md`` and ``leaderboard/index.html`` (with the navigation section from
``leaderboard/navigation/``, which ``baselines/navigation_board.py`` writes). The bench outputs
(figures included) go to ``results/bench-<suite>/`` (``results/bench-data-<dataset>/``).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

import azgym
from azgym.bench.leaderboard import board
from azgym.bench.leaderboard import entries as leaderboard
from azgym.bench.report.table import ranked_table
from azgym.bench.run.contenders import Contender, contender
from azgym.bench.run.runner import default_contenders, run_benchmark, run_log_benchmark
from azgym.bench.suites import SUITES
from azgym.localize.registry import list_trackers
from azgym.logs import read_log
from azgym.logs.manifest import read_manifest
from azgym.logs.problems import Problems
from azgym.logs.read import shipped_logs

ROOT = Path(__file__).resolve().parent.parent
LEARNED = ("ng-ransac", "learned")
"""The learned localizers: not among ``azgym bench``'s defaults, but on the board."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--suite", action="append", choices=sorted(SUITES))
    parser.add_argument("--data", action="append", metavar="NAME",
                        help="a log: a shipped log's name or a log folder")
    parser.add_argument("--real", action="store_true",
                        help="every shipped log of real data (as if each were given by --data)")
    parser.add_argument("--localizer", action="append", metavar="SPEC",
                        help="only this contender's entries (repeatable; default: every one)")
    parser.add_argument("--no-board", action="store_true",
                        help="write the entries only (azgym leaderboard build writes the board)")
    args = parser.parse_args()
    known = {c.label for c in _contenders(True, None)}
    for spec in args.localizer or []:
        if spec not in known:
            parser.error(f"--localizer {spec}: not a contender of the board; one of "
                         f"{', '.join(sorted(known))}")
    entries = ROOT / "leaderboard" / "entries"
    logs = (args.data or []) + (real_logs() if args.real else [])
    for name in args.suite or ([] if logs else list(SUITES)):
        suite = SUITES[name]
        result = run_benchmark(suite, _contenders(suite.routes, args.localizer),
                               workers=args.workers,
                               progress=lambda line: print(line, flush=True))
        out = ROOT / "results" / f"bench-{name}"
        result.write(out)
        _submit(result.summary, out, entries, name, args.localizer)
    for folder in logs:
        log = read_log(folder)
        result = run_log_benchmark(log, _contenders(log.odometry is not None or
                                                    log.imu is not None, args.localizer),
                                   workers=args.workers,
                                   progress=lambda line: print(line, flush=True))
        out = ROOT / "results" / f"bench-data-{log.manifest.name}"
        result.write(out)
        _submit(result.summary, out, entries, f"data-{log.manifest.name}", args.localizer)
    if args.no_board:
        return
    for path in board.build(entries, ROOT / "leaderboard", ROOT / "leaderboard" / "navigation",
                            mapping_dir=ROOT / "leaderboard" / "mapping"):
        print(f"wrote {path}")


def real_logs() -> list[str]:
    """The names of the shipped logs of real data (their manifests say ``simulated = false``)."""
    manifests = {name: read_manifest(folder, Problems(str(folder)))
                 for name, folder in shipped_logs().items()}
    return [name for name, manifest in manifests.items()
            if manifest is not None and not manifest.simulated]


def _contenders(routes: bool, only: list[str] | None) -> list[Contender]:
    """The default built-in localizers, the learned ones, and the trackers on driven routes.

    ``only``: just these specs (those that run on the suite: a tracker only on driven routes).
    """
    every = default_contenders() + [contender(spec) for spec in LEARNED] + (
        [contender(spec) for spec in list_trackers()] if routes else [])
    if only is None:
        return every
    return [c for c in every if c.label in only]


def _submit(summary: dict[str, Any], out: Path, entries: Path, suffix: str,
            only: list[str] | None) -> None:
    """An entry ``<localizer>-<suffix>`` of every localizer of a run (of those in ``only``)."""
    print(ranked_table(summary), flush=True)
    for label in summary["localizers"]:
        if only is not None and label not in only:
            continue
        path = leaderboard.submit(out, label, entries, name=f"{label}-{suffix}",
                                  version=azgym.__version__, authors=["azgym developers"],
                                  link="", overwrite=True)
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
