"""The commands that reproduce papers and run studies: ``azgym reproduce`` and ``azgym study``.

Each handler takes the parsed arguments and returns the exit code; :mod:`azgym.cli` adds their
parsers to the ``azgym`` command.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from azgym.cli.options import (
    add_overwrite,
    out_folder,
    progress_printer,
    resolve_workers,
    workers_option,
)
from azgym.files import claim_folder

__all__ = ["add_reproduce", "add_study"]


def _reproduce_paper(args: argparse.Namespace) -> int:
    from azgym.bench.suites.paper import ProtocolConfig
    from azgym.experiments.paper.report import PAPER_FILES, write_outputs
    from azgym.experiments.paper.reproduce import reproduce, time_exhaustive_mex
    from azgym.site import load_scenario

    _figures_need_matplotlib(args.no_figures)
    claim_folder(Path(args.out), PAPER_FILES, args.overwrite, "--out")
    config = ProtocolConfig.quick(seed=args.seed) if args.quick else ProtocolConfig(seed=args.seed)
    workers = resolve_workers(args)
    print(f"Reproducing Rátosi & Simon (2021) Sec. 3: grid step {config.grid_step} m, "
          f"{config.realisations} realisations, K in {config.outlier_counts}, "
          f"{workers} worker(s)", flush=True)
    started = time.perf_counter()
    reproduction = reproduce(config=config, workers=workers,
                             progress=progress_printer())
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


def _reproduce_plotter(args: argparse.Namespace) -> int:
    from azgym.experiments.plotter import PLOTTER_FILES, reproduce_plotter, write_outputs
    from azgym.files import prepare_folder

    _figures_need_matplotlib(False)
    out = prepare_folder(claim_folder(Path(args.out), PLOTTER_FILES, args.overwrite, "--out"))
    result = reproduce_plotter(seed=args.seed, runs=args.runs, progress=progress_printer())
    written = write_outputs(result, out)
    print(f"{args.runs} runs of a {result['lap_s']:g} s lap, seed {args.seed}: 90th percentile "
          "of the position error")
    for method, p90 in result["p90"].items():
        paper = " (paper: < 2.6 cm)" if method == "lpkf" else ""
        print(f"  {method:<6} {100 * p90:8.2f} cm{paper}")
    print(f"  naive after 40 s: {result['naive_at_40s']:.1f} m (paper: 10 m)")
    print("wrote " + ", ".join(map(str, written)))
    return 0


def _study_error_model(args: argparse.Namespace) -> int:
    from azgym.experiments.error_model import ERROR_MODEL_FILES, run
    from azgym.files import prepare_folder

    _figures_need_matplotlib(args.no_figures)
    out = prepare_folder(claim_folder(Path(args.out), ERROR_MODEL_FILES, args.overwrite,
                                      "--out"))
    summary = run(args.scenario, frames=args.frames, noise_sigma=args.noise,
                  calibration_px=args.calibration_px, seed=args.seed, out=out,
                  figures=not args.no_figures, progress=progress_printer())
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
    print("Wrote " + " and ".join(str(out / name) for name in ERROR_MODEL_FILES
                                  if not (args.no_figures and name.endswith(".png"))))
    return 0


def _study_ids(args: argparse.Namespace) -> int:
    from azgym.experiments.identification import measure_identification
    from azgym.sensing.image.blink_code import BLINK_CAMERA_RATE_HZ

    stats = measure_identification(args.scenario, camera_rate_hz=args.rate or BLINK_CAMERA_RATE_HZ,
                                   noise_sigma=args.noise, seed=args.seed,
                                   progress=progress_printer())
    print(f"{stats.scenario}, every route, camera {stats.camera_rate_hz:g} Hz, noise "
          f"{stats.noise_sigma:g} grey levels: {stats.frames} frames")
    print(f"  beacons in view for a whole codeword: {stats.eligible} blobs; right id "
          f"{100 * stats.correct_share:.2f} %, no id "
          f"{100 * stats.unidentified / max(1, stats.eligible):.2f} %, wrong id "
          f"{100 * stats.misidentified / max(1, stats.eligible):.2f} %")
    print(f"  every blob with an id: {stats.with_id}; wrong {stats.wrong_id} "
          f"({100 * stats.misdecode_rate:.2f} %)")
    return 0


def add_reproduce(commands: argparse._SubParsersAction) -> None:
    """``azgym reproduce paper``: the paper's Sec. 3 study."""
    reproduce = commands.add_parser("reproduce", help="reproduce a paper's study")
    target = reproduce.add_subparsers(dest="target", required=True)
    paper = target.add_parser("paper", help="Rátosi & Simon (2021), Sec. 3")
    paper.add_argument("--quick", action="store_true",
                       help="every other grid point, 2 realisations (about a minute)")
    paper.add_argument("--out", type=out_folder, default="results/paper", help="output folder")
    add_overwrite(paper, "the results in --out")
    paper.add_argument("--workers", type=workers_option, default=0,
                       help="worker processes (0: one per core)")
    paper.add_argument("--seed", type=int, default=2021, help="seed of every random draw")
    paper.add_argument("--no-figures", action="store_true", help="skip the PNG figures")
    paper.set_defaults(handler=_reproduce_paper)
    plotter = target.add_parser("plotter", help="Dang et al. (2015): TKF and LPKF on a square")
    plotter.add_argument("--runs", type=int, default=100, help="simulated runs of one lap")
    plotter.add_argument("--seed", type=int, default=0, help="seed of every random draw")
    plotter.add_argument("--out", type=out_folder, default="results/plotter",
                         help="output folder")
    add_overwrite(plotter, "the results in --out")
    plotter.set_defaults(handler=_reproduce_plotter)


def add_study(commands: argparse._SubParsersAction) -> None:
    """``azgym study error-model|ids``: check azgym's models against what they model."""
    study = commands.add_parser("study", help="check azgym's models against what they model")
    studies = study.add_subparsers(dest="study", required=True)
    model = studies.add_parser("error-model", help="azimuth errors of beacons detected from "
                               "pixels beside the paper's eq. 1-3")
    model.add_argument("--scenario", default="warehouse-small",
                       help="a shipped scenario's name or a scenario file (azgym scenarios "
                            "lists them)")
    model.add_argument("--frames", type=int, default=600, help="random poses")
    model.add_argument("--noise", type=float, default=2.0, help="sensor noise [grey levels]")
    model.add_argument("--calibration-px", type=float, default=1.0,
                       help="principal point error for the calibrated comparison [px]")
    model.add_argument("--seed", type=int, default=0, help="seed of every random draw")
    model.add_argument("--out", type=out_folder, default="results/study", help="output folder")
    add_overwrite(model, "the results in --out")
    model.add_argument("--no-figures", action="store_true", help="skip the PNG figure")
    model.set_defaults(handler=_study_error_model)
    ids = studies.add_parser("ids", help="how well blinking ids decode along the routes")
    ids.add_argument("--scenario", default="warehouse-small",
                     help="a shipped scenario's name or a scenario file (azgym scenarios "
                          "lists them)")
    ids.add_argument("--rate", type=float, default=None,
                     help="camera frames per second (default: the blinking camera's 30)")
    ids.add_argument("--noise", type=float, default=2.0, help="sensor noise [grey levels]")
    ids.add_argument("--seed", type=int, default=0, help="seed of every random draw")
    ids.set_defaults(handler=_study_ids)


def _figures_need_matplotlib(no_figures: bool) -> None:
    """Refuse before the work a study whose figures cannot be drawn (no matplotlib)."""
    from azgym.errors import require

    if not no_figures:
        require("matplotlib", "plot")
