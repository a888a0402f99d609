"""Speed benchmark of the localizers (issue #2's targets), with a reference timed in the same run.

    python baselines/speed.py [--calls 3000] [--out results/speed.json]

Every figure is the median over many calls, end to end through ``localize()`` on one core, with
the compile time of numba kept out. Beside each figure: the ratio to a reference workload timed in
the same process (one ``numpy.arctan2`` over 12 elements, the cost unit of a numpy call on a frame),
so runs on different machines can be compared. The ransac breakdown shows where its time goes.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import azgym  # noqa: E402
from azgym.localize import ransac as ransac_module  # noqa: E402
from azgym.localize.base import Problem  # noqa: E402
from azgym.localize.refinement import finish  # noqa: E402
from azgym.sensing.synthetic import noisy_measurements  # noqa: E402

TARGETS_US = {"ransac": 30.0, "mex": 500_000.0}
PAPER_US = {"ransac": 56.0, "mex": 278_000.0}


def median_us(call, count: int) -> float:
    """Median wall time of ``call()`` in µs over ``count`` calls (after one warm-up call)."""
    call()
    times = np.empty(count)
    for k in range(count):
        start = time.perf_counter_ns()
        call()
        times[k] = time.perf_counter_ns() - start
    return float(np.median(times)) / 1000.0


def frames(room, count: int, seed: int = 7) -> list:
    rng = np.random.default_rng(seed)
    return [noisy_measurements(*rng.uniform(-10, 10, 2), rng.uniform(-math.pi, math.pi),
                               room.beacons, room.error_model, rng) for _ in range(count)]


def per_frame_median(localizer, beacons, batch: list) -> float:
    localizer.localize(batch[0], beacons)
    times = np.empty(len(batch))
    for k, frame in enumerate(batch):
        start = time.perf_counter_ns()
        localizer.localize(frame, beacons)
        times[k] = time.perf_counter_ns() - start
    return float(np.median(times)) / 1000.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--calls", type=int, default=3000)
    parser.add_argument("--mex-calls", type=int, default=5)
    parser.add_argument("--out", default="results/speed.json")
    args = parser.parse_args()

    room = azgym.load_scenario("paper-room")
    beacons = room.beacons
    batch = frames(room, args.calls)
    dx = beacons.xy[:, 0] - 1.0
    dy = beacons.xy[:, 1] - 2.0
    reference = median_us(lambda: np.arctan2(dy, dx), 20_000)

    report: dict = {"reference_us": reference, "calls": args.calls, "localizers": {}}
    for name, params in (("ransac", {}), ("ransac", {"weighted": True}), ("lsq", {}),
                         ("loo", {}), ("triplet", {})):
        label = name + ("-weighted" if params else "")
        micros = per_frame_median(azgym.make_localizer(name, **params), beacons, batch)
        report["localizers"][label] = {"median_us": micros,
                                       "ratio_to_reference": micros / reference}

    mex = azgym.make_localizer("mex")
    micros = per_frame_median(mex, beacons, batch[: args.mex_calls])
    report["localizers"]["mex (exhaustive 1 cm, 22 m x 22 m)"] = {
        "median_us": micros, "ratio_to_reference": micros / reference}

    # Where ransac's time goes, on one typical frame.
    ransac = azgym.make_localizer("ransac")
    frame = batch[0]
    problem = Problem.from_frame(frame, beacons)
    triplets = ransac.triplets(problem.size)
    pose = np.empty(4)
    mask = np.zeros(problem.size, dtype=bool)

    def search() -> None:
        ransac_module._search(problem.bx, problem.by, problem.cos_az, problem.sin_az,
                              problem.width, problem.beacon_index, triplets,
                              ransac.delta_alpha_d, True, ransac.degeneracy_tol, pose, mask)

    search()
    model = ransac.error_model()
    report["ransac_breakdown_us"] = {
        "whole localize()": median_us(lambda: ransac.localize(frame, beacons), args.calls),
        "Problem.from_frame (id lookup, gather)": median_us(
            lambda: Problem.from_frame(frame, beacons), args.calls),
        "triplet search, 220 triplets (steps 1-5)": median_us(search, args.calls),
        "refinement + covariance + Estimate (step 6)": median_us(
            lambda: finish(problem, mask, pose, False, ransac.max_iter, model), args.calls),
    }

    print(f"reference: numpy.arctan2 over 12 elements = {reference:.3f} µs\n")
    print(f"{'localizer':<38} {'median µs':>12} {'× reference':>12} {'target µs':>10} "
          f"{'paper µs':>10}")
    for label, row in report["localizers"].items():
        key = label.split(" ")[0]
        target = TARGETS_US.get(key, float("nan"))
        paper = PAPER_US.get(key, float("nan"))
        print(f"{label:<38} {row['median_us']:>12.1f} {row['ratio_to_reference']:>12.1f} "
              f"{target:>10.0f} {paper:>10.0f}")
    print("\nransac breakdown (median µs):")
    for part, micros in report["ransac_breakdown_us"].items():
        print(f"  {part:<46} {micros:8.2f}")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(report, indent=1) + "\n", encoding="utf-8")
    print(f"\nwrote {args.out}")


if __name__ == "__main__":
    main()
