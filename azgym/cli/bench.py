"""``azgym bench``: score localizers on a frame suite, a navigation suite or a log; mappers.

One command, four runners, chosen by what is named: a frame suite (``--suite``, by default
:data:`DEFAULT_SUITE` in its quick size) through :func:`~azgym.bench.run.runner.run_benchmark`;
a navigation suite (:mod:`azgym.bench.navigation.suites`), run like a frame suite —
``--localizer``, ``--with-builtins``, ``--split``, ``--quick``, ``--workers``, ``--out`` mean the
same — with ``--navigator`` naming who drives; a log of bearing data (``--data DIR``,
docs/logs.md), scored as a suite is; or, as ``azgym bench mapping``, the mapping suite's
mappers (``--mapper``, :func:`~azgym.bench.mapping.benchmark.run_mapping`), where ``--quick``,
``--time-limit``, ``--workers``, ``--out`` and ``--overwrite`` mean the same, before or after
``mapping``. Which runner takes which of the options that are not everyone's is one table
(:data:`RUNNERS`), checked by :func:`check_options`. Who runs is the
library's one rule (:func:`~azgym.bench.run.contenders.resolve_contenders`); each runner's result
writes its own files.
"""

from __future__ import annotations

import argparse
import textwrap
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, TypeVar

from azgym.cli.options import (
    add_backend_options,
    add_overwrite,
    check_backend,
    on_ctrl_c,
    out_folder,
    profile_option,
    progress_printer,
    resolve_workers,
    seconds_option,
    workers_option,
)
from azgym.errors import InvalidInputError

if TYPE_CHECKING:
    from azgym.bench.run.contenders import Contender
    from azgym.bench.run.runner import Progress
    from azgym.profile import Profile

__all__ = ["BENCH_FILES", "DEFAULT_OUT", "DEFAULT_SUITE", "OPTIONS", "RUNNERS", "Runner",
           "add_bench", "check_options"]

T = TypeVar("T")

DEFAULT_OUT = Path("results/bench")
"""Where a run's results go unless ``--out`` says: a folder per suite and size, or log."""
DEFAULT_SUITE = "warehouse-static"
"""The suite ``azgym bench`` runs, in its quick size, when none is named."""

BENCH_FILES = ("results.json", "frames.csv", "cdf.png", "causes.png", "error_map_*.png",
               "trajectories_*.png", "trajectories/*/*.tum")
"""What a frame suite's or a log's run writes into ``--out``
(:meth:`~azgym.bench.report.results.BenchResult.write`): refused there without ``--overwrite``."""

OPTIONS: dict[str, tuple[str, object]] = {
    "--suite": ("suite", None), "--navigator": ("navigator", []), "--quick": ("quick", False),
    "--split": ("split", "dev"), "--time-limit": ("time_limit", None),
    "--backend": ("backend", "local"), "--address": ("address", None),
    "--profile": ("profile", None)}
"""The options that not every runner takes: each one's attribute and its value when not given."""


@dataclass(frozen=True)
class Runner:
    """One of ``azgym bench``'s runners: which options of :data:`OPTIONS` it takes, and why.

    Attributes:
        name: The runner, as an error names it.
        takes: The options of :data:`OPTIONS` it takes.
        reason: Why it takes no other: a sentence with ``{either}`` (the options it refuses,
            joined by "or"), ``{each}`` (joined by "and") and ``{navigation_suites}``.
    """

    name: str
    takes: frozenset[str]
    reason: str

    def refuses(self) -> list[str]:
        """The options of :data:`OPTIONS` it does not take, in their order there."""
        return [option for option in OPTIONS if option not in self.takes]


RUNNERS = {
    "frame": Runner("a frame suite", frozenset(
        {"--suite", "--quick", "--split", "--time-limit", "--backend", "--address", "--profile"}),
        "{each} is for the navigation suites ({navigation_suites})"),
    "navigation": Runner("a navigation suite", frozenset(
        {"--suite", "--navigator", "--quick", "--split"}),
        "a navigation suite runs each localizer with its own defaults, in local processes, in "
        "the loop that drives the forklift: it takes no {either}"),
    "data": Runner("a log (--data)", frozenset({"--time-limit", "--profile"}),
                   "--data scores a log in local worker processes: it takes no {either}"),
    "mapping": Runner("azgym bench mapping", frozenset({"--quick", "--time-limit"}),
                      "it runs the mapping suite's dev split (its routes are public) with each "
                      "mapper's own defaults, in local worker processes: it takes no {either}"),
}
"""``azgym bench``'s runners: a frame suite, a navigation suite, a log, the mapping suite."""


def check_options(runner: str, args: argparse.Namespace) -> None:
    """Refuse the first option given that ``RUNNERS[runner]`` does not take, naming both.

    Raises:
        InvalidInputError: An option of :data:`OPTIONS` given (not at its default) that the
            runner does not take.
    """
    from azgym.bench.navigation.suites import NAVIGATION_SUITES

    chosen = RUNNERS[runner]
    refused = chosen.refuses()
    for option in refused:
        attribute, unset = OPTIONS[option]
        if getattr(args, attribute) != unset:
            reason = chosen.reason.format(
                either=_listed(refused, "or"), each=_listed(refused, "and"),
                navigation_suites=", ".join(NAVIGATION_SUITES))
            raise InvalidInputError(f"{option} is not for {chosen.name}: {reason}")


def _listed(options: list[str], conjunction: str) -> str:
    """``a``, ``a and b``, ``a, b or c``: the options as a sentence lists them."""
    if len(options) == 1:
        return options[0]
    return f"{', '.join(options[:-1])} {conjunction} {options[-1]}"


def add_bench(commands: argparse._SubParsersAction) -> None:
    """``azgym bench``: score localizers on a suite."""
    from azgym.bench.run.contenders import DEFAULT_SPECS
    from azgym.bench.run.isolation import DEFAULT_TIME_LIMIT

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
    bench.add_argument("--out", type=out_folder, metavar="DIR",
                       help=f"output folder (default: {DEFAULT_OUT}/SUITE, SUITE-quick for a quick "
                            "run, data-LOG for a log)")
    add_overwrite(bench, "a previous run's results in --out")
    bench.set_defaults(handler=_bench)
    _add_mapping(bench.add_subparsers(
        dest="runner", metavar="mapping", help="mapping: score mappers on the mapping suite "
        "instead (azgym bench mapping --help); without it, localizers on --suite or --data"))


def _add_mapping(runners: argparse._SubParsersAction) -> None:
    """``azgym bench mapping``; the options it shares with bench default to bench's (SUPPRESS)."""
    from azgym.bench.run.isolation import DEFAULT_TIME_LIMIT
    from azgym.mapping.registry import DEFAULT_MAPPERS

    mapping = runners.add_parser("mapping", help="score mappers (beacon maps surveyed and "
                                 "repaired from a drive) on the mapping suite",
                                 argument_default=argparse.SUPPRESS)
    mapping.add_argument("--mapper", action="append", metavar="SPEC",
                         help="a mapper: NAME, package.module:Class or path/file.py:Class, then "
                              "optionally :NAME=VALUE,... hyperparameters; repeatable (default: "
                              f"the built-ins: {', '.join(DEFAULT_MAPPERS)})")
    mapping.add_argument("--quick", action="store_true",
                         help="the suite's small version: one route per perturbation")
    mapping.add_argument("--time-limit", type=seconds_option, metavar="SECONDS",
                         help="time a mapper may take on one survey of a drive; a call over it "
                              f"is a failure (default: {DEFAULT_TIME_LIMIT:g})")
    mapping.add_argument("--workers", type=workers_option, help="processes (0: one per core)")
    mapping.add_argument("--out", type=out_folder, metavar="DIR",
                         help=f"output folder (default: {DEFAULT_OUT}/mapping, mapping-quick "
                              "for a quick run)")
    add_overwrite(mapping, "a previous run's mapping.json in --out")
    mapping.set_defaults(handler=_bench_mapping)


def _bench(args: argparse.Namespace) -> int:
    from azgym.bench.mapping.suites import MAPPING_SUITES
    from azgym.bench.navigation.suites import NAVIGATION_SUITES
    from azgym.bench.report.table import run_report
    from azgym.bench.run.isolation import DEFAULT_TIME_LIMIT
    from azgym.bench.run.runner import run_benchmark
    from azgym.bench.suites import SUITES
    from azgym.errors import unknown_name
    from azgym.profile import read_profile

    check_backend(args)
    runner = ("data" if args.data is not None
              else "navigation" if args.suite in NAVIGATION_SUITES else "frame")
    check_options(runner, args)
    profile = None if args.profile is None else read_profile(args.profile)
    if runner == "data":
        return _bench_data(args, progress_printer(), profile)
    if runner == "navigation":
        return _bench_navigation(args, progress_printer())
    if args.suite in MAPPING_SUITES:
        raise InvalidInputError(f"--suite {args.suite}: a mapping suite scores mappers: run "
                                "azgym bench mapping [--mapper SPEC ...]")
    if args.suite is not None and args.suite not in SUITES:
        raise unknown_name("suite", args.suite, [*SUITES, *NAVIGATION_SUITES])
    # With no suite named, the default suite runs in its quick size: the README's main job.
    quick = args.quick or args.suite is None
    suite = SUITES[args.suite or DEFAULT_SUITE]
    if profile is not None:
        suite.check_profile(profile)
    if args.time_limit is None:
        args.time_limit = DEFAULT_TIME_LIMIT
    progress = progress_printer()
    contenders = _contenders(args, args.time_limit, profile, progress)
    workers = resolve_workers(args)
    out = _claim(args, BENCH_FILES, f"{suite.name}{'-quick' if quick else ''}")
    started = time.perf_counter()
    result = _interruptible(lambda: run_benchmark(
        suite, contenders, split=args.split, quick=quick, workers=workers,
        time_limit=args.time_limit, progress=progress, backend=args.backend,
        address=args.address, profile=profile))
    written = result.write(out)
    print(run_report(result.summary, time.perf_counter() - started, written))
    _say_figures_skipped()
    return 0


def _claim(args: argparse.Namespace, names: tuple[str, ...], run: str) -> Path:
    """``--out`` (default ``results/bench/RUN``), made writable, once nothing is replaced unasked.

    Checked before the run (``--overwrite`` replaces), so that a bad ``--out`` wastes none.
    """
    from azgym.files import claim_folder, prepare_folder

    out = Path(args.out) if args.out is not None else DEFAULT_OUT / run
    return prepare_folder(claim_folder(out, names, args.overwrite, "--out"))


def _interruptible(run: Callable[[], T]) -> T:
    """``run()``; Ctrl-C during it says that nothing was written (results come at its end)."""
    return on_ctrl_c(run, lambda: "nothing was written: a run writes its results when it ends")


def _contenders(args: argparse.Namespace, time_limit: float, profile: Profile | None,
                progress: Progress) -> list[Contender]:
    """The contenders ``--localizer`` and ``--with-builtins`` name, each built once first.

    A bad name, spec or hyperparameter stops the command here, before any frame is drawn,
    rather than scoring a localizer that cannot run as failing every frame. Each is built in a
    worker process, as the run would build it, within the time limit; with a profile, the
    built-ins too (with the profile's defaults). The workers' fork server starts first, warming
    up the run's built-ins, so that each is compiled (on a first run) or loaded once, there.
    """
    from azgym.bench.run.contenders import check_buildable, resolve_contenders, with_reference
    from azgym.bench.run.runner import start_workers

    if args.localizer or profile is not None:  # some are built here, in workers
        run = resolve_contenders(args.localizer, with_builtins=args.with_builtins, check=None)
        start_workers(with_reference(run), "local", progress, profile)
    return resolve_contenders(args.localizer, with_builtins=args.with_builtins,
                              check=partial(check_buildable, time_limit=time_limit,
                                            profile=profile),
                              check_builtins=profile is not None)


def _bench_data(args: argparse.Namespace, progress: Progress, profile: Profile | None) -> int:
    """``azgym bench --data DIR [--profile PROFILE.toml]``: every contender on a log's frames.

    Each takes its defaults from the log's profile, with ``profile``'s fields over it.
    """
    from azgym.bench.report.table import run_report
    from azgym.bench.run.isolation import DEFAULT_TIME_LIMIT
    from azgym.bench.run.runner import run_log_benchmark
    from azgym.bench.suites.data import log_cases, log_profile
    from azgym.logs import read_log

    log = read_log(args.data)
    log_cases(log)  # a log without truth stops here, before any localizer is built
    for note in log.notes:  # what the reader changed, said before the figures it shapes
        progress(f"note: {note}")
    time_limit = DEFAULT_TIME_LIMIT if args.time_limit is None else args.time_limit
    contenders = _contenders(args, time_limit, log_profile(log, profile), progress)
    out = _claim(args, BENCH_FILES, f"data-{log.manifest.name}")
    started = time.perf_counter()
    result = _interruptible(lambda: run_log_benchmark(
        log, contenders, workers=resolve_workers(args), time_limit=time_limit,
        progress=progress, profile=profile))
    written = result.write(out)
    print(run_report(result.summary, time.perf_counter() - started, written))
    _say_figures_skipped()
    return 0


def _bench_navigation(args: argparse.Namespace, progress: Progress) -> int:
    """Run the navigation suite ``args.suite``; print the table and write ``navigation.json``."""
    from azgym.bench.navigation.benchmark import (
        check_contenders,
        navigation_contenders,
        run_navigation,
    )
    from azgym.bench.navigation.report import RESULTS_FILE
    from azgym.bench.navigation.suites import get_navigation_suite

    suite = get_navigation_suite(args.suite)
    contenders = navigation_contenders(suite, args.navigator, args.localizer,
                                       with_builtins=args.with_builtins)
    workers = resolve_workers(args)
    out = _claim(args, (RESULTS_FILE,), f"{suite.name}{'-quick' if args.quick else ''}")
    check_contenders(suite, contenders)
    started = time.perf_counter()
    result = _interruptible(lambda: run_navigation(
        suite, contenders, split=args.split, quick=args.quick, workers=workers,
        progress=progress))
    path = result.write(out)
    print()
    print(result.table())
    record = result.record
    print(f"\n{suite.name} v{suite.version}, {record['split']} split (seed {record['seed']}), "
          f"{record['episodes']} episodes each; {time.perf_counter() - started:.1f} s; "
          f"wrote {path}")
    return 0


def _bench_mapping(args: argparse.Namespace) -> int:
    """``azgym bench mapping``: every mapper on the mapping suite; its table, ``mapping.json``."""
    from azgym.bench.mapping import report
    from azgym.bench.mapping.benchmark import run_mapping
    from azgym.bench.run.isolation import DEFAULT_TIME_LIMIT
    from azgym.mapping.registry import DEFAULT_MAPPERS

    check_backend(args)
    check_options("mapping", args)
    for option, given in (("--data", args.data is not None), ("--localizer", args.localizer),
                          ("--with-builtins", args.with_builtins)):
        if given:
            raise InvalidInputError(f"{option} is not for azgym bench mapping: it scores "
                                    "mappers, named by --mapper")
    mappers = list(dict.fromkeys(getattr(args, "mapper", None) or DEFAULT_MAPPERS))
    _check_mappers(mappers)
    time_limit = DEFAULT_TIME_LIMIT if args.time_limit is None else args.time_limit
    out = _claim(args, report.MAPPING_FILES, f"{report.SUITE}{'-quick' if args.quick else ''}")
    started = time.perf_counter()
    result = _interruptible(lambda: run_mapping(
        report.SUITE, mappers, quick=args.quick, workers=resolve_workers(args),
        time_limit=time_limit, progress=progress_printer()))
    path = report.write_mapping(result, out)
    print("\n".join(["", report.score_table(result.summaries.values()), "",
                     *textwrap.wrap(report.LEGEND, 100)]))
    print(f"\n{result.suite} v{result.version}, dev split (seed {result.seed}), "
          f"{len(result.cases)} cases{', quick' if result.quick else ''}; "
          f"{time.perf_counter() - started:.1f} s; wrote {path}")
    return 0


def _check_mappers(specs: list[str]) -> None:
    """Refuse an unreadable spec, an unknown name or a built-in's bad hyperparameter now.

    A built-in is built here (azgym's code); a plug-in is built where the run builds it, in a
    worker, before any case is run (:func:`~azgym.bench.mapping.calls.build_problems`).
    """
    from azgym.mapping.registry import MAPPERS, make_mapper
    from azgym.registry import split_spec

    for spec in specs:
        target, _ = split_spec(spec, "mapper")
        if target in MAPPERS.names(plugins=False):
            make_mapper(spec)
        elif ":" not in target:
            MAPPERS.check_name(target)


def _say_figures_skipped() -> None:
    """One line when the run's figures were not drawn (no matplotlib), saying how to get them."""
    from azgym.site.drawing import figures_skipped

    figures = [name for name in BENCH_FILES if name.endswith(".png")]
    if (skipped := figures_skipped(figures)) is not None:
        print(skipped)
