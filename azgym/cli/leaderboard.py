"""``azgym leaderboard submit|build|verify``: make, publish and check leaderboard entries.

``submit`` makes an entry from an ``azgym bench`` output folder, ``build`` writes the board,
``verify`` reruns an entry (or a navigation results file) and compares its figures.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from azgym.cli.options import resolve_workers, workers_option

__all__ = ["DATASETS_HELP", "add_leaderboard"]

DATASETS_HELP = ("where the logs of entries scored on a log are, as DIR/NAME/ (default: "
                 "datasets/ beside the entries, if there is one; shipped logs are found by name)")


def add_leaderboard(commands: argparse._SubParsersAction) -> None:
    """``azgym leaderboard submit|build|verify``: make, publish and check entries."""
    board = commands.add_parser("leaderboard", help="submit, build or verify entries")
    actions = board.add_subparsers(dest="action", required=True)
    submit = actions.add_parser("submit", help="make an entry from an azgym bench output")
    submit.add_argument("results", help="the folder azgym bench wrote (results.json, frames.csv)")
    submit.add_argument("--localizer", required=True, help="the localizer's label in the results")
    submit.add_argument("--name", required=True, help="entry name (letters, digits, . _ -)")
    submit.add_argument("--version", required=True, help="the localizer's version")
    submit.add_argument("--authors", required=True, nargs="+")
    submit.add_argument("--link", default="", help="paper or code")
    submit.add_argument("--entries", default="leaderboard/entries")
    submit.add_argument("--overwrite", action="store_true")
    submit.add_argument("--datasets", metavar="DIR", help=DATASETS_HELP)
    build = actions.add_parser("build", help="write leaderboard/README.md and index.html")
    build.add_argument("--entries", default="leaderboard/entries")
    build.add_argument("--out", default="leaderboard")
    build.add_argument("--navigation", metavar="DIR",
                       help="navigation results files (default: navigation/ beside --entries, "
                            "if there is one)")
    build.add_argument("--datasets", metavar="DIR", help=DATASETS_HELP)
    build.add_argument("--skip-unavailable", action="store_true",
                       help="leave entries whose dataset is not found off the board (listed "
                            "as unchecked) instead of refusing to build")
    verify = actions.add_parser("verify", help="rerun an entry and compare its figures")
    verify.add_argument("entry", help="path of the entry's .json, or of a navigation results "
                                      "file")
    verify.add_argument("--workers", type=workers_option, default=1,
                        help="processes (0: one per core; default: 1)")
    verify.add_argument("--datasets", metavar="DIR", help=DATASETS_HELP)
    board.set_defaults(handler=_leaderboard)


def _leaderboard(args: argparse.Namespace) -> int:
    from azgym.bench.leaderboard import board
    from azgym.bench.leaderboard import entries as leaderboard
    from azgym.bench.navigation.board import verify_navigation
    from azgym.bench.navigation.results_file import is_navigation_file

    if args.action == "submit":
        path = leaderboard.submit(Path(args.results), args.localizer, Path(args.entries),
                                  name=args.name, version=args.version, authors=args.authors,
                                  link=args.link, overwrite=args.overwrite,
                                  datasets=_datasets(args))
        print(f"wrote {path}")
    elif args.action == "build":
        for path in board.build(Path(args.entries), Path(args.out),
                                _navigation_dir(args.navigation, Path(args.entries)),
                                datasets=_datasets(args),
                                skip_unavailable=args.skip_unavailable):
            print(f"wrote {path}")
    elif is_navigation_file(Path(args.entry)):
        print(f"{args.entry}: rerunning its navigators and localizers (azgym's own)", flush=True)
        differences = verify_navigation(Path(args.entry), workers=resolve_workers(args))
        return _verdict(args.entry, differences)
    else:
        entry = leaderboard.load_entry(Path(args.entry), _datasets(args))
        test = entry["split"] == "test"
        where = "on a fresh secret seed" if test else "on its own frames"
        print(f"{args.entry}: rerunning its localizer {entry['localizer']['spec']!r}, which is "
              f"the submitter's code, {where}", flush=True)
        differences = leaderboard.verify(Path(args.entry), workers=resolve_workers(args),
                                         datasets=_datasets(args))
        return _verdict(args.entry, differences, test)
    return 0


def _datasets(args: argparse.Namespace) -> Path | None:
    """``--datasets DIR``: where dataset entries' logs are looked for (None: the default)."""
    return None if args.datasets is None else Path(args.datasets)


def _verdict(entry: str, differences: dict[str, tuple[Any, Any]],
             test: bool = False) -> int:
    """Print a rerun's differing figures, or that it reproduced; the command's exit status.

    A test entry is rerun on fresh frames, so its figures agree when their 95 % intervals
    overlap (:func:`azgym.bench.leaderboard.entries.verify`); any other, within 1e-6.
    """
    if differences:
        for key, (claimed, fresh) in differences.items():
            print(f"{key}: entry {claimed}, rerun {fresh}")
        print(f"{entry}: NOT reproduced")
        return 1
    agreed = ("each 95 % interval overlaps the rerun's" if test
              else "every accuracy figure within 1e-6")
    print(f"{entry}: reproduced ({agreed})")
    return 0


def _navigation_dir(named: str | None, entries: Path) -> Path | None:
    """The navigation results folder: the one named (it must exist), else any beside entries."""
    from azgym.bench.leaderboard.entry_files import LeaderboardError

    if named is None:
        beside = entries.parent / "navigation"
        return beside if beside.is_dir() else None
    if not Path(named).is_dir():
        raise LeaderboardError(f"--navigation {named}: no such folder")
    return Path(named)
