"""robust's map repair (``robust:repair=true``): false repairs, moved beacons found, its cost.

    python baselines/map_repair.py [--part clean|moved|bounds|speed|all] [--seeds 3]
                                   [--first-seed 0]
                                   [--span DEGREES]

``--span`` sets robust's ``repair_span`` (the least spread of a suspect's rays) to try another.

1. **clean**: every route of warehouse-routes and robot-routes (their dev seeds, as the suites
   draw them) through ``robust:repair=true``: the repairs made. warehouse-small ships with one
   beacon moved (its ``moved_to``), which should be repaired; any other repair is false. Also
   the beacons not moved that were suspected (set aside for a while, not repaired).
2. **moved**: each route of warehouse-small, warehouse-paper and robot-arena driven with 1-3
   beacons moved 0.5-3 m by the mapping suite's rule (``perturb.move_beacons``, among the
   beacons the drive as shipped makes observable; the world has them moved, the tracker the
   stale map), ``--seeds`` draws each from ``--first-seed``: per truly moved beacon (a shipped
   ``moved_to`` included) the angle between its move and the line of sight when it was first
   seen from two places (``scoring.first_seen_from_two_places`` on its true detections), when
   it was first suspected (``diagnostics["suspected"]``: noticed and set aside) and whether and
   when it was repaired (located again), both from that first time, the new position's
   error when repaired and where the tracker had it at the end (corrected since); the p95 of the
   position error with repair, on the stale map without it, and on the true map, and their
   ratio, over the whole drive and over the frames after the last moved beacon's repair (the
   run's moved beacons seen from two places all repaired; none if one never was); and the p95
   of robust without repair driving the route again on the map the repair leaves (each
   repaired beacon where the tracker has it at the end), against the true map's.
3. **bounds**: what any method could do with the moved part's beacons within 10 s of each
   first being seen from two places, from its true detections there: how far the move turns
   its azimuths, the noncentrality Σ Δ²/σ² of a test that knew where it went (σ² the error
   model's azimuth variance, with true poses; and with the track's error added, robust's
   covariance on the true map: the best track; and Δᵀ Σ⁻¹ Δ with that error correlated over
   time, Σ as map repair's fit test has it with the time constant the lag at which the best
   track's error autocorrelation falls to 1/e on the drive), and the Cramér-Rao worst-axis standard
   deviation of its new position from those bearings (with the track's error: plus its mean
   position covariance, which rays a few seconds apart share). A noncentrality under 25 cannot
   be told from noise; a bound over 0.1 m cannot be located to ``repair_std``.
4. **speed**: robust and ``robust:repair=true`` timed over the clean routes of the scenarios
   that ship no moved beacon (no repair happens: warehouse-small's beacon 9 is left out), the
   least disturbed of 5 rounds, as a ratio.
"""

from __future__ import annotations

import argparse
import math
import os
import time

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import azgym  # noqa: E402
from azgym.bench.mapping.perturb import move_beacons, true_map  # noqa: E402
from azgym.bench.mapping.scoring import (  # noqa: E402
    first_seen_from_two_places,
    observable_by_truth,
    truly_moved,
)
from azgym.bench.mapping.suites import true_detections  # noqa: E402
from azgym.bench.run.profiles import contender_params  # noqa: E402
from azgym.bench.suites import robot  # noqa: E402
from azgym.bench.suites.catalog import get_suite  # noqa: E402
from azgym.core import BeaconMap, pose_error  # noqa: E402
from azgym.mapping.base import map_answer  # noqa: E402
from azgym.world.drive import simulate  # noqa: E402

MOVED_BY = (0.5, 3.0)
WINDOW_S = 10.0
"""The bounds part's window after a beacon is first seen from two places [s]."""
DETECTABLE = 25.0
"""A move whose azimuth changes add up to less noncentrality than this (five standard deviations
of a test that knew where the beacon went) cannot be told from noise in the window."""
LOCATABLE_M = 0.1
"""The bounds part's standard deviation of a located beacon: robust's ``repair_std`` [m]."""
REPAIR: dict = {"repair": True}
"""robust's options for its map repair (``--span`` adds ``repair_span``, ``--std``
``repair_std``)."""


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


def run_track(tracker, steps, beacons) -> tuple[np.ndarray, float, dict[int, int]]:
    """Position errors per frame (inf: no answer), seconds spent in predict and update, and
    the frame each beacon was first suspected in (its ``diagnostics["suspected"]``)."""
    errors, spent = [], 0.0
    suspected: dict[int, int] = {}
    for k, (motion, measurements, pose) in enumerate(steps):
        start = time.perf_counter()
        if k == 0:
            tracker.reset(seed=0, initial=pose)
        tracker.predict(motion)
        estimate = tracker.update(measurements, beacons)
        spent += time.perf_counter() - start
        errors.append(pose_error(estimate.pose, pose)[0] if estimate.ok else math.inf)
        for beacon in estimate.diagnostics.get("suspected", ()):
            suspected.setdefault(beacon, k)
    return np.array(errors), spent, suspected


def clean() -> None:
    for suite in ("warehouse-routes", "robot-routes"):
        for name, cases in sequences(suite):
            scenario = azgym.load_scenario(cases[0].scenario)
            tracker = azgym.make_tracker("robust", **REPAIR, **params_for(scenario.name))
            _, _, suspected = run_track(tracker, [(c.motion, c.measurements, c.pose)
                                                  for c in cases], scenario.beacons)
            really = moved_as_shipped(scenario)
            where = dict(zip(scenario.beacons.ids.tolist(), scenario.beacon_positions[:, :2],
                             strict=True))
            found = [f"{r.beacon} at {r.time:.1f} s, {100 * math.dist(r.new, where[r.beacon]):.1f}"
                     f" cm off" for r in tracker.repairs]
            false = [r.beacon for r in tracker.repairs if r.beacon not in really]
            print(f"clean {name}: {len(cases)} frames, moved as shipped {sorted(really)}, "
                  f"repairs {found}, false repairs {false}, false suspicions "
                  f"{sorted(set(suspected) - really)}")


def moved_as_shipped(scenario) -> set[int]:
    """The ids of the beacons a scenario ships moved (its world has them off its map)."""
    return set(truly_moved(scenario.beacons, (), true_map(scenario)))


def left_map(beacons: BeaconMap, placed: dict) -> BeaconMap:
    """The map a repairing tracker leaves: ``beacons`` with each repaired one where it is now."""
    ids = sorted(placed)
    return map_answer(ids, [placed[b].new for b in ids],
                      [placed[b].covariance for b in ids]).updated(beacons)


def p95_of(errors: np.ndarray) -> float:
    """The 95th percentile of position errors, inf when it falls among unanswered frames."""
    if errors.size == 0:
        return math.nan
    with np.errstate(invalid="ignore"):  # inf - inf between two unanswered frames
        p95 = float(np.percentile(errors, 95))
    return math.inf if math.isnan(p95) else p95


def drives(seeds: int, first_seed: int):
    """The moved part's drives: (scenario, route, seed, world, its true map, frames, times)."""
    for name in ("warehouse-small", "warehouse-paper", robot.SCENARIO):
        scenario = azgym.load_scenario(name)
        routes = [r for r in scenario.routes if name != robot.SCENARIO or r.name in robot.ROUTES]
        extra = {"odometry": robot._odometry(scenario)} if name == robot.SCENARIO else {}
        for seed in range(first_seed, first_seed + seeds):
            for k, route in enumerate(routes):
                rng = np.random.default_rng([seed, k])
                shipped = list(simulate(scenario, route, seed=seed + k, **extra))
                poses = np.array([f.pose for f in shipped])
                among = sorted(observable_by_truth(*true_detections(scenario, shipped), poses))
                world = move_beacons(scenario, rng, 1 + (seed + k) % 3, among, MOVED_BY).world
                frames = list(simulate(world, route, seed=seed + k, **extra))
                yield (scenario, route, seed, world, true_map(world), frames,
                       np.array([f.time for f in frames]))


def moved(seeds: int, first_seed: int) -> None:
    ratios, after_ratios, again_ratios, delays, misses, errors = [], [], [], [], 0, []
    noticed, unnoticed, false_suspicions = [], 0, 0
    for scenario, route, seed, world, truth, frames, times in drives(seeds, first_seed):
        name = scenario.name
        steps = [(f.motion, f.measurements, f.pose) for f in frames]
        tracker = azgym.make_tracker("robust", **REPAIR, **params_for(name))
        with_repair, _, suspected = run_track(tracker, steps, scenario.beacons)
        stale = run_track(azgym.make_tracker("robust", **params_for(name)), steps,
                          scenario.beacons)[0]
        true = run_track(azgym.make_tracker("robust", **params_for(name)), steps,
                         truth)[0]
        repaired = {r.beacon: r for r in tracker.repairs}
        detected, ids, _ = true_detections(world, frames)
        parts, done = [], 0.0
        really = truly_moved(scenario.beacons, (), truth)
        false_suspicions += len(set(suspected) - set(really))
        for beacon in sorted(really):
            row = scenario.beacons.ids.tolist().index(beacon)
            mine = detected[ids == beacon]
            since = first_seen_from_two_places(times[mine], poses_of(frames, mine))
            seen = ""
            if since is not None:
                angle = line_of_sight(frames, times, since, scenario, truth, row)
                first = times[suspected[beacon]] - since if beacon in suspected else None
                seen = f"{angle:.0f}° to the line of sight, suspected " + \
                    ("never" if first is None else f"{first:+.1f} s") + ", "
                if first is not None:
                    noticed.append(first)
                unnoticed += first is None
            found = repaired.pop(beacon, None)
            if found is None:
                misses += since is not None
                done = math.inf if since is not None else done
                parts.append(f"{beacon}: {seen}"
                             f"{'missed' if since is not None else 'unseen'}")
                continue
            done = max(done, found.time)
            error = math.dist(found.new, truth.xyz[row, :2])
            final = math.dist(tracker.placed[beacon].new, truth.xyz[row, :2])
            delay = found.time - (since if since is not None else found.time)
            delays.append(delay)
            errors.append((error, final))
            parts.append(f"{beacon}: {seen}repaired {delay:+.1f} s, "
                         f"{100 * error:.1f} cm, at the end {100 * final:.1f} cm")
        p95 = [p95_of(e) for e in (with_repair, stale, true)]
        ratios.append(p95[0] / p95[2])
        again = p95_of(run_track(azgym.make_tracker("robust", **params_for(name)), steps,
                                 left_map(scenario.beacons, tracker.placed))[0])
        again_ratios.append(again / p95[2])
        later = times > done
        after = [p95_of(e[later]) for e in (with_repair, true)]
        if later.any():
            after_ratios.append(after[0] / after[1])
        tail = (f"after repair ({later.sum()} frames) {after[0]:.3f} against "
                f"{after[1]:.3f} m, {after[0] / after[1]:.2f}" if later.any()
                else "after repair: none")
        print(f"{name}/{route.name} seed {seed}: moved {parts}; false "
              f"{sorted(repaired)}; p95 repair {p95[0]:.3f} stale {p95[1]:.3f} true "
              f"{p95[2]:.3f} m, repair/true {ratios[-1]:.2f}; {tail}; the map it leaves, "
              f"driven again: {again:.3f} m, {again_ratios[-1]:.2f}")
    within = np.array(delays) <= 10.0
    first, last = np.median(errors, axis=0) if errors else (math.nan, math.nan)
    print(f"delays (s): median {np.median(delays):.1f}, max {max(delays):.1f}, within 10 s "
          f"{within.sum()}/{within.size + misses}; missed {misses}; new position error median "
          f"{100 * first:.1f} cm when repaired, {100 * last:.1f} cm at the end; p95 ratio "
          f"repair/true over the drive: median {np.median(ratios):.3f}, within 10 %: "
          f"{sum(r <= 1.1 for r in ratios)}/{len(ratios)}; after the last repair: median "
          f"{np.median(after_ratios):.3f}, within 10 %: "
          f"{sum(r <= 1.1 for r in after_ratios)}/{len(after_ratios)} runs with every moved "
          f"beacon seen repaired; the map it leaves, driven again: median "
          f"{np.median(again_ratios):.3f}, within 10 %: {sum(r <= 1.1 for r in again_ratios)}/"
          f"{len(again_ratios)}")
    soon = np.array(noticed) <= 10.0
    print(f"suspected (s from first seen from two places): median {np.median(noticed):.1f}, "
          f"max {max(noticed):.1f}, within 10 s {soon.sum()}/{soon.size + unnoticed}; never "
          f"{unnoticed}; beacons not moved suspected {false_suspicions}")


def bounds(seeds: int, first_seed: int) -> None:
    """What any method could do with each moved beacon in its first 10 s (module docstring)."""
    table = []
    for scenario, route, seed, world, truth, frames, times in drives(seeds, first_seed):
        covariances, tau = track_covariances(scenario.name, frames, truth)
        detected, ids, _ = true_detections(world, frames)
        for beacon in sorted(truly_moved(scenario.beacons, (), truth)):
            row = scenario.beacons.ids.tolist().index(beacon)
            mine = detected[ids == beacon]
            since = first_seen_from_two_places(times[mine], poses_of(frames, mine))
            if since is None:
                continue
            window = mine[(times[mine] >= since) & (times[mine] <= since + WINDOW_S)]
            cameras = poses_of(frames, window)
            new, old = truth.xyz[row, :2], scenario.beacons.xyz[row, :2]
            ranges = np.hypot(*(new - cameras).T)
            bearings = np.arctan2(*(new - cameras).T[::-1])
            moved_by = np.remainder(np.arctan2(*(old - cameras).T[::-1]) - bearings + math.pi,
                                    2.0 * math.pi) - math.pi
            normals = np.column_stack((-np.sin(bearings), np.cos(bearings)))
            own = scenario.error_model.variance(ranges, scenario.beacons.width[row])
            track = covariances[window]
            with_track = own + track[:, 2, 2] + np.einsum(
                "ki,kij,kj->k", normals, track[:, :2, :2], normals) / ranges ** 2
            floor = float(np.linalg.eigvalsh(track[:, :2, :2].mean(axis=0))[-1])
            sensitivity = np.column_stack((normals / ranges[:, None], np.ones(len(window))))
            shared = (sensitivity @ track.mean(axis=0) @ sensitivity.T) * np.exp(
                -np.abs(np.subtract.outer(times[window], times[window])) / tau)
            correlated = float(moved_by @ np.linalg.solve(np.diag(own) + shared, moved_by))
            table.append((f"{scenario.name}/{route.name} seed {seed} beacon {beacon}",
                          len(window), math.degrees(np.abs(moved_by).max()),
                          float(np.sum(moved_by ** 2 / own)),
                          float(np.sum(moved_by ** 2 / with_track)), correlated,
                          fisher_std(normals, ranges, own),
                          math.sqrt(fisher_std(normals, ranges, with_track) ** 2 + floor)))
    for name, count, largest, perfect, tracked, correlated, std, std_tracked in table:
        print(f"{name}: {count} sightings, the move turns its azimuth up to {largest:.2f}°; "
              f"noncentrality {perfect:.0f} (true poses), {tracked:.0f} (the track's error), "
              f"{correlated:.0f} (correlated over time); "
              f"locatable to {100 * std:.1f} cm (true poses), {100 * std_tracked:.1f} cm")
    columns = np.array([row[3:] for row in table])
    print(f"bounds over the {len(table)} moved beacons seen from two places, in their first "
          f"{WINDOW_S:.0f} s: noncentrality under {DETECTABLE:.0f} with true poses "
          f"{int((columns[:, 0] < DETECTABLE).sum())}, with the track's error "
          f"{int((columns[:, 1] < DETECTABLE).sum())} (least {columns[:, 1].min():.0f}), "
          f"correlated over time {int((columns[:, 2] < DETECTABLE).sum())} (least "
          f"{columns[:, 2].min():.0f}); "
          f"not locatable within {100 * LOCATABLE_M:.0f} cm with true poses "
          f"{int((columns[:, 3] > LOCATABLE_M).sum())}, with the track's error "
          f"{int((columns[:, 4] > LOCATABLE_M).sum())}")


def track_covariances(name: str, frames, truth) -> tuple[np.ndarray, float]:
    """robust's (x, y, heading) covariance per frame on the true map (K, 3, 3), the best
    track's, and the time its error takes to decorrelate [s]: the lag at which the
    autocorrelation of its x, y and heading errors (their mean) falls to 1/e."""
    tracker = azgym.make_tracker("robust", **params_for(name))
    covariances, errors, times = [], [], []
    for k, frame in enumerate(frames):
        if k == 0:
            tracker.reset(seed=0, initial=frame.pose)
        tracker.predict(frame.motion)
        estimate = tracker.update(frame.measurements, truth)
        covariances.append(np.asarray(estimate.covariance)[:3, :3] if estimate.ok
                           else np.full((3, 3), np.inf))
        if estimate.ok:
            errors.append(np.subtract(estimate.pose[:3], frame.pose[:3]))
            times.append(frame.time)
    return np.array(covariances), decorrelation_time(np.array(errors), np.array(times))


def decorrelation_time(errors: np.ndarray, times: np.ndarray) -> float:
    """The lag at which the mean autocorrelation of ``errors``' columns falls to 1/e [s]."""
    errors = errors.copy()
    errors[:, 2] = np.remainder(errors[:, 2] + math.pi, 2.0 * math.pi) - math.pi
    errors -= errors.mean(axis=0)
    step = float(np.median(np.diff(times)))
    power = np.sum(errors ** 2, axis=0)
    for lag in range(1, len(errors) // 2):
        if np.mean(np.sum(errors[:-lag] * errors[lag:], axis=0) / power) < math.exp(-1.0):
            return lag * step
    return len(errors) // 2 * step


def fisher_std(normals: np.ndarray, ranges: np.ndarray, variances: np.ndarray) -> float:
    """The least worst-axis standard deviation of a point from its bearings [m] (Cramér-Rao):
    each bearing's information n nᵀ / (D² σ²); infinite when they do not fix both axes."""
    scaled = normals / (ranges * np.sqrt(variances))[:, None]
    smallest = float(np.linalg.eigvalsh(scaled.T @ scaled)[0]) if np.isfinite(scaled).all() \
        else 0.0
    return 1.0 / math.sqrt(smallest) if smallest > 1e-12 else math.inf


def line_of_sight(frames, times: np.ndarray, since: float, scenario, truth, row: int) -> float:
    """The angle between a beacon's move and the line from the camera to its map position when
    first seen from two places [°] (0: along the line of sight, 90: across it)."""
    camera = np.array(frames[int(np.searchsorted(times, since))].pose[:2])
    old, new = scenario.beacons.xyz[row, :2], truth.xyz[row, :2]
    sight, move = old - camera, new - old
    cosine = abs(float(sight @ move)) / float(np.linalg.norm(sight) * np.linalg.norm(move))
    return math.degrees(math.acos(min(1.0, cosine)))


def poses_of(frames, rows: np.ndarray) -> np.ndarray:
    """The true camera positions (x, y) of ``frames`` at ``rows`` (K, 2)."""
    return np.array([frames[k].pose[:2] for k in rows.tolist()]).reshape(-1, 2)


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
                total += run_track(tracker, [(c.motion, c.measurements, c.pose) for c in cases],
                                scenario.beacons)[1]
            best[spec] = min(best.get(spec, math.inf), total)
    frames = sum(len(cases) for _, cases in runs)
    print(f"speed over {frames} frames: robust {1e6 * best['robust'] / frames:.1f} µs/frame, "
          f"repair=true {1e6 * best['repair'] / frames:.1f} µs/frame, ratio "
          f"{best['repair'] / best['robust']:.3f}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--part", choices=("clean", "moved", "bounds", "speed", "all"),
                        default="all")
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--first-seed", type=int, default=0,
                        help="the first seed of the moved part (a held-out seed alone)")
    parser.add_argument("--span", type=float, metavar="DEGREES")
    parser.add_argument("--std", type=float, metavar="METRES", help="robust's repair_std")
    args = parser.parse_args()
    if args.span is not None:
        REPAIR["repair_span"] = math.radians(args.span)
    if args.std is not None:
        REPAIR["repair_std"] = args.std
    if args.part in ("clean", "all"):
        clean()
    if args.part in ("moved", "all"):
        moved(args.seeds, args.first_seed)
    if args.part in ("bounds", "all"):
        bounds(args.seeds, args.first_seed)
    if args.part in ("speed", "all"):
        speed()


if __name__ == "__main__":
    main()
