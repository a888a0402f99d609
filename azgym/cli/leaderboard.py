"""``azgym leaderboard submit|build|verify``: make, publish and check leaderboard entries.

``submit`` makes an entry from an ``azgym bench`` output folder, ``build`` writes the board,
``verify`` reruns an entry (or a navigation or mapping results file) and compares its figures.

Without ``--entries``, ``submit`` and ``build`` use the board of the folder they are run in or of
the nearest folder above it (``leaderboard/entries/``, as in azgym's repository), and say which;
where there is none they refuse rather than start a new board, which only ``--entries`` does.
``submit`` warns when its entry would stand alone in its table: a quick run (ranked apart from the
full-size runs) or a board without another entry of its suite, split and size.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from azgym.cli.options import (
    add_overwrite,
    out_folder,
    progress_printer,
    resolve_workers,
    workers_option,
)
from azgym.errors import InvalidInputError

__all__ = ["BOARD", "DATASETS_HELP", "add_leaderboard", "find_entries"]

BOARD = Path("leaderboard") / "entries"
"""Where a board's entries are, below the folder it is found from (azgym's repository)."""
ENTRIES_HELP = ("the board's entries folder (default: leaderboard/entries/ in this folder or the "
                "nearest one above it, as in azgym's repository; a new folder starts a new board)")

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
    submit.add_argument("--authors", required=True, nargs="+", metavar="NAME",
                        help="one or more authors, each a quoted name (\"Ada Lovelace\")")
    submit.add_argument("--link", default="", help="paper or code")
    submit.add_argument("--entries", metavar="DIR", type=out_folder, help=ENTRIES_HELP)
    add_overwrite(submit, "an entry of that name (its NAME.json and NAME.frames.csv.gz)")
    submit.add_argument("--datasets", metavar="DIR", help=DATASETS_HELP)
    build = actions.add_parser("build", help="write leaderboard/README.md and index.html")
    build.add_argument("--entries", metavar="DIR", type=out_folder, help=ENTRIES_HELP)
    build.add_argument("--out", metavar="DIR", type=out_folder,
                       help="where README.md and index.html are written (default: the folder "
                            "holding --entries)")
    build.add_argument("--navigation", metavar="DIR",
                       help="navigation results files (default: navigation/ beside --entries, "
                            "if there is one)")
    build.add_argument("--mapping", metavar="DIR",
                       help="mapping results files (default: mapping/ beside --entries, if "
                            "there is one)")
    build.add_argument("--datasets", metavar="DIR", help=DATASETS_HELP)
    add_overwrite(build, "a README.md or index.html in --out that is no azgym board")
    build.add_argument("--skip-unavailable", action="store_true",
                       help="leave entries whose dataset is not found off the board (listed "
                            "as unchecked) instead of refusing to build")
    verify = actions.add_parser("verify", help="rerun an entry and compare its figures")
    verify.add_argument("entry", help="path of the entry's .json, or of a navigation or "
                                      "mapping results file")
    verify.add_argument("--workers", type=workers_option, default=1,
                        help="processes (0: one per core; default: 1)")
    verify.add_argument("--datasets", metavar="DIR", help=DATASETS_HELP)
    board.set_defaults(handler=_leaderboard)


def _leaderboard(args: argparse.Namespace) -> int:
    from azgym.bench.leaderboard import board
    from azgym.bench.leaderboard import entries as leaderboard
    from azgym.bench.mapping.board import verify_mapping
    from azgym.bench.mapping.results_file import is_mapping_file
    from azgym.bench.navigation.board import verify_navigation
    from azgym.bench.navigation.results_file import is_navigation_file
    from azgym.localize.registry import is_builtin

    if args.action == "submit":
        entries = _entries(args.entries)
        existed = {path.name for path in entries.glob("*.json")} if entries.is_dir() else set()
        path = leaderboard.submit(Path(args.results), args.localizer, entries,
                                  name=args.name, version=args.version, authors=args.authors,
                                  link=args.link, overwrite=args.overwrite,
                                  datasets=_datasets(args))
        print(f"wrote {path}")
        _warn_if_alone(path, bool(existed - {path.name}))
    elif args.action == "build":
        entries = _entries(args.entries)
        out = Path(args.out) if args.out is not None else entries.parent
        board.claim_board_folder(out, args.overwrite)
        for path in board.build(entries, out, _results_dir(args.navigation, entries,
                                                           "navigation"),
                                datasets=_datasets(args),
                                skip_unavailable=args.skip_unavailable,
                                progress=progress_printer(),
                                mapping_dir=_results_dir(args.mapping, entries, "mapping")):
            print(f"wrote {path}")
        from azgym.site.drawing import figures_skipped

        if (skipped := figures_skipped(["the tables' error CDFs"])) is not None:
            print(skipped)
    elif is_mapping_file(Path(args.entry)):
        print(f"{args.entry}: rerunning its mappers (azgym's own) on its cases", flush=True)
        differences = verify_mapping(Path(args.entry), workers=resolve_workers(args),
                                     progress=progress_printer())
        return _verdict(args.entry, differences)
    elif is_navigation_file(Path(args.entry)):
        print(f"{args.entry}: rerunning its navigators and localizers (azgym's own)", flush=True)
        differences = verify_navigation(Path(args.entry), workers=resolve_workers(args))
        return _verdict(args.entry, differences)
    else:
        entry = leaderboard.load_entry(Path(args.entry), _datasets(args))
        test = entry["split"] == "test"
        where = "on a fresh secret seed" if test else "on its own frames"
        spec = entry["localizer"]["spec"]
        whose = "azgym's own" if is_builtin(spec) else "the submitter's code"
        print(f"{args.entry}: rerunning its localizer {spec!r}, which is {whose}, {where}",
              flush=True)
        differences = leaderboard.verify(Path(args.entry), workers=resolve_workers(args),
                                         progress=progress_printer(),
                                         datasets=_datasets(args))
        return _verdict(args.entry, differences, test)
    return 0


def find_entries(start: Path) -> Path | None:
    """The board's entries folder (:data:`BOARD`) in ``start`` or the nearest folder above it."""
    start = start.resolve()
    return next((folder / BOARD for folder in (start, *start.parents)
                 if (folder / BOARD).is_dir()), None)


def _entries(named: str | None) -> Path:
    """``--entries``: the folder named, else the board found from here (said), else refused."""
    if named is not None:
        return Path(named)
    found = find_entries(Path.cwd())
    if found is None:
        raise InvalidInputError(
            f"--entries: no {BOARD}/ in {Path.cwd()} or any folder above it, so no board to "
            "use; run this inside azgym's repository (its leaderboard/ holds the reference "
            "entries), or give --entries DIR to start a board of your own there")
    print(f"board: {found} (--entries names another)", flush=True)
    return found


def _warn_if_alone(path: Path, others: bool) -> None:
    """Warn when a submitted entry will stand alone in its table on the board."""
    from azgym.bench.leaderboard.entries import table_mates
    from azgym.bench.leaderboard.entry_files import read_json

    entry = read_json(path, "leaderboard entry")
    warnings = []
    if entry["quick"]:
        warnings.append(f"{entry['name']} is a quick run: the board ranks it apart from the "
                        "full-size runs, the reference entries' (rerun azgym bench without "
                        "--quick to rank beside them)")
    if not table_mates(path):
        size = "quick" if entry["quick"] else "full"
        warnings.append(f"{path.parent} has no other entry on {entry['suite']} ({entry['split']}"
                        f" split, {size} size): {entry['name']} will be alone in its table" +
                        ("" if others else f"; {path.parent} held no entries: this is a new "
                         "board, and azgym's reference entries are in its repository's "
                         "leaderboard/entries/ (--entries)"))
    for warning in warnings:
        print(f"azgym: warning: {warning}", file=sys.stderr)


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


def _results_dir(named: str | None, entries: Path, option: str) -> Path | None:
    """A results folder (``--navigation``, ``--mapping``): the one named, which must exist.

    Not named: the folder of the option's name beside the entries, if there is one.
    """
    from azgym.bench.leaderboard.entry_files import LeaderboardError

    if named is None:
        beside = entries.parent / option
        return beside if beside.is_dir() else None
    if not Path(named).is_dir():
        raise LeaderboardError(f"--{option} {named}: no such folder")
    return Path(named)
