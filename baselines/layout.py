"""The layout planner's acceptance figures: prediction against Monte Carlo, and a placement.

    python baselines/layout.py [--frames 400] [--step 0.5] [--seed 0] [--out baselines/layout]

(a) ``paper-room``: the predicted σ_pos = sqrt(C_xx + C_yy) of every cell of the floor grid
against the RMS position error of ``ransac`` (and of each ``--localizer``) over ``--frames``
noisy frames per cell (K = 0, eq. 3's errors, random heading): the share of cells where they
agree within 10 %, the median ratio, the same for the spread without the bias (std), and the
share expected from sampling alone (a prediction exactly right still misses 10 % at a cell now
and then: the RMS of N frames scatters by about 1/(2√N) to 1/√(2N) of itself).

(b) ``warehouse-small``: ``azgym layout optimize --add 4``; the predicted p95 over the floor
before and after, and a Monte Carlo run (``ransac``, ``--frames-placement`` frames per cell) on
the old and the new layout, scored the same way (a cell without a fix counts as 1 m).

Writes ``layout.json`` and the figures into ``--out``.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

import azgym
from azgym.bench.run.processes import default_workers
from azgym.files import prepare_folder, write_file
from azgym.placement.analysis import agreement, predict
from azgym.placement.candidates import candidate_places
from azgym.placement.figures import analysis_figure, placement_figure
from azgym.placement.floor import floor_grid
from azgym.placement.monte_carlo import monte_carlo
from azgym.placement.objective import floor_figures
from azgym.placement.optimize import place_beacons
from azgym.placement.scenario_file import with_new_beacons, write_scenario


def expected_share(frames: int, trials: int = 20_000, seed: int = 0) -> float:
    """Share of cells within 10 % if the prediction were exact and the error round and Gaussian.

    The RMS of ``frames`` 2-D errors of σ_pos = 1, drawn ``trials`` times.
    """
    rng = np.random.default_rng(seed)
    squared = rng.chisquare(2 * frames, size=trials) / (2 * frames)  # mean |e|² / σ_pos²
    return float(np.mean(np.abs(np.sqrt(squared) - 1) <= 0.1))


def prediction_check(localizers: list[str], step: float, frames: int, seed: int,
                     out: Path) -> dict:
    """(a): the paper room's prediction against each localizer's Monte Carlo RMS."""
    scenario = azgym.load_scenario("paper-room")
    floor = floor_grid(scenario, step)
    prediction = predict(scenario, floor)
    result = {"cells": len(floor.points), "step_m": step, "frames": frames,
              "predicted": floor_figures(prediction.sigma, prediction.visible),
              "expected_share_within_10pct_if_exact": expected_share(frames)}
    for name in localizers:
        started = time.perf_counter()
        checked = monte_carlo(scenario, floor.points, prediction.seen, name, frames, seed,
                              workers=default_workers())
        result[name] = agreement(prediction.sigma, checked)
        result[name]["seconds"] = round(time.perf_counter() - started, 1)
        ratio = checked.rms / prediction.sigma
        result[name]["ratio_p05_p95"] = [float(np.percentile(ratio, 5)),
                                         float(np.percentile(ratio, 95))]
        worst = int(np.argmax(np.abs(ratio - 1)))
        result[name]["worst_cell"] = {"xy": floor.points[worst].tolist(),
                                      "predicted_m": float(prediction.sigma[worst]),
                                      "rms_m": float(checked.rms[worst]),
                                      "bias_m": float(checked.bias[worst])}
        analysis_figure(scenario, floor, prediction.sigma, prediction.visible, checked.rms,
                        out / f"paper-room-{name.replace(':', '_')}.png", name)
    return result


def placement_check(step: float, frames: int, seed: int, out: Path) -> dict:
    """(b): four beacons placed on warehouse-small, predicted and checked by Monte Carlo."""
    scenario = azgym.load_scenario("warehouse-small")
    floor = floor_grid(scenario, step)
    candidates = candidate_places(scenario)
    placement = place_beacons(scenario, floor, candidates, 4)
    data = with_new_beacons(scenario, placement.new_xyz, placement.width, "warehouse-small-plus-4")
    placed = write_scenario(out / "warehouse-small-plus-4.toml", data, "baselines/layout.py")
    result = {"cells": len(floor.points), "candidates": len(candidates),
              "new_beacons": placement.new_xyz.tolist(),
              "predicted_before": floor_figures(placement.before, placement.visible_before),
              "predicted_after": floor_figures(placement.after, placement.visible_after)}
    for label, site in (("before", scenario), ("after", placed)):
        prediction = predict(site, floor)
        checked = monte_carlo(site, floor.points, prediction.seen, "ransac", frames, seed,
                              workers=default_workers())
        result[f"monte_carlo_{label}"] = agreement(prediction.sigma, checked)
        analysis_figure(site, floor, prediction.sigma, prediction.visible, checked.rms,
                        out / f"warehouse-small-{label}.png", "ransac")
    placement_figure(scenario, floor, placement.before, placement.after, placement.new_xyz,
                     (result["predicted_before"]["sigma_p95_m"],
                      result["predicted_after"]["sigma_p95_m"]), out / "warehouse-small-plus-4.png")
    return result


def report(result: dict) -> None:
    """The figures, as the acceptance reads them."""
    a = result["prediction_check"]
    print(f"(a) paper-room, {a['cells']} cells of {a['step_m']:g} m, {a['frames']} frames per "
          f"cell (sampling alone: {100 * a['expected_share_within_10pct_if_exact']:.1f} % within"
          " 10 %)")
    for name, f in a.items():
        if isinstance(f, dict) and "share_within_10pct" in f:
            low, high = f["ratio_p05_p95"]
            print(f"    {name:<18} RMS within 10 % of σ at {100 * f['share_within_10pct']:.1f} % "
                  f"of cells (std: {100 * f['std_share_within_10pct']:.1f} %), median ratio "
                  f"{f['ratio_median']:.3f}, p5-p95 {low:.3f}-{high:.3f}, no fix "
                  f"{100 * f['failed_share']:.2f} %")
    b = result["placement_check"]
    print(f"(b) warehouse-small + 4 beacons, {b['cells']} cells:")
    for label in ("before", "after"):
        predicted, checked = b[f"predicted_{label}"], b[f"monte_carlo_{label}"]["rms"]
        print(f"    {label:<6} predicted p95 {100 * predicted['sigma_p95_m']:6.2f} cm, median "
              f"{100 * predicted['sigma_median_m']:.2f} cm, p95 over the cells with a fix "
              f"{100 * predicted['sigma_p95_with_fix_m']:.2f} cm; Monte Carlo p95 "
              f"{100 * checked['sigma_p95_m']:6.2f} cm, median "
              f"{100 * checked['sigma_median_m']:.2f} cm; cells without a fix "
              f"{predicted['cells_undetermined']}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=400, help="frames per cell for (a)")
    parser.add_argument("--frames-placement", type=int, default=200,
                        help="frames per cell for (b)")
    parser.add_argument("--step", type=float, default=0.5, help="grid spacing [m]")
    parser.add_argument("--localizer", action="append", default=[],
                        help="more localizers for (a), besides ransac")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="baselines/layout")
    args = parser.parse_args()
    out = prepare_folder(Path(args.out))
    started = time.perf_counter()
    result = {"prediction_check": prediction_check(["ransac", *args.localizer], args.step,
                                                   args.frames, args.seed, out),
              "placement_check": placement_check(args.step, args.frames_placement, args.seed,
                                                 out)}
    result["seconds"] = round(time.perf_counter() - started, 1)
    write_file(out / "layout.json", json.dumps(result, indent=1, allow_nan=False) + "\n")
    report(result)
    print(f"{result['seconds']:.0f} s; wrote {out}")


if __name__ == "__main__":
    main()
