"""The survey's robust loss, Cauchy against Huber, on drives with mirror images and misread ids.

    python baselines/survey_loss.py [--seeds 3] [--rates 0.01 0.03 0.05]

warehouse-small's three routes (aisle-loop at 0.75 m/s, the acceptance drive's speed; the
others at their own), each with the scenario's ghosts (its glass wall's and metal racks' mirror
images) and its misread ids at each ``--rates`` (the share of detections whose id is read as
another beacon's; the scenario ships 0.01), ``--seeds`` draws each, surveyed from the known
start with beacons 1 and 2 as anchors and the shipped map as the prior, once with each loss.
Printed per loss and rate, over every route and seed: the beacons surveyed, their position
error (median, p95 and worst, anchors aside), the beacons called moved that were not (only
beacon 9 was moved after the map was made) and the drives in which beacon 9 was missed.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import azgym  # noqa: E402
from azgym.mapping import Prior, Settings, simulated_drive, survey  # noqa: E402
from azgym.site.elements import Faults  # noqa: E402
from azgym.world.drive import simulate  # noqa: E402

SCENARIO = "warehouse-small"
SPEEDS = {"aisle-loop": 0.75}
"""Route speeds other than the scenario's [m/s]."""
MOVED = 9
"""The beacon the scenario moved after its map was made."""
LOSSES = ("cauchy", "huber")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--rates", type=float, nargs="+", default=[0.01, 0.03, 0.05])
    args = parser.parse_args()
    shipped = azgym.load_scenario(SCENARIO)
    truth = dict(zip(shipped.beacons.ids.tolist(), shipped.beacon_positions[:, :2], strict=True))
    prior = Prior(shipped.beacons, (1, 2))
    print(f"{'loss':>7} {'misread':>8} {'surveyed':>9} {'median cm':>10} {'p95 cm':>7} "
          f"{'worst cm':>9} {'false moved':>12} {'9 missed':>9}")
    for rate in args.rates:
        routes = tuple(dataclasses.replace(r, speed=SPEEDS.get(r.name, r.speed))
                       for r in shipped.routes)
        scenario = dataclasses.replace(shipped, routes=routes, faults=Faults(rate))
        drives = [list(simulate(scenario, route.name, seed)) for route in routes
                  for seed in range(args.seeds)]
        for loss in LOSSES:
            errors: list[float] = []
            surveyed = total = false_moved = missed = 0
            for frames in drives:
                result = survey(simulated_drive(frames, frames[0].pose), prior,
                                Settings(loss=loss))
                surveyed += int(result.observable.sum())
                total += len(result.ids)
                errors += [math.dist(result.xy[b], truth[i])
                           for b, i in enumerate(result.ids.tolist())
                           if result.observable[b] and i not in prior.anchors]
                false_moved += len(set(result.moved) - {MOVED})
                seen = np.flatnonzero(result.ids == MOVED)
                missed += int(seen.size > 0 and bool(result.observable[seen[0]])
                              and MOVED not in result.moved)
            values = 100.0 * np.array(errors)
            print(f"{loss:>7} {rate:>8.2f} {surveyed:>4}/{total:<4} {np.median(values):>10.2f} "
                  f"{np.percentile(values, 95):>7.2f} {values.max():>9.2f} {false_moved:>12} "
                  f"{missed:>9}")


if __name__ == "__main__":
    main()
