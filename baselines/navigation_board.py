"""The navigation section of the leaderboard: both navigators with every default localizer.

For each navigation suite (``navigation``, ``navigation-image``), the scripted pure pursuit and
the shipped PPO policy drive the suite's episodes on each of its default localizers and
trackers, on the dev split and on a test split with a fresh seed (reported in the file).

    python baselines/navigation_board.py [--workers 2] [--suite NAME ...] [--split dev|test ...]

Writes ``leaderboard/navigation/<suite>-<split>.json``, then rebuilds ``leaderboard/README.md``
and ``leaderboard/index.html``. ``azgym leaderboard verify leaderboard/navigation/FILE`` reruns
a file's episodes and compares every figure.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from azgym.bench.leaderboard import board
from azgym.bench.navigation.benchmark import (
    check_contenders,
    navigation_contenders,
    run_navigation,
)
from azgym.bench.navigation.suites import NAVIGATION_SUITES

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--suite", action="append", choices=list(NAVIGATION_SUITES))
    parser.add_argument("--split", action="append", choices=("dev", "test"))
    args = parser.parse_args()
    folder = ROOT / "leaderboard" / "navigation"
    folder.mkdir(parents=True, exist_ok=True)
    for name in args.suite or NAVIGATION_SUITES:
        suite = NAVIGATION_SUITES[name]
        contenders = navigation_contenders(suite, [], [])  # the command's rule, its defaults
        check_contenders(suite, contenders)
        for split in args.split or ("dev", "test"):
            started = time.perf_counter()
            result = run_navigation(suite, contenders, split=split, workers=args.workers,
                                    progress=print)
            path = result.write(folder, f"{name}-{split}.json")
            print(result.table())
            print(f"{name} {split} (seed {result.record['seed']}): "
                  f"{time.perf_counter() - started:.0f} s; wrote {path}\n", flush=True)
    for path in board.build(ROOT / "leaderboard" / "entries", ROOT / "leaderboard", folder,
                            mapping_dir=ROOT / "leaderboard" / "mapping"):
        print(f"wrote {path}")


if __name__ == "__main__":
    main()
