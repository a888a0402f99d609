"""robust's map repair (``robust:repair=true``): false repairs, moved beacons found, its cost.

    python baselines/map_repair.py [--part clean|moved|speed|all] [--seeds 3] [--span DEGREES]

``--span`` sets robust's ``repair_span`` (the least spread of a suspect's rays) to try another.

1. **clean**: every route of warehouse-routes and robot-routes (their dev seeds, as the suites
   draw them) through ``robust:repair=true``: the repairs made. warehouse-small ships with one
   beacon moved (its ``moved_to``), which should be repaired; any other repair is false.
2. **moved**: each route of warehouse-small, warehouse-paper and robot-arena driven with 1-3
   beacons moved 0.5-3 m (the world has them moved, the tracker the stale map), ``--seeds``
   draws each: per moved beacon whether it was repaired, the delay from its first being seen
   from two places (two camera positions 0.5 m apart), the new position's error when repaired
   and where the tracker had it at the end (refined since); the p95 of the position error
   with repair, on the stale map without it, and on the true map, and their ratio.
3. **speed**: robust and ``robust:repair=true`` timed over the clean routes of the scenarios
   that ship no moved beacon (no repair happens: warehouse-small's beacon 9 is left out), the
   least disturbed of 5 rounds, as a ratio.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import time

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import azgym  # noqa: E402
from azgym.bench.run.profiles import contender_params  # noqa: E402
from azgym.bench.suites import robot  # noqa: E402
from azgym.bench.suites.catalog import get_suite  # noqa: E402
from azgym.core import BeaconMap, pose_error  # noqa: E402
from azgym.world.drive import simulate  # noqa: E402

MOVED_BY = (0.5, 3.0)
REPAIR: dict = {"repair": True}
"""robust's options for its map repair (``--span`` adds ``repair_span``)."""
TWO_PLACES_M = 0.5


def sequences(suite_name: str) -> list[tuple[str, list]]:
    """A route suite's sequences (name, cases) as its dev seed draws them."""
    suite = get_suite(suite_name)
    runs: dict[str, list] = {}
    for case in suite.build(suite.dev_seed, False):
        runs.setdefault(case.sequence, []).append(case)
    return list(runs.items())


def params_for(scenario: str) -> dict:
    """robust's hyperparameters as the suites give them (robot-arena's profile)."""
    if scenario == robot.SCENARIO:
        return contender_params("robust", {}, robot.contender_defaults())
    return {}


def replay(tracker, steps, beacons) -> tuple[np.ndarray, float]:
    """Position errors per frame (inf: no answer) and seconds spent in predict and update."""
    errors, spent = [], 0.0
    for k, (motion, measurements, pose) in enumerate(steps):
        start = time.perf_counter()
        if k == 0:
            tracker.reset(seed=0, initial=pose)
        tracker.predict(motion)
        estimate = tracker.update(measurements, beacons)
        spent += time.perf_counter() - start
        errors.append(pose_error(estimate.pose, pose)[0] if estimate.ok else math.inf)
    return np.array(errors), spent


def clean() -> None:
    for suite in ("warehouse-routes", "robot-routes"):
        for name, cases in sequences(suite):
            scenario = azgym.load_scenario(cases[0].scenario)
            tracker = azgym.make_tracker("robust", **REPAIR, **params_for(scenario.name))
            replay(tracker, [(c.motion, c.measurements, c.pose) for c in cases], scenario.beacons)
            really = moved_as_shipped(scenario)
            where = dict(zip(scenario.beacons.ids.tolist(), scenario.beacon_positions[:, :2],
                             strict=True))
            found = [f"{r.beacon} at {r.time:.1f} s, {100 * math.dist(r.new, where[r.beacon]):.1f}"
                     f" cm off" for r in tracker.repairs]
            false = [r.beacon for r in tracker.repairs if r.beacon not in really]
            print(f"clean {name}: {len(cases)} frames, moved as shipped {sorted(really)}, "
                  f"repairs {found}, false repairs {false}")


def moved_as_shipped(scenario) -> set[int]:
    """The ids of the beacons a scenario ships moved (its world has them off its map)."""
    moved = scenario.beacon_positions[:, :2] != scenario.beacons.xyz[:, :2]
    return set(scenario.beacons.ids[moved.any(axis=1)].tolist())


def moved_world(scenario, rng: np.random.Generator, count: int):
    """The scenario with ``count`` beacons moved in the world, the true map, the moved rows."""
    xyz = scenario.beacons.xyz.copy()
    chosen = rng.choice(len(xyz), count, replace=False)
    x0, y0, x1, y1 = scenario.bounds
    for k in chosen:
        while True:
            step = rng.uniform(*MOVED_BY) * np.array([math.cos(a := rng.uniform(0, 2 * math.pi)),
                                                      math.sin(a)])
            if x0 + 0.2 < xyz[k, 0] + step[0] < x1 - 0.2 and y0 + 0.2 < xyz[k, 1] + step[1] < \
                    y1 - 0.2:
                break
        xyz[k, :2] += step
    return (dataclasses.replace(scenario, physical_xyz=xyz),
            BeaconMap(scenario.beacons.ids, xyz, scenario.beacons.width), chosen)


def p95_of(errors: np.ndarray) -> float:
    """The 95th percentile of position errors, inf when it falls among unanswered frames."""
    with np.errstate(invalid="ignore"):  # inf - inf between two unanswered frames
        p95 = float(np.percentile(errors, 95))
    return math.inf if math.isnan(p95) else p95


def two_places(frames, beacon: int) -> float | None:
    """When a beacon was first seen from two camera positions TWO_PLACES_M apart [s]."""
    seen = [f for f in frames if beacon in f.measurements.ids]
    if not seen:
        return None
    first = np.array(seen[0].pose[:2])
    return next((f.time for f in seen if math.dist(f.pose[:2], first) >= TWO_PLACES_M), None)


def moved(seeds: int) -> None:
    ratios, delays, misses, errors = [], [], 0, []
    for name in ("warehouse-small", "warehouse-paper", robot.SCENARIO):
        scenario = azgym.load_scenario(name)
        routes = [r for r in scenario.routes if name != robot.SCENARIO or r.name in robot.ROUTES]
        extra = {"odometry": robot._odometry(scenario)} if name == robot.SCENARIO else {}
        for seed in range(seeds):
            for k, route in enumerate(routes):
                rng = np.random.default_rng([seed, k])
                world, truth, chosen = moved_world(scenario, rng, 1 + (seed + k) % 3)
                frames = list(simulate(world, route, seed=seed + k, **extra))
                steps = [(f.motion, f.measurements, f.pose) for f in frames]
                tracker = azgym.make_tracker("robust", **REPAIR, **params_for(name))
                with_repair, _ = replay(tracker, steps, scenario.beacons)
                stale, _ = replay(azgym.make_tracker("robust", **params_for(name)), steps,
                                  scenario.beacons)
                true, _ = replay(azgym.make_tracker("robust", **params_for(name)), steps, truth)
                repaired = {r.beacon: r for r in tracker.repairs}
                parts = []
                for row in chosen:
                    beacon = int(scenario.beacons.ids[row])
                    since = two_places(frames, beacon)
                    found = repaired.pop(beacon, None)
                    if found is None:
                        misses += since is not None
                        parts.append(f"{beacon}: {'missed' if since is not None else 'unseen'}")
                        continue
                    error = math.dist(found.new, truth.xyz[row, :2])
                    final = math.dist(tracker.placed[beacon].new, truth.xyz[row, :2])
                    delay = found.time - (since if since is not None else found.time)
                    delays.append(delay)
                    errors.append((error, final))
                    parts.append(f"{beacon}: {delay:+.1f} s, {100 * error:.1f} cm, at the end "
                                 f"{100 * final:.1f} cm")
                p95 = [p95_of(e) for e in (with_repair, stale, true)]
                ratios.append(p95[0] / p95[2])
                print(f"{name}/{route.name} seed {seed}: moved {parts}; false "
                      f"{sorted(repaired)}; p95 repair {p95[0]:.3f} stale {p95[1]:.3f} true "
                      f"{p95[2]:.3f} m, repair/true {ratios[-1]:.2f}")
    within = np.array(delays) <= 10.0
    first, last = np.median(errors, axis=0) if errors else (math.nan, math.nan)
    print(f"delays (s): median {np.median(delays):.1f}, max {max(delays):.1f}, within 10 s "
          f"{within.sum()}/{within.size + misses}; missed {misses}; new position error median "
          f"{100 * first:.1f} cm when repaired, {100 * last:.1f} cm at the end; p95 ratio "
          f"repair/true: median {np.median(ratios):.3f}, "
          f"within 10 %: {sum(r <= 1.1 for r in ratios)}/{len(ratios)}")


def speed(rounds: int = 5) -> None:
    runs = [(scenario, cases) for suite in ("warehouse-routes", "robot-routes")
            for _, cases in sequences(suite)
            if not moved_as_shipped(scenario := azgym.load_scenario(cases[0].scenario))]
    best: dict[str, float] = {}
    for _ in range(rounds):
        for spec in ("robust", "repair"):
            total = 0.0
            for scenario, cases in runs:
                extra = REPAIR if spec == "repair" else {}
                tracker = azgym.make_tracker("robust", **extra, **params_for(scenario.name))
                total += replay(tracker, [(c.motion, c.measurements, c.pose) for c in cases],
                                scenario.beacons)[1]
            best[spec] = min(best.get(spec, math.inf), total)
    frames = sum(len(cases) for _, cases in runs)
    print(f"speed over {frames} frames: robust {1e6 * best['robust'] / frames:.1f} µs/frame, "
          f"repair=true {1e6 * best['repair'] / frames:.1f} µs/frame, ratio "
          f"{best['repair'] / best['robust']:.3f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--part", choices=("clean", "moved", "speed", "all"), default="all")
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--span", type=float, metavar="DEGREES")
    args = parser.parse_args()
    if args.span is not None:
        REPAIR["repair_span"] = math.radians(args.span)
    if args.part in ("clean", "all"):
        clean()
    if args.part in ("moved", "all"):
        moved(args.seeds)
    if args.part in ("speed", "all"):
        speed()


if __name__ == "__main__":
    main()
