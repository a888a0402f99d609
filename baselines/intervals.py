"""Do the benchmark's 95 % intervals cover? A coverage check of the headline's bootstrap on routes.

The route suites' frames are far from independent: a route's consecutive frames share the pose,
the occluding racks and a tracker's state. This script draws ``warehouse-routes`` from
``--seeds`` different seeds, runs each contender on each draw through the benchmark's runner,
and for every bootstrap block length computes, per seed, the 95 % interval of the headline (the
p75 position error over every frame, a refusal infinite). The pooled headline over all seeds'
frames stands for the value the intervals estimate; the coverage is the share of seeds whose
interval holds it. A frame-by-frame bootstrap (block length 0) is the i.i.d. reference. It also
prints how long a route's errors stay correlated, the reason for the blocks.

    python baselines/intervals.py [--seeds 20] [--contender ransac ...] [--workers 2]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from azgym.bench.run.contenders import contender
from azgym.bench.run.runner import run_contenders
from azgym.bench.suites import get_suite
from azgym.metrics import BLOCK_SECONDS, bootstrap_blocks, confidence_intervals, quantile

FIRST_SEED = 1000
"""The seeds drawn are FIRST_SEED, FIRST_SEED + 1, ... (not the dev seed)."""
BLOCKS = (0.0, 1.0, 2.0, BLOCK_SECONDS, 10.0)
"""Block lengths compared [s]; 0: every frame on its own (an i.i.d. bootstrap)."""


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--contender", action="append")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    suite = get_suite("warehouse-routes")
    contenders = [contender(spec) for spec in args.contender or ["ransac"]]
    started = time.perf_counter()
    draws = []  # per seed: (cases, outcomes)
    for seed in range(FIRST_SEED, FIRST_SEED + args.seeds):
        cases = suite.build(seed, False)
        draws.append((cases, run_contenders(cases, contenders, workers=args.workers)))
    print(f"warehouse-routes, {args.seeds} seeds from {FIRST_SEED}: "
          f"{sum(len(cases) for cases, _ in draws)} frames, {time.perf_counter() - started:.0f} s")
    for c in contenders:
        errors = [np.where(out[c.label].ok, out[c.label].position * 100, np.inf)
                  for _, out in draws]
        pooled = quantile(np.concatenate(errors), 0.75)
        print(f"\n{c.label}: pooled headline {pooled:.2f} cm; per seed "
              f"{min(quantile(e, 0.75) for e in errors):.2f}-"
              f"{max(quantile(e, 0.75) for e in errors):.2f} cm")
        lags = {f"{lag / 10:g} s": _exceedance_correlation(draws[0][0], errors[0], lag)
                for lag in (1, 10, 50)}
        print("  correlation of 'error above p75' with the same route's frame later (seed "
              f"{FIRST_SEED}): " + ", ".join(f"{lag} {value:.2f}" for lag, value in lags.items()))
        print(f"  {'blocks':>8} {'coverage':>9} {'median width cm':>16}")
        for seconds in BLOCKS:
            covered, widths = 0, []
            for cases, out in draws:
                outcome = out[c.label]
                sequences = [case.sequence if seconds else "" for case in cases]
                blocks = bootstrap_blocks(sequences, [case.time for case in cases],
                                          seconds or 1.0)
                low, high = confidence_intervals(outcome.position, outcome.ok,
                                                 blocks)["p75_all_cm"]
                covered += low <= pooled <= high
                widths.append(high - low)
            name = "frames" if seconds == 0 else f"{seconds:g} s"
            print(f"  {name:>8} {100 * covered / len(draws):8.0f}% {np.median(widths):16.2f}")


def _exceedance_correlation(cases, errors: np.ndarray, lag: int) -> float:
    """Correlation of "error above the p75" between frames ``lag`` apart on the same route."""
    above = (errors > quantile(errors, 0.75)).astype(float)
    pairs = [(above[k], above[k + lag]) for k in range(len(cases) - lag)
             if cases[k].sequence == cases[k + lag].sequence]
    first, later = np.array(pairs).T
    return float(np.corrcoef(first, later)[0, 1])


if __name__ == "__main__":
    main()
