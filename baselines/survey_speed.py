"""How long ``azgym survey`` takes on a 5-minute log, with a reference timed in the same run.

    python baselines/survey_speed.py [--rounds 3] [--minutes 5]

A 5-minute drive of warehouse-small (its aisle-loop driven slowly enough to last that long,
seed 0) is written as a log (``export_route``) into a temporary folder and read back; then,
``--rounds`` times, a reference workload (a dense 300 x 300 ``numpy.linalg.solve``, 20 times) is
timed right before the survey of the log (``read_log`` + ``log_drives`` + ``survey`` from the
known start with beacons 1 and 2 as anchors, as ``azgym survey LOG --anchor 1 2`` runs it), on
one core (``OMP_NUM_THREADS=1`` etc. set before numpy loads). The least disturbed round (the
fastest survey) is printed beside its reference and their ratio, which compares across machines.
"""

from __future__ import annotations

import os

for _variable in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_variable] = "1"

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from azgym.logs import export_route, read_log  # noqa: E402
from azgym.mapping import Prior, log_drives, settings_from_profile, survey  # noqa: E402
from azgym.site import load_scenario  # noqa: E402

ROUTE = "aisle-loop"
LOOP_METRES = 95.0
"""The route's length, about (its speed is set so that it lasts ``--minutes``)."""


def reference() -> float:
    """Seconds of the reference workload."""
    rng = np.random.default_rng(0)
    a = rng.standard_normal((300, 300)) + 300 * np.eye(300)
    b = rng.standard_normal(300)
    start = time.perf_counter()
    for _ in range(20):
        np.linalg.solve(a, b)
    return time.perf_counter() - start


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--minutes", type=float, default=5.0)
    args = parser.parse_args()
    scenario = load_scenario("warehouse-small")
    routes = tuple(dataclasses.replace(r, speed=LOOP_METRES / (60.0 * args.minutes))
                   if r.name == ROUTE else r for r in scenario.routes)
    slow = dataclasses.replace(scenario, routes=routes)
    with tempfile.TemporaryDirectory() as folder:
        log_folder = export_route(slow, ROUTE, 0, Path(folder) / "log")
        rounds = []
        for _ in range(args.rounds):
            unit = reference()
            start = time.perf_counter()
            log = read_log(log_folder)
            result = survey(log_drives(log), Prior(log.beacons, (1, 2)),
                            settings_from_profile(log.manifest.profile))
            rounds.append((time.perf_counter() - start, unit))
    seconds, unit = min(rounds)
    frames = sum(len(p) for p in result.poses)
    print(f"log: {frames} frames over {log.frames['time'][-1]:.0f} s, "
          f"{int(result.rays.sum())} detections, {int(result.observable.sum())} of "
          f"{len(result.ids)} beacons surveyed")
    print(f"{'survey s':>9} {'reference s':>12} {'ratio':>7}   rounds (s)")
    print(f"{seconds:>9.2f} {unit:>12.4f} {seconds / unit:>7.0f}   "
          + ", ".join(f"{s:.2f}" for s, _ in rounds))


if __name__ == "__main__":
    main()
