"""The warehouse's figures: localizers on warehouse frames, and the speed of the sensor and world.

    python baselines/warehouse.py [--seed 0] [--out results/warehouse.json]

Accuracy: every route of ``warehouse-small`` is driven (``azgym.world.drive``). The frames are
localized by ``ransac`` and ``lsq`` through the benchmark's runner under two conditions: as
shipped, with reflections (glass wall, metal racks), misread ids and a moved beacon, and the
benchmark's "clean" level, with reflectivities, the misread rate and the move set to zero.
``warehouse-paper`` and ``warehouse-large`` follow, as shipped. The report gives availability and
the mean, p75 and p95 position errors. Speed: the median µs of one sensor frame in
``warehouse-small`` and ``warehouse-large``, and of one world step, over 5 rounds, reporting the
least disturbed round.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

import azgym
from azgym.bench.run.runner import Contender, run_contenders
from azgym.bench.suites import Case, frame_cause
from azgym.bench.suites.warehouse import fault_levels
from azgym.sensing.geometry.sensor import GeometrySensor
from azgym.world.drive import simulate
from azgym.world.world import World

FAULTY = ("moved", "ghost", "misidentified")
"""The causes that count as a fault here (partial occlusion is the paper's coverage error)."""


def accuracy(scenario: azgym.Scenario, seed: int) -> dict:
    """ransac and lsq on every route of the scenario, frame by frame, through the runner."""
    cases = [Case(scenario.name, frame.measurements, frame.pose, frame_cause(frame.truth.label),
                  route.name)
             for route in scenario.routes for frame in simulate(scenario, route, seed=seed)]
    outcomes = run_contenders(cases, [Contender("ransac", "ransac"), Contender("lsq", "lsq")],
                              maps={scenario.name: scenario.beacons})
    result = {"frames": len(cases),
              "frames_with_ghost_misread_or_moved": sum(case.cause in FAULTY for case in cases)}
    for name, outcome in outcomes.items():
        stats = outcome.stats()
        result[name] = {key: stats[key] for key in ("availability", "mean_cm", "p75_cm",
                                                     "p95_cm", "failure_rate")}
    return result


def best_round_us(call, count: int, rounds: int = 5) -> float:
    medians = []
    for _ in range(rounds):
        times = np.empty(count)
        for k in range(count):
            start = time.perf_counter_ns()
            call(k)
            times[k] = time.perf_counter_ns() - start
        medians.append(float(np.median(times)) / 1000)
    return min(medians)


def speed() -> dict:
    result = {}
    for name in ("warehouse-small", "warehouse-large"):
        scenario = azgym.load_scenario(name)
        sensor = GeometrySensor(scenario)
        rng = np.random.default_rng(0)
        poses = [frame.pose for route in scenario.routes
                 for frame in simulate(scenario, route, seed=0)][::3]
        sensor.observe(tuple(poses[0]), rng)
        result[f"sensor frame, {name} (µs)"] = best_round_us(
            lambda k, p=poses, s=sensor, g=rng: s.observe(tuple(p[k % len(p)]), g), 2000)
    scenario = azgym.load_scenario("warehouse-small")
    world = World(scenario, scenario.routes[0].start_pose())
    result["world step, warehouse-small (µs)"] = best_round_us(
        lambda k: world.step(0.3, 0.3 * math.sin(k / 50)), 2000)
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", default="results/warehouse.json")
    args = parser.parse_args()
    shipped = azgym.load_scenario("warehouse-small")
    report = {"as shipped": accuracy(shipped, args.seed),
              "clean": accuracy(fault_levels(shipped)["clean"], args.seed)}
    for name in ("warehouse-paper", "warehouse-large"):
        report[f"{name}, as shipped"] = accuracy(azgym.load_scenario(name), args.seed)
    report["speed"] = speed()
    for condition in [key for key in report if key != "speed"]:
        row = report[condition]
        print(f"{condition}: {row['frames']} frames, "
              f"{row['frames_with_ghost_misread_or_moved']} with a ghost, misread id or moved "
              "beacon")
        for name in ("ransac", "lsq"):
            stats = row[name]
            print(f"  {name:<7} available {100 * stats['availability']:5.1f} %  mean "
                  f"{stats['mean_cm']:7.1f} cm  p75 {stats['p75_cm']:7.1f} cm  p95 "
                  f"{stats['p95_cm']:7.1f} cm  failures {100 * stats['failure_rate']:5.1f} %")
    for part, micros in report["speed"].items():
        print(f"{part:<40} {micros:8.1f}")
    Path(args.out).parent.mkdir(parents=True, exist_ok=True)
    Path(args.out).write_text(json.dumps(report, indent=1) + "\n", encoding="utf-8")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
