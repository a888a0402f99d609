"""The mapping section of the leaderboard: the four built-in mappers on the mapping suite.

survey (azgym's bearing-only SLAM), rays (each beacon's rays intersected, no graph), prior (the
stale map unchanged: the null baseline) and repair (robust:repair=true along the drive) survey
every case of the mapping suite's dev split, at full size (``--quick``: its small version):

    python baselines/mapping_board.py [--workers 2] [--quick]

Writes ``leaderboard/mapping/mapping-dev.json`` (``mapping-dev-quick.json`` for a quick run), the
file ``azgym bench mapping --out DIR`` writes, then rebuilds ``leaderboard/README.md`` and
``leaderboard/index.html``. ``azgym leaderboard verify leaderboard/mapping/FILE`` reruns a file's
cases and compares every figure but the runtimes.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from azgym.bench.leaderboard import board
from azgym.bench.mapping.benchmark import run_mapping
from azgym.bench.mapping.report import SUITE, score_table, write_mapping
from azgym.bench.run.isolation import DEFAULT_TIME_LIMIT
from azgym.mapping.registry import DEFAULT_MAPPERS

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    folder = ROOT / "leaderboard" / "mapping"
    folder.mkdir(parents=True, exist_ok=True)
    started = time.perf_counter()
    result = run_mapping(SUITE, list(DEFAULT_MAPPERS), quick=args.quick, workers=args.workers,
                         time_limit=DEFAULT_TIME_LIMIT, progress=print)
    path = write_mapping(result, folder, f"{SUITE}-dev{'-quick' if args.quick else ''}.json")
    print(score_table(result.summaries.values()))
    print(f"{SUITE} ({len(result.cases)} cases): {time.perf_counter() - started:.0f} s; "
          f"wrote {path}\n", flush=True)
    leaderboard = ROOT / "leaderboard"
    for written_file in board.build(leaderboard / "entries", leaderboard,
                                    leaderboard / "navigation", mapping_dir=folder):
        print(f"wrote {written_file}")


if __name__ == "__main__":
    main()
