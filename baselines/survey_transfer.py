"""The survey away from warehouse-small: robot-arena's routes, and the shipped real logs.

    python baselines/survey_transfer.py [--seeds 2]

robot-arena (a narrow camera seeing one or two beacons a frame, a robot's drifting wheel
odometry, no IMU) is nothing like the warehouse the survey was built on; nothing is tuned for
it. Each of its routes, ``--seeds`` draws, is written as a log by ``export_route`` and surveyed
as ``azgym survey LOG --anchor 1 2`` does (the known start, beacons 1 and 2 held, the log's map
as the prior), with the settings a robot's tracker gets on the robot suite
(:func:`azgym.bench.suites.robot.contender_defaults`: the scenario's vehicle and camera, and its
odometry's errors; the exported log's own profile leaves the motion noise out, and the
forklift's defaults then assumed are 40 times too sure of the turn rate) or, with
``--log-profile``, with the log's own profile. Printed per drive: its length, the beacons
surveyed, why the others were not (counted by reason) or the survey's refusal, the surveyed
ones' error against the truth (median, p95, worst; anchors aside), the mean of their
normalized errors squared (NEES: 2 when the covariances are honest), the ids surveyed that no
beacon has (phantoms) and the beacons called moved; then the NEES over every drive. Then each
shipped real log (envs/logs) is offered to the survey, and what it answers is printed.
"""

from __future__ import annotations

import argparse
import math
import os
import tempfile
from collections import Counter
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import azgym  # noqa: E402
from azgym.bench.suites.robot import contender_defaults  # noqa: E402
from azgym.errors import AzgymError  # noqa: E402
from azgym.logs import export_route, read_log  # noqa: E402
from azgym.mapping import Prior, log_drives, settings_from_profile, survey  # noqa: E402

SCENARIO = "robot-arena"
ANCHORS = (1, 2)
LOGS = Path(__file__).parents[1] / "envs" / "logs"


def arena(seeds: int, log_profile: bool) -> None:
    """Each robot-arena route surveyed (module docstring)."""
    scenario = azgym.load_scenario(SCENARIO)
    every: list[float] = []
    truth = dict(zip(scenario.beacons.ids.tolist(), scenario.beacon_positions[:, :2],
                     strict=True))
    with tempfile.TemporaryDirectory() as folder:
        for route in scenario.routes:
            for seed in range(seeds):
                log = read_log(export_route(scenario, route.name, seed,
                                            Path(folder) / f"{route.name}-{seed}"))
                try:
                    result = survey(log_drives(log), Prior(log.beacons, ANCHORS),
                                    settings_from_profile(log.manifest.profile if log_profile
                                                          else contender_defaults()))
                except AzgymError as error:
                    print(f"{route.name} seed {seed}: refused: {str(error)[:160]}")
                    continue
                errors = 100.0 * np.array([math.dist(result.xy[b], truth[i]) for b, i in
                                           enumerate(result.ids.tolist())
                                           if result.observable[b] and i in truth
                                           and i not in ANCHORS])
                nees = [_nees(result.xy[b] - truth[i], result.covariances[b])
                        for b, i in enumerate(result.ids.tolist())
                        if result.observable[b] and i in truth and i not in ANCHORS]
                every += nees
                phantoms = [i for b, i in enumerate(result.ids.tolist())
                            if result.observable[b] and i not in truth]
                why = Counter(r.split(":")[0].split(",")[0] for r in result.reasons if r)
                figures = (f"median {np.median(errors):.1f} cm, p95 "
                           f"{np.percentile(errors, 95):.1f} cm, worst {errors.max():.1f} cm, "
                           f"NEES {np.mean(nees):.1f}" if errors.size else "no beacon surveyed")
                print(f"{route.name} seed {seed}: {log.frames['time'][-1]:.0f} s, surveyed "
                      f"{int(result.observable.sum())} of {len(result.ids)} ({figures}); "
                      f"phantoms {phantoms}; moved {list(result.moved)}; not surveyed: {dict(why)}")
    if every:
        print(f"NEES over the {len(every)} surveyed beacons: mean {np.mean(every):.2f}, median "
              f"{np.median(every):.2f} (2 and 1.39 when honest)")


def _nees(error: np.ndarray, covariance: np.ndarray) -> float:
    """The normalized error squared of one beacon's position."""
    return float(error @ np.linalg.solve(covariance, error))


def real_logs() -> None:
    """Each shipped real log offered to the survey."""
    for folder in sorted(LOGS.iterdir()):
        log = read_log(folder)
        if log.manifest.simulated:
            continue
        try:
            drives = log_drives(log)
        except AzgymError as error:
            print(f"{folder.name}: refused: {str(error).split(': ', 1)[1]}")
            continue
        result = survey(drives, Prior(log.beacons, ANCHORS),
                        settings_from_profile(log.manifest.profile))
        print(f"{folder.name}: surveyed {int(result.observable.sum())} of {len(result.ids)}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=2)
    parser.add_argument("--log-profile", action="store_true",
                        help="survey with the log's own profile (no motion noise in it)")
    args = parser.parse_args()
    arena(args.seeds, args.log_profile)
    real_logs()


if __name__ == "__main__":
    main()
