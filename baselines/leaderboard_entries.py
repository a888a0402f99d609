"""Reference leaderboard entries: built-in localizers on every suite, trackers on the routes.

The default built-in localizers and the learned ones run on every suite, and every built-in
tracker on the suites of driven routes (dev split, full size).

    python baselines/leaderboard_entries.py [--workers 2] [--suite NAME ...]

Writes ``leaderboard/entries/<localizer>-<suite>.json`` (and the per-frame results beside each),
then rebuilds ``leaderboard/README.md`` and ``leaderboard/index.html`` (with the navigation
section from ``leaderboard/navigation/``, which ``baselines/navigation_board.py`` writes). The
bench outputs (figures included) go to ``results/bench-<suite>/``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import azgym
from azgym.bench import board, leaderboard
from azgym.bench.contenders import contender
from azgym.bench.runner import default_contenders, run_benchmark
from azgym.bench.suites import SUITES
from azgym.bench.table import ranked_table
from azgym.localize.registry import list_trackers

ROOT = Path(__file__).resolve().parent.parent
LEARNED = ("ng-ransac", "learned")
"""The learned localizers: not among ``azgym bench``'s defaults, but on the board."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--suite", action="append", choices=sorted(SUITES))
    args = parser.parse_args()
    entries = ROOT / "leaderboard" / "entries"
    for name in args.suite or list(SUITES):
        suite = SUITES[name]
        contenders = default_contenders() + [contender(spec) for spec in LEARNED] + (
            [contender(spec) for spec in list_trackers()] if suite.routes else [])
        result = run_benchmark(suite, contenders, workers=args.workers,
                               progress=lambda line: print(line, flush=True))
        out = ROOT / "results" / f"bench-{name}"
        result.write(out)
        print(ranked_table(result.summary), flush=True)
        for label in result.summary["localizers"]:
            path = leaderboard.submit(out, label, entries, name=f"{label}-{name}",
                                      version=azgym.__version__, authors=["azgym developers"],
                                      link="",
                                      overwrite=True)
            print(f"wrote {path}")
    for path in board.build(entries, ROOT / "leaderboard", ROOT / "leaderboard" / "navigation"):
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
