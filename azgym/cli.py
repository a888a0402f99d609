"""azgym: benchmark azimuth-based indoor localizers, and reproduce the papers they come from.

azgym bench [--suite S] [--localizer SPEC ...] [--with-builtins] [--split dev|test]
            [--workers N] [--time-limit SECONDS] [--quick] [--out DIR]
azgym leaderboard submit|build|verify ...
azgym reproduce paper [--quick] [--out DIR] [--workers N] [--seed S] [--no-figures]
azgym reproduce plotter [--runs N] [--seed S] [--out DIR]
azgym study error-model [--scenario S] [--frames N] [--noise SIGMA] [--calibration-px PX]
azgym study ids [--scenario S] [--rate HZ] [--noise SIGMA]
azgym scenarios
azgym localizers
azgym check SPEC
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from azgym.bench.isolation import DEFAULT_TIME_LIMIT
from azgym.errors import AzgymError

if TYPE_CHECKING:
    from azgym.bench.contenders import Contender


def _reproduce_paper(args: argparse.Namespace) -> int:
    from azgym.bench.runner import default_workers
    from azgym.bench.suites.paper import ProtocolConfig
    from azgym.experiments.paper.report import write_outputs
    from azgym.experiments.paper.reproduce import reproduce, time_exhaustive_mex
    from azgym.site import load_scenario

    config = ProtocolConfig.quick(seed=args.seed) if args.quick else ProtocolConfig(seed=args.seed)
    workers = args.workers or default_workers()
    print(f"Reproducing Rátosi & Simon (2021) Sec. 3: grid step {config.grid_step} m, "
          f"{config.realisations} realisations, K in {config.outlier_counts}, "
          f"{workers} worker(s)", flush=True)
    started = time.perf_counter()
    reproduction = reproduce(config=config, workers=workers,
                             progress=lambda line: print(line, flush=True))
    mex_seconds = time_exhaustive_mex(load_scenario("paper-room"), repeats=1 if args.quick else 3)
    reproduction.results["mex_exhaustive_ms"] = mex_seconds * 1000
    written = write_outputs(reproduction, Path(args.out), figures=not args.no_figures)
    print(f"\nExhaustive 1 cm MEX: {mex_seconds * 1000:.0f} ms per estimate")
    print(f"Done in {time.perf_counter() - started:.0f} s. Wrote:")
    for path in written:
        print(f"  {path}")
    print()
    print((Path(args.out) / "results.md").read_text(encoding="utf-8"))
    return 0


DEFAULT_SUITE = "warehouse-static"


def _reproduce_plotter(args: argparse.Namespace) -> int:
    from azgym.experiments.plotter.figure import write_figure
    from azgym.experiments.plotter.reproduce import reproduce_plotter
    from azgym.files import prepare_folder, write_file

    out = Path(args.out)
    prepare_folder(out)
    result = reproduce_plotter(seed=args.seed, runs=args.runs)
    summary = {key: value for key, value in result.items() if key != "errors"}
    written = [write_file(out / "results.json", json.dumps(summary, indent=1) + "\n"),
               write_figure(result, out / "errors.png")]
    print(f"{args.runs} runs of a {result['lap_s']:g} s lap, seed {args.seed}: 90th percentile "
          "of the position error")
    for method, p90 in result["p90"].items():
        paper = " (paper: < 2.6 cm)" if method == "lpkf" else ""
        print(f"  {method:<6} {100 * p90:8.2f} cm{paper}")
    print(f"  naive after 40 s: {result['naive_at_40s']:.1f} m (paper: 10 m)")
    print("wrote " + ", ".join(map(str, written)))
    return 0


def _bench(args: argparse.Namespace) -> int:
    from azgym.bench.runner import default_workers, run_benchmark
    from azgym.bench.suites import get_suite
    from azgym.bench.table import ranked_table, tracking_table
    from azgym.files import prepare_folder

    # With no suite named, the default suite runs in its quick size: the README's main job.
    quick = args.quick or args.suite is None
    suite = get_suite(args.suite or DEFAULT_SUITE)
    contenders = _contenders(args.localizer, args.with_builtins, args.time_limit)
    workers = args.workers or default_workers()
    prepare_folder(Path(args.out))  # before the run: a bad --out must not waste it
    started = time.perf_counter()
    result = run_benchmark(suite, contenders, split=args.split, quick=quick, workers=workers,
                           time_limit=args.time_limit, progress=_progress_printer())
    written = result.write(Path(args.out))
    print()
    print(ranked_table(result.summary))
    if tracks := tracking_table(result.summary):
        print(f"\n{tracks}")
    print(f"\n{time.perf_counter() - started:.1f} s; wrote {', '.join(map(str, written))}")
    return 0


def _contenders(specs: Sequence[str], with_builtins: bool,
                time_limit: float = DEFAULT_TIME_LIMIT) -> list[Contender]:
    """The contenders ``--localizer`` names (every built-in if none), each built once first.

    A bad name, spec or hyperparameter stops the command here, before any frame is drawn,
    rather than scoring a localizer that cannot run as failing every frame. Each is built in a
    worker process, as the run would build it, within the time limit.
    """
    from azgym.bench.contenders import (
        check_buildable,
        contender,
        default_contenders,
        with_defaults,
    )

    named: dict[str, Contender] = {}  # by label: a localizer named twice runs once
    for candidate in map(contender, specs):
        named.setdefault(candidate.label, candidate)
    for candidate in named.values():
        check_buildable(candidate, time_limit)
    if not named:
        return default_contenders()
    return with_defaults(named.values()) if with_builtins else list(named.values())


def _leaderboard(args: argparse.Namespace) -> int:
    from azgym.bench import board, leaderboard

    if args.action == "submit":
        path = leaderboard.submit(Path(args.results), args.localizer, Path(args.entries),
                                  name=args.name, version=args.version, authors=args.authors,
                                  link=args.link, overwrite=args.overwrite)
        print(f"wrote {path}")
    elif args.action == "build":
        for path in board.build(Path(args.entries), Path(args.out)):
            print(f"wrote {path}")
    else:
        spec = leaderboard.load_entry(Path(args.entry))["localizer"]["spec"]
        print(f"{args.entry}: rerunning its localizer {spec!r}, which is the submitter's code",
              flush=True)
        differences = leaderboard.verify(Path(args.entry), workers=args.workers or 1)
        if differences:
            for key, (claimed, fresh) in differences.items():
                print(f"{key}: entry {claimed}, rerun {fresh}")
            print(f"{args.entry}: NOT reproduced")
            return 1
        print(f"{args.entry}: reproduced (every accuracy figure within 1e-6)")
    return 0


def _progress_printer():
    """Print progress: a bar redrawn in place on a terminal, only finished lines otherwise."""
    terminal = sys.stdout.isatty()

    def show(text: str) -> None:
        if not text.startswith("\r"):
            print(("\r" if terminal else "") + text, flush=True)
        elif terminal:
            print(text, end="", flush=True)

    return show


def _study_error_model(args: argparse.Namespace) -> int:
    from azgym.experiments.error_model import run

    summary = run(args.scenario, frames=args.frames, noise_sigma=args.noise,
                  calibration_px=args.calibration_px, seed=args.seed, out=Path(args.out),
                  figures=not args.no_figures)
    centre, azimuth = summary["centre_error_px"], summary["azimuth_error_deg"]
    calibrated = summary["azimuth_error_calibrated_deg"]
    print(f"{summary['scenario']}: {summary['detections']} beacon detections in "
          f"{args.frames} frames (noise {args.noise} grey levels)")
    print(f"  eq. 1 model: centre error ±{summary['model_center_error_px']:.2f} px, "
          f"Δα_d = {summary['model_delta_alpha_d_deg']:.3f}°")
    print(f"  centre error [px]:         mean {centre['mean']:.3f}, p95 {centre['p95']:.3f}, "
          f"max {centre['max']:.2f}")
    print(f"  azimuth error [deg]:       mean {azimuth['mean']:.4f}, p95 {azimuth['p95']:.4f}; "
          f"{100 * summary['azimuth_error_within_model']:.1f} % within Δα_d")
    print(f"  with the principal point {args.calibration_px:g} px off: mean "
          f"{calibrated['mean']:.3f}, p95 {calibrated['p95']:.3f}; "
          f"{100 * summary['calibrated_within_model']:.1f} % within Δα_d")
    if summary["coverage_over_eq2_bound"]:
        print(f"  coverage error / eq. 2 bound ({summary['partly_covered']} partly covered): "
              f"median {summary['coverage_over_eq2_bound']['median']:.2f}, max "
              f"{summary['coverage_over_eq2_bound']['max']:.2f}")
    print(f"Wrote {args.out}/error_model.json" + ("" if args.no_figures else
                                                  f" and {args.out}/error_model.png"))
    return 0


def _study_ids(args: argparse.Namespace) -> int:
    from azgym.experiments.identification import measure_identification
    from azgym.sensing.image.blink_code import BLINK_CAMERA_RATE_HZ

    stats = measure_identification(args.scenario, camera_rate_hz=args.rate or BLINK_CAMERA_RATE_HZ,
                                   noise_sigma=args.noise, seed=args.seed)
    print(f"{stats.scenario}, every route, camera {stats.camera_rate_hz:g} Hz, noise "
          f"{stats.noise_sigma:g} grey levels: {stats.frames} frames")
    print(f"  beacons in view for a whole codeword: {stats.eligible} blobs; right id "
          f"{100 * stats.correct_share:.2f} %, no id "
          f"{100 * stats.unidentified / max(1, stats.eligible):.2f} %, wrong id "
          f"{100 * stats.misidentified / max(1, stats.eligible):.2f} %")
    print(f"  every blob with an id: {stats.with_id}; wrong {stats.wrong_id} "
          f"({100 * stats.misdecode_rate:.2f} %)")
    return 0


def _scenarios(_args: argparse.Namespace) -> int:
    from azgym.site import list_scenarios, load_scenario

    for name in list_scenarios():
        print(f"{name:<20} {load_scenario(name).description}")
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
    from azgym.localize.registry import make_localizer

    check_localizer(make_localizer(args.localizer))  # raises (exit code 2) on a failed check
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
    _add_leaderboard(commands)
    _add_reproduce(commands)
    _add_study(commands)
    _add_listings(commands)
    return parser


def _seconds(text: str) -> float:
    """A command-line duration: a finite number of seconds > 0."""
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError(f"must be a number of seconds > 0, got {text!r}")
    return value


def _add_bench(commands: argparse._SubParsersAction) -> None:
    """``azgym bench``: score localizers on a suite."""
    from azgym.bench.contenders import DEFAULT_SPECS

    bench = commands.add_parser("bench", help="score localizers on a benchmark suite")
    bench.add_argument("--suite", help=f"suite name (default: {DEFAULT_SUITE}, quick)")
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
    bench.add_argument("--workers", type=int, default=0, help="processes (0: one per core)")
    bench.add_argument("--time-limit", type=_seconds, default=DEFAULT_TIME_LIMIT,
                       metavar="SECONDS",
                       help="time a localizer may take on one frame (or to be built); a frame "
                            "over it is scored unavailable")
    bench.add_argument("--quick", action="store_true", help="the suite's small version")
    bench.add_argument("--out", default="results/bench", help="output folder")
    bench.set_defaults(handler=_bench)


def _add_leaderboard(commands: argparse._SubParsersAction) -> None:
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
    build = actions.add_parser("build", help="write leaderboard/README.md and index.html")
    build.add_argument("--entries", default="leaderboard/entries")
    build.add_argument("--out", default="leaderboard")
    verify = actions.add_parser("verify", help="rerun an entry and compare its figures")
    verify.add_argument("entry", help="path of the entry's .json")
    verify.add_argument("--workers", type=int, default=1)
    board.set_defaults(handler=_leaderboard)


def _add_reproduce(commands: argparse._SubParsersAction) -> None:
    """``azgym reproduce paper``: the paper's Sec. 3 study."""
    reproduce = commands.add_parser("reproduce", help="reproduce a paper's study")
    target = reproduce.add_subparsers(dest="target", required=True)
    paper = target.add_parser("paper", help="Rátosi & Simon (2021), Sec. 3")
    paper.add_argument("--quick", action="store_true",
                       help="every other grid point, 2 realisations (about a minute)")
    paper.add_argument("--out", default="results/paper", help="output folder")
    paper.add_argument("--workers", type=int, default=0, help="worker processes (0: one per core)")
    paper.add_argument("--seed", type=int, default=2021, help="seed of every random draw")
    paper.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    paper.set_defaults(handler=_reproduce_paper)
    plotter = target.add_parser("plotter", help="Dang et al. (2015): TKF and LPKF on a square")
    plotter.add_argument("--runs", type=int, default=100, help="simulated runs of one lap")
    plotter.add_argument("--seed", type=int, default=0, help="seed of every random draw")
    plotter.add_argument("--out", default="results/plotter", help="output folder")
    plotter.set_defaults(handler=_reproduce_plotter)


def _add_study(commands: argparse._SubParsersAction) -> None:
    """``azgym study error-model|ids``: check azgym's models against what they model."""
    study = commands.add_parser("study", help="check azgym's models against what they model")
    studies = study.add_subparsers(dest="study", required=True)
    model = studies.add_parser("error-model", help="azimuth errors of beacons detected from "
                               "pixels beside the paper's eq. 1-3")
    model.add_argument("--scenario", default="warehouse-small")
    model.add_argument("--frames", type=int, default=600, help="random poses")
    model.add_argument("--noise", type=float, default=2.0, help="sensor noise [grey levels]")
    model.add_argument("--calibration-px", type=float, default=1.0,
                       help="principal point error for the calibrated comparison [px]")
    model.add_argument("--seed", type=int, default=0)
    model.add_argument("--out", default="results/study", help="output folder")
    model.add_argument("--no-figures", action="store_true")
    model.set_defaults(handler=_study_error_model)
    ids = studies.add_parser("ids", help="how well blinking ids decode along the routes")
    ids.add_argument("--scenario", default="warehouse-small")
    ids.add_argument("--rate", type=float, default=None,
                     help="camera frames per second (default: the blinking camera's 30)")
    ids.add_argument("--noise", type=float, default=2.0, help="sensor noise [grey levels]")
    ids.add_argument("--seed", type=int, default=0)
    ids.set_defaults(handler=_study_ids)


def _add_listings(commands: argparse._SubParsersAction) -> None:
    """``azgym scenarios``, ``azgym localizers``: what ships with azgym; ``azgym check``."""
    commands.add_parser("scenarios", help="list the shipped scenarios").set_defaults(
        handler=_scenarios)
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
