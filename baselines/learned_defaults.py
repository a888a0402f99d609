"""How ``learned``'s refinement defaults were chosen: each setting varied on held-out frames.

    python baselines/learned_defaults.py

The shipped weights localize frames of generated warehouses they never saw in training (the
held-out layouts of :mod:`azgym.learn.dataset`, data seed 7, which neither training nor the
model card's figures use), first with the defaults (3 rounds, last gate 1° at the training
noise, ``min_trust`` −2), then with one setting changed at a time. Printed per variant: the
frames' p75 position error and the share more than 1 m off. No suite's frames are used.
"""

from __future__ import annotations

import argparse
import math
import os

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

from azgym.learn.dataset import HELD_OUT_LAYOUTS, make_frames  # noqa: E402
from azgym.learn.regression_report import localize_frames  # noqa: E402
from azgym.localize.learned import LEARNED_WEIGHTS, PoseRegressor  # noqa: E402

DATA_SEED = 7
LAYOUTS = 12
FRAMES_PER_LAYOUT = 100
VARIANTS: tuple[tuple[str, int, dict[str, float]], ...] = (
    ("defaults", 3, {}),
    ("min_trust -4", 3, {"min_trust": -4.0}),
    ("min_trust 0", 3, {"min_trust": 0.0}),
    ("4 rounds", 4, {}),
    ("last gate 0.5°", 3, {"gate": math.radians(0.5)}),
    ("last gate 2°", 3, {"gate": math.radians(2.0)}),
)


def main() -> None:
    argparse.ArgumentParser(description=__doc__.splitlines()[0]).parse_args()
    regressor = PoseRegressor.load(LEARNED_WEIGHTS)
    batch = make_frames(list(HELD_OUT_LAYOUTS[:LAYOUTS]), FRAMES_PER_LAYOUT, DATA_SEED)
    print(f"learned, shipped weights, {len(batch)} frames of {LAYOUTS} held-out layouts "
          f"(data seed {DATA_SEED})")
    print(f"{'variant':<16} {'p75 [cm]':>9} {'beyond 1 m':>11}")
    for name, rounds, settings in VARIANTS:
        error = localize_frames(batch, regressor, rounds, **settings)
        print(f"{name:<16} {100 * np.percentile(error, 75):9.2f} "
              f"{100 * np.mean(error > 1.0):10.1f}%")


if __name__ == "__main__":
    main()
