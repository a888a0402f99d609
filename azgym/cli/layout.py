"""``azgym layout analyze|optimize``: a beacon layout's predicted accuracy, and beacons to add.

Every argument is checked (the scenario, the grid, the localizer, the count, the output folder)
before any work starts. See docs/layout.md.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from azgym.cli.options import (
    add_overwrite,
    out_folder,
    progress_printer,
    resolve_workers,
    seconds_option,
    workers_option,
)

__all__ = ["DEFAULT_FRAMES", "MAX_TOTAL_FRAMES", "add_layout"]

DEFAULT_FRAMES = 100
"""Monte Carlo frames per cell by default (about 7 % sampling error on an RMS; 400: 3.5 %)."""
MAX_TOTAL_FRAMES = 10_000_000
"""The most Monte Carlo frames one analysis runs (cells × frames; ~10 minutes of ransac)."""


def _prepared(args: argparse.Namespace) -> tuple[Any, Any, Path]:
    """The scenario, its floor grid and the output folder (made only when it is used)."""
    from azgym.placement.floor import floor_grid
    from azgym.placement.scenario_file import file_stem
    from azgym.site import load_scenario

    scenario = load_scenario(args.scenario)
    floor = floor_grid(scenario, args.step)
    out = Path("results/layout") / file_stem(scenario.name) if args.out is None else Path(args.out)
    return scenario, floor, out


def _analyze(args: argparse.Namespace) -> int:
    from azgym.arguments import seed as seed_rule
    from azgym.arguments import whole_number
    from azgym.errors import InvalidInputError
    from azgym.files import claim_folder, prepare_folder
    from azgym.localize.registry import make_localizer
    from azgym.placement.analysis import ANALYSIS_FILES, analyze, summary, write_analysis

    frames = whole_number("frames", args.frames, minimum=0)
    seed = seed_rule("--seed", args.seed)
    workers = resolve_workers(args)
    make_localizer(args.localizer)  # a bad spec stops here, before any work
    scenario, floor, out = _prepared(args)
    covariance: Any = None
    absent: tuple[int, ...] = ()
    if args.survey is not None:
        from azgym.mapping.survey_file import read_survey
        from azgym.placement.surveyed import surveyed_scenario

        scenario, covariance, absent = surveyed_scenario(scenario, read_survey(args.survey))
    cells = int(floor.free.sum())
    if cells * frames > MAX_TOTAL_FRAMES:
        raise InvalidInputError(f"frames {frames} at {cells} cells makes {cells * frames} "
                                f"Monte Carlo frames, more than {MAX_TOTAL_FRAMES}; use fewer "
                                "frames or a larger step")
    # The last check: every other argument is good.
    prepare_folder(claim_folder(out, ANALYSIS_FILES, args.overwrite, "--out"))
    print(f"{scenario.name}: {cells} cells of {floor.step:g} m, "
          f"{_count(scenario.beacons, 'beacon')}"
          + (f"; Monte Carlo: {frames} frames per cell through {args.localizer}" if frames
             else ""), flush=True)
    if args.survey is not None:
        print(f"surveyed map {args.survey}: " + (
            f"{_count(absent, 'beacon')} absent (unobservable or not detected): "
            f"{', '.join(map(str, absent))}" if absent else "every beacon surveyed"), flush=True)
    started = time.perf_counter()
    prediction, checked = analyze(scenario, floor, args.localizer, frames, seed,
                                  progress_printer(), workers=workers,
                                  time_limit=args.time_limit, covariance=covariance)
    written = write_analysis(out, scenario, prediction, checked, figures=not args.no_figures,
                             absent=absent)
    _print_summary(summary(scenario, prediction, checked, absent))
    print(f"{time.perf_counter() - started:.1f} s; wrote {', '.join(map(str, written))}")
    return 0


def _count(items: Any, noun: str) -> str:
    """``1 beacon``, ``4 beacons``."""
    count = len(items) if not isinstance(items, int) else items
    return f"{count} {noun}{'' if count == 1 else 's'}"


def _print_summary(result: dict[str, Any]) -> None:
    """The analysis' figures, one line each."""
    predicted = result["predicted"]
    print(f"predicted σ_pos over {predicted['cells']} cells: median "
          f"{100 * predicted['sigma_median_m']:.2f} cm, p95 {100 * predicted['sigma_p95_m']:.2f} "
          f"cm (no fix or ≥ {result['penalty_sigma_m']:g} m counts as {result['penalty_sigma_m']:g}"
          " m)")
    print(f"cells with < 3 beacons seen: {predicted['cells_under_3_beacons']}; "
          f"undetermined: {predicted['cells_undetermined']}")
    if "survey" in result:
        survey = result["survey"]
        for label, figures in (("map's bias floor σ_map", survey["map_bias_floor"]),
                               ("σ_total with the map's error", survey["total"])):
            print(f"{label}: median {100 * figures['sigma_median_m']:.2f} cm, p95 "
                  f"{100 * figures['sigma_p95_m']:.2f} cm")
        if survey["map_share_of_variance_median"] is not None:
            print(f"the map's share of σ_total²: median "
                  f"{100 * survey['map_share_of_variance_median']:.1f} % of the cells with a fix")
    if "monte_carlo" in result:
        check = result["monte_carlo"]
        rms = check["rms"]
        print(f"Monte Carlo ({check['localizer']}, {check['frames']} frames per cell): RMS median "
              f"{100 * rms['sigma_median_m']:.2f} cm, p95 {100 * rms['sigma_p95_m']:.2f} cm")
        if check["cells_compared"]:
            print(f"RMS / predicted σ: median {check['ratio_median']:.3f}, within 10 % at "
                  f"{100 * check['share_within_10pct']:.1f} % of {check['cells_compared']} "
                  "cells")
        failed = ("" if check["failed_share"] is None else
                  f"{100 * check['failed_share']:.2f} % of the frames had no fix; ")
        print(f"run at {_count(check['cells_run'], 'cell')} seeing ≥ 3 beacons: {failed}"
              f"not run at {_count(check['cells_not_run'], 'cell')} seeing fewer (no fix)")
        for reason, frames in check["lost_frames"].items():
            print(f"  {_count(frames, 'frame')} lost: {reason}")
        if check["lost_frames_other_reasons"]:
            print(f"  {_count(check['lost_frames_other_reasons'], 'frame')} lost for other "
                  "reasons")


def _optimize(args: argparse.Namespace) -> int:
    from azgym.files import claim_folder, prepare_folder
    from azgym.placement.candidates import candidate_places
    from azgym.placement.optimize import check_add, place_beacons
    from azgym.placement.scenario_file import placement_files, source_data

    scenario, floor, out = _prepared(args)
    candidates = candidate_places(scenario, args.spacing)
    add = check_add(args.add, candidates)
    source_data(scenario)  # a scenario without a file to add to stops here
    prepare_folder(claim_folder(out, placement_files(scenario.name), args.overwrite,
                                "--out"))  # the last check
    print(f"{scenario.name}: {int(floor.free.sum())} cells of {floor.step:g} m; placing "
          f"{_count(add, 'beacon')} on {len(candidates)} candidate places", flush=True)
    started = time.perf_counter()
    placement = place_beacons(scenario, floor, candidates, add, progress_printer())
    written = _write_placement(args, scenario, floor, placement, out)
    print(f"{time.perf_counter() - started:.1f} s; wrote {', '.join(map(str, written))}")
    return 0


def _write_placement(args: argparse.Namespace, scenario: Any, floor: Any, placement: Any,
                     out: Path) -> list[Path]:
    """The new scenario file and figure, and the printout; refused when nothing helps."""
    from azgym.errors import InvalidInputError
    from azgym.placement.objective import floor_figures
    from azgym.placement.scenario_file import (
        PLACEMENT_FIGURE,
        placed_name,
        with_new_beacons,
        write_scenario,
    )

    placed = len(placement.chosen)
    if not placed:
        raise InvalidInputError(f"{scenario.name}: no candidate place lowers the objective (the "
                                "p95 of the predicted σ, then its mean): none is seen from cells "
                                "where it would help; nothing written")
    if placed < args.add:
        print(f"only {_count(placed, 'beacon')} of the {args.add} asked for lower the objective; "
              f"placing {placed}")
    name = placed_name(scenario.name, placed)
    data = with_new_beacons(scenario, placement.new_xyz, placement.width, name)
    path = out / f"{name}.toml"
    write_scenario(path, data, f"{scenario.name} with {_count(placed, 'beacon')} placed by azgym "
                   f"layout optimize (grid {floor.step:g} m, candidates every {args.spacing:g} m).")
    before = floor_figures(placement.before, placement.visible_before)
    after = floor_figures(placement.after, placement.visible_after)
    written = [path]
    if not args.no_figures:
        from azgym.placement.figures import placement_figure

        written.append(placement_figure(
            scenario, floor, placement.before, placement.after, placement.new_xyz,
            (before["sigma_p95_m"], after["sigma_p95_m"]), out / PLACEMENT_FIGURE))
    for beacon, index in zip(data["beacons"][-placed:], placement.chosen, strict=True):
        x, y, z = beacon["xyz"]
        print(f"  new beacon {beacon['id']}: ({x:g}, {y:g}, {z:g}) on a "
              f"{placement.candidates.kind[index]}")
    for label, figures in (("before", before), ("after", after)):
        print(f"{label:>6}: p95 σ_pos {100 * figures['sigma_p95_m']:.2f} cm, median "
              f"{100 * figures['sigma_median_m']:.2f} cm, cells with < 3 beacons "
              f"{figures['cells_under_3_beacons']}")
    return written


def add_layout(commands: argparse._SubParsersAction) -> None:
    """``azgym layout analyze|optimize``."""
    from azgym.bench.run.isolation import DEFAULT_TIME_LIMIT
    from azgym.placement.candidates import DEFAULT_SPACING
    from azgym.placement.floor import DEFAULT_STEP

    layout = commands.add_parser("layout", help="predict a beacon layout's accuracy over the "
                                                "floor, or place more beacons")
    actions = layout.add_subparsers(dest="action", required=True)
    analyze = actions.add_parser("analyze", help="maps of the predicted σ, the beacons seen and "
                                                 "a Monte Carlo check")
    optimize = actions.add_parser("optimize", help="place new beacons to lower the p95 of the "
                                                   "predicted σ")
    for parser in (analyze, optimize):
        parser.add_argument("scenario", help="a shipped scenario's name or a .toml file")
        parser.add_argument("--step", type=float, default=DEFAULT_STEP, metavar="M",
                            help="grid spacing [m]")
        parser.add_argument("--out", metavar="DIR", type=out_folder,
                            help="output folder (default: results/layout/SCENARIO)")
        parser.add_argument("--no-figures", action="store_true", help="skip the PNG files")
        add_overwrite(parser, "the files it writes in --out")
    analyze.add_argument("--survey", type=Path, metavar="DIR",
                         help="an azgym survey output folder (or its survey.csv): predict with "
                         "the surveyed beacons only and add their covariances' bias floor")
    analyze.add_argument("--localizer", default="ransac", metavar="SPEC",
                         help="the localizer of the Monte Carlo check")
    analyze.add_argument("--frames", type=int, default=DEFAULT_FRAMES, metavar="N",
                         help="Monte Carlo frames per cell (0: none)")
    analyze.add_argument("--seed", type=int, default=0,
                         help="seed of the Monte Carlo draws, in [0, 2**31)")
    analyze.add_argument("--workers", type=workers_option, default=0,
                         help="processes running the localizer (0: one per core)")
    analyze.add_argument("--time-limit", type=seconds_option, default=DEFAULT_TIME_LIMIT,
                         metavar="SECONDS", help="time the localizer may take on one frame (or "
                         "to be built); a frame over it has no fix (default: "
                         f"{DEFAULT_TIME_LIMIT:g}, as azgym bench)")
    analyze.set_defaults(handler=_analyze)
    optimize.add_argument("--add", type=int, required=True, metavar="N",
                          help="how many beacons to place")
    optimize.add_argument("--spacing", type=float, default=DEFAULT_SPACING, metavar="M",
                          help="spacing of the candidate places along the walls [m]")
    optimize.set_defaults(handler=_optimize)
