"""azgym: benchmark azimuth-based indoor localizers, and reproduce the papers they come from.

azgym bench [--suite S | --data DIR] [--localizer SPEC ...] [--with-builtins] [--split dev|test]
            [--workers N] [--time-limit SECONDS] [--quick] [--out DIR] [--navigator NAME ...]
            [--backend local|ray] [--address ADDR] [--profile PROFILE.toml]
azgym sweep CONFIG [--backend local|ray] [--address ADDR] [--workers N] [--out DIR]
azgym import DIR
azgym calibrate LOG --out PROFILE.toml [--figure FILE] [--turn-rate auto|odometry|imu] [--seed N]
                [--overwrite]
azgym export route --scenario S [--route R] [--seed N] --out DIR [--name NAME] [--motion-rate HZ]
azgym layout analyze SCENARIO [--step M] [--localizer L] [--frames N] [--seed S] [--workers N]
                      [--time-limit SECONDS] [--out DIR]
azgym layout optimize SCENARIO --add N [--step M] [--spacing M] [--out DIR]
azgym leaderboard submit|build|verify ...
azgym reproduce paper [--quick] [--out DIR] [--workers N] [--seed S] [--no-figures]
azgym reproduce plotter [--runs N] [--seed S] [--out DIR]
azgym study error-model [--scenario S] [--frames N] [--noise SIGMA] [--calibration-px PX]
azgym study ids [--scenario S] [--rate HZ] [--noise SIGMA]
azgym scenarios
azgym generate --seed N [--out FILE.toml] [--size X Y]
azgym localizers
azgym check SPEC
azgym train localizer --model ng-ransac|learned --out DIR [--layouts N] [--frames-per-layout N]
                      [--epochs N] [--seed S] [--hidden H] [--threads N]
azgym train navigator --env ID --algo ppo|sac --out DIR [--steps N] [--seed S] [--localizer L]
                      [--envs N] [--threads N]
azgym evaluate navigator POLICY [--env ID] [--localizer L ...] [--episodes N] [--seed S]
                         [--sensor geometry|image] [--ids oracle|blink] [--out DIR]
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from azgym.bench.run.isolation import DEFAULT_TIME_LIMIT
from azgym.cli_calibrate import add_calibrate
from azgym.cli_evaluate import add_evaluate
from azgym.cli_layout import add_layout
from azgym.cli_leaderboard import add_leaderboard
from azgym.cli_logs import add_logs
from azgym.cli_options import (
    check_backend,
    out_folder,
    profile_option,
    read_profile_option,
    resolve_workers,
    seconds_option,
    workers_option,
)
from azgym.cli_studies import add_reproduce, add_study
from azgym.cli_sweep import add_backend_options, add_sweep
from azgym.cli_train import add_train
from azgym.errors import AzgymError, InvalidInputError

if TYPE_CHECKING:
    from azgym.bench.run.contenders import Contender
    from azgym.profile import Profile


DEFAULT_SUITE = "warehouse-static"


def _bench(args: argparse.Namespace) -> int:
    from azgym.bench.navigation.suites import NAVIGATION_SUITES
    from azgym.bench.report.table import run_report
    from azgym.bench.run.runner import run_benchmark
    from azgym.bench.suites import SUITES
    from azgym.errors import unknown_name
    from azgym.files import prepare_folder

    check_backend(args)
    profile = read_profile_option(args)
    if args.data is not None:
        from azgym.cli_logs import bench_data

        return bench_data(args, _progress_printer(), profile)
    if args.suite in NAVIGATION_SUITES:
        from azgym.cli_navigation import bench_navigation

        return bench_navigation(args, _progress_printer())
    if args.navigator:
        raise InvalidInputError(f"--navigator is for the navigation suites "
                                f"({', '.join(NAVIGATION_SUITES)})")
    if args.suite is not None and args.suite not in SUITES:
        raise unknown_name("suite", args.suite, [*SUITES, *NAVIGATION_SUITES])
    # With no suite named, the default suite runs in its quick size: the README's main job.
    quick = args.quick or args.suite is None
    suite = SUITES[args.suite or DEFAULT_SUITE]
    if profile is not None:
        suite.check_profile(profile)
    if args.time_limit is None:
        args.time_limit = DEFAULT_TIME_LIMIT
    contenders = _contenders(args.localizer, args.with_builtins, args.time_limit, profile)
    workers = resolve_workers(args)
    prepare_folder(Path(args.out))  # before the run: a bad --out must not waste it
    started = time.perf_counter()
    result = run_benchmark(suite, contenders, split=args.split, quick=quick, workers=workers,
                           time_limit=args.time_limit, progress=_progress_printer(),
                           backend=args.backend, address=args.address, profile=profile)
    written = result.write(Path(args.out))
    print(run_report(result.summary, time.perf_counter() - started, written))
    return 0


def _contenders(specs: Sequence[str], with_builtins: bool,
                time_limit: float = DEFAULT_TIME_LIMIT,
                profile: Profile | None = None) -> list[Contender]:
    """The contenders ``--localizer`` names (every built-in if none), each built once first.

    A bad name, spec or hyperparameter stops the command here, before any frame is drawn,
    rather than scoring a localizer that cannot run as failing every frame. Each is built in a
    worker process, as the run would build it, within the time limit; with a profile, the
    built-ins too (with the profile's defaults).
    """
    from azgym.bench.run.contenders import (
        check_buildable,
        contender,
        with_defaults,
    )

    named: dict[str, Contender] = {}  # by label: a localizer named twice runs once
    for candidate in map(contender, specs):
        named.setdefault(candidate.label, candidate)
    chosen = list(named.values()) if named and not with_builtins else \
        with_defaults(named.values())
    for candidate in chosen:  # a built-in may refuse a profile's value: said before the run
        if candidate.label in named or profile is not None:
            check_buildable(candidate, time_limit, profile)
    return chosen


def _progress_printer():
    """Print progress: a bar redrawn in place on a terminal, only finished lines otherwise."""
    terminal = sys.stdout.isatty()

    def show(text: str) -> None:
        if not text.startswith("\r"):
            print(("\r" if terminal else "") + text, flush=True)
        elif terminal:
            print(text, end="", flush=True)

    return show


def _scenarios(_args: argparse.Namespace) -> int:
    from azgym.site import list_scenarios, load_scenario

    for name in list_scenarios():
        print(f"{name:<20} {load_scenario(name).description}")
    return 0


def _generate(args: argparse.Namespace) -> int:
    from azgym.site.generator import write_generated

    path = Path(args.out or f"generated-{args.seed}.toml")
    scenario = write_generated(path, args.seed, size=args.size)
    print(f"wrote {path}: {scenario.description} (loads back to the same scenario)")
    return 0


def _localizers(_args: argparse.Namespace) -> int:
    from azgym.localize.registry import PRESETS, build, list_localizers, list_trackers

    for name in list_localizers():
        if name in PRESETS:
            target, params = PRESETS[name]
            pairs = ",".join(f"{key}={json.dumps(value)}" for key, value in params.items())
            print(f"{name:<16} {target} with {pairs}")
            continue
        doc = (type(build(name)).__doc__ or "").strip().splitlines()
        print(f"{name:<16} {doc[0] if doc else ''}")
    print("\ntrackers (any localizer above runs as one too):")
    for name in list_trackers():
        doc = (type(build(name)).__doc__ or "").strip().splitlines()
        print(f"{name:<16} {doc[0] if doc else ''}")
    return 0


def _check(args: argparse.Namespace) -> int:
    from azgym.localize.checks import check_localizer
    from azgym.localize.registry import SupportsLocalize, build
    from azgym.track.checks import check_tracker

    built = build(args.localizer)  # raises (exit code 2) on a failed check, as the checks do
    if isinstance(built, SupportsLocalize):
        check_localizer(built)
    else:
        check_tracker(built)
    return 0


class _DefaultsFormatter(argparse.HelpFormatter):
    """Help that ends each option with its default, unless the text says it or there is none."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if (not action.option_strings or "default" in text
                or action.default in (None, False, [], argparse.SUPPRESS)):
            return text
        return f"{text} (default: %(default)s)"


class _Parser(argparse.ArgumentParser):
    """An argument parser whose ``--help`` shows every option's default."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", _DefaultsFormatter)
        super().__init__(*args, **kwargs)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``azgym`` command."""
    from azgym._version import __version__

    parser = _Parser(prog="azgym", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"azgym {__version__}")
    commands = parser.add_subparsers(dest="command", required=True)
    _add_bench(commands)
    add_leaderboard(commands)
    add_reproduce(commands)
    add_study(commands)
    add_train(commands)
    add_evaluate(commands)
    add_logs(commands)
    add_calibrate(commands)
    add_layout(commands)
    add_sweep(commands)
    _add_listings(commands)
    return parser


def _add_bench(commands: argparse._SubParsersAction) -> None:
    """``azgym bench``: score localizers on a suite."""
    from azgym.bench.run.contenders import DEFAULT_SPECS

    bench = commands.add_parser("bench", help="score localizers on a benchmark suite")
    bench.add_argument("--suite", help=f"suite name (default: {DEFAULT_SUITE}, quick); the "
                                       "closed-loop suites: navigation, navigation-image")
    bench.add_argument("--localizer", action="append", default=[], metavar="SPEC",
                       help="a localizer: NAME, package.module:Class or path/file.py:Class, "
                            "then optionally :NAME=VALUE,... hyperparameters (JSON scalars), "
                            "e.g. ransac:weighted=true; repeatable; every result is labelled "
                            "by the spec that rebuilds it (default: the built-ins: "
                            f"{', '.join(DEFAULT_SPECS)})")
    bench.add_argument("--with-builtins", action="store_true",
                       help="run the default built-ins too (naming a --localizer otherwise runs "
                            "only the ones named, and ransac as the runtime reference)")
    bench.add_argument("--split", choices=("dev", "test"), default="dev",
                       help="dev: the suite's fixed seed; test: a fresh seed, reported")
    bench.add_argument("--workers", type=workers_option, default=0,
                       help="processes (0: one per core)")
    bench.add_argument("--time-limit", type=seconds_option, default=None, metavar="SECONDS",
                       help="time a localizer may take on one frame (or to be built); a frame "
                            f"over it is scored unavailable (default: {DEFAULT_TIME_LIMIT:g}; "
                            "frame suites only)")
    add_backend_options(bench, " (frame suites)")
    bench.add_argument("--navigator", action="append", default=[], metavar="NAME",
                       help="navigation suites: who drives, 'pure-pursuit' or 'ppo' (the "
                            "shipped policy); repeatable (default: both)")
    bench.add_argument("--data", metavar="DIR", help="score on a log of bearing data instead of "
                                                     "a suite (docs/logs.md)")
    bench.add_argument("--profile", type=profile_option, metavar="PROFILE.toml",
                       help="a profile (docs/logs.md): every contender's defaults (a spec's own "
                            "win), a suite's simulated noise, or fields over a log's own")
    bench.add_argument("--quick", action="store_true", help="the suite's small version")
    bench.add_argument("--out", type=out_folder, default="results/bench", help="output folder")
    bench.set_defaults(handler=_bench)


def _add_listings(commands: argparse._SubParsersAction) -> None:
    """``azgym scenarios``, ``azgym localizers``: what ships; ``azgym generate``, ``check``."""
    commands.add_parser("scenarios", help="list the shipped scenarios").set_defaults(
        handler=_scenarios)
    generate = commands.add_parser("generate", help="write a procedurally generated warehouse")
    generate.add_argument("--seed", type=int, required=True, help="the same seed, the same site")
    generate.add_argument("--out", metavar="FILE.toml",
                          help="the scenario file to write (default: generated-SEED.toml)")
    generate.add_argument("--size", type=float, nargs=2, metavar=("X", "Y"),
                          help="the room's east-west and north-south sides [m] (default: drawn)")
    generate.set_defaults(handler=_generate)
    commands.add_parser("localizers", help="list the registered localizers and presets"
                        ).set_defaults(handler=_localizers)
    check = commands.add_parser("check", help="run the conformance checks on a localizer")
    check.add_argument("localizer", metavar="SPEC",
                       help="as for bench --localizer, e.g. path/mine.py:Mine:max_iter=20")
    check.set_defaults(handler=_check)


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``azgym`` command."""
    args = build_parser().parse_args(argv)
    try:
        return int(args.handler(args))
    except AzgymError as exc:
        print(f"azgym: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
