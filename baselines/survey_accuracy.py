"""The survey's acceptance on warehouse-small: beacon errors, and ransac on the surveyed map.

    python baselines/survey_accuracy.py [--seed 0] [--speed 0.75]

The drive: warehouse-small's aisle-loop (95 m) at ``--speed`` (0.75 m/s: 126 s, over the two
minutes the acceptance asks for), written as a log by ``export_route`` (the scenario's simulated
odometry and IMU, its glass wall's and racks' mirror images, its misread ids) into a temporary
folder. It is surveyed by the command itself, run as a process:
``azgym survey LOG --prior ANCHORS --anchor 1 2 --out DIR`` (the known start is the log's first
true pose; the map is unknown but for beacons 1 and 2, ``ANCHORS`` a ``beacons.csv`` of those
two), and the ``beacons.csv`` it writes is read back.

Printed: each surveyed beacon's error against the world's true positions (beacon 9 stands
1.5 m from where the shipped map has it), their median, p95 and worst, and the mean of their
normalized errors squared under the covariances ``survey.csv`` gives (NEES); then ransac (its
defaults) on every frame of the same drive, its headline p75 (a refusal counts as infinite)
on the surveyed map, on the true map and on the stale map the log ships with, and the
surveyed map's p75 over the true map's. The acceptance: median <= 3 cm, p95 <= 8 cm, ratio
<= 1.10.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os
import subprocess
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import azgym  # noqa: E402
from azgym.core import BeaconMap, pose_error  # noqa: E402
from azgym.logs import export_route, read_log  # noqa: E402
from azgym.logs.frames import frame_measurements  # noqa: E402
from azgym.logs.manifest import read_beacons  # noqa: E402
from azgym.mapping.survey_file import read_survey  # noqa: E402
from azgym.metrics import quantile  # noqa: E402

SCENARIO = "warehouse-small"
ROUTE = "aisle-loop"
ANCHORS = (1, 2)


def drive_log(seed: int, speed: float, folder: Path) -> Path:
    """The acceptance drive written as a log in ``folder``."""
    scenario = azgym.load_scenario(SCENARIO)
    routes = tuple(dataclasses.replace(r, speed=speed) if r.name == ROUTE else r
                   for r in scenario.routes)
    return export_route(dataclasses.replace(scenario, routes=routes), ROUTE, seed,
                        folder / "log")


def surveyed_map(log_folder: Path, out: Path) -> tuple[BeaconMap, str]:
    """``azgym survey`` run on the log: the map it wrote and what it printed.

    Its prior is a ``beacons.csv`` of the anchors alone, written beside ``out`` (the log's own
    map, given whole, would hold every other beacon by its position: docs/mapping.md, "The
    model").
    """
    known = read_log(log_folder).beacons
    anchors = out.parent / "anchors.csv"
    anchors.write_text("id,x,y,z,width\n" + "".join(
        f"{i},{x!r},{y!r},{z!r},{w!r}\n" for i, (x, y, z), w in zip(
            known.ids.tolist(), known.xyz.tolist(), known.width.tolist(), strict=True)
        if i in ANCHORS))
    command = [sys.executable, "-m", "azgym", "survey", str(log_folder), "--prior",
               str(anchors), "--anchor", *map(str, ANCHORS), "--out", str(out)]
    done = subprocess.run(command, capture_output=True, text=True, timeout=600, check=True)
    return read_beacons(out / "beacons.csv"), done.stdout


def ransac_p75(log_folder: Path, beacons: BeaconMap) -> float:
    """ransac's p75 position error [cm] over the log's frames against ``beacons``."""
    log = read_log(log_folder)
    localizer = azgym.make_localizer("ransac")
    errors = []
    for k, measurements in enumerate(frame_measurements(log)):
        truth = log.pose(k)
        assert truth is not None  # a simulated log has its truth
        estimate = localizer.localize(measurements, beacons)
        errors.append(pose_error(estimate.pose, truth)[0] if estimate.ok else math.inf)
    return 100.0 * quantile(errors, 0.75)


def beacon_errors(surveyed: BeaconMap) -> dict[int, float]:
    """Each surveyed beacon's distance from its true position [m], anchors left out."""
    scenario = azgym.load_scenario(SCENARIO)
    truth = dict(zip(scenario.beacons.ids.tolist(), scenario.beacon_positions[:, :2],
                     strict=True))
    return {i: math.dist(xy, truth[i]) for i, xy in zip(surveyed.ids.tolist(),
                                                         surveyed.xyz[:, :2], strict=True)
            if i not in ANCHORS}


def nees(out: Path) -> float:
    """The surveyed beacons' mean normalized error squared under the covariances ``survey.csv``
    gives (anchors aside)."""
    scenario = azgym.load_scenario(SCENARIO)
    truth = dict(zip(scenario.beacons.ids.tolist(), scenario.beacon_positions[:, :2],
                     strict=True))
    surveyed = read_survey(out)
    found = [float((xy - truth[i]) @ np.linalg.solve(cov, xy - truth[i]))
             for i, xy, cov in zip(surveyed.ids.tolist(), surveyed.xy, surveyed.covariance,
                                   strict=True) if i not in ANCHORS]
    return float(np.mean(found))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--speed", type=float, default=0.75)
    args = parser.parse_args()
    scenario = azgym.load_scenario(SCENARIO)
    true_map = BeaconMap(scenario.beacons.ids, scenario.beacon_positions, scenario.beacons.width)
    with tempfile.TemporaryDirectory() as folder:
        log_folder = drive_log(args.seed, args.speed, Path(folder))
        log = read_log(log_folder)
        surveyed, printed = surveyed_map(log_folder, Path(folder) / "surveyed")
        times = log.frames["time"]
        print(f"drive: {ROUTE} at {args.speed} m/s, seed {args.seed}: {len(times)} frames over "
              f"{times[-1]:.0f} s")
        print(printed.strip())
        errors = beacon_errors(surveyed)
        print("beacon errors [cm]: " + ", ".join(f"{i}: {100 * e:.1f}"
                                                 for i, e in sorted(errors.items())))
        values = np.array(list(errors.values()))
        print(f"{len(values)} surveyed beacons (anchors aside): median "
              f"{100 * np.median(values):.1f} cm, p95 {100 * np.percentile(values, 95):.1f} cm, "
              f"worst {100 * values.max():.1f} cm; NEES {nees(Path(folder) / 'surveyed'):.2f} "
              "(2 when the covariances are honest)")
        on_survey = ransac_p75(log_folder, surveyed)
        on_truth = ransac_p75(log_folder, true_map)
        on_stale = ransac_p75(log_folder, log.beacons)
        print(f"ransac p75: surveyed map {on_survey:.2f} cm, true map {on_truth:.2f} cm, "
              f"shipped (stale) map {on_stale:.2f} cm; surveyed / true {on_survey / on_truth:.3f}")


if __name__ == "__main__":
    main()
