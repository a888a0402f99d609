"""The headline's interval on routes covers what it claims to, checked by simulation."""

from __future__ import annotations

import numpy as np
import pytest

from azgym.bench.run.contenders import contender
from azgym.bench.run.runner import run_contenders
from azgym.bench.suites import get_suite
from azgym.metrics import bootstrap_blocks, confidence_intervals, quantile

SEEDS = range(1000, 1020)


@pytest.mark.slow
def test_ransacs_route_interval_covers_the_pooled_headline_and_is_wider_than_iid():
    suite, ransac = get_suite("warehouse-routes"), contender("ransac")
    runs = []
    for seed in SEEDS:
        cases = suite.build(seed, False)
        runs.append((cases, run_contenders(cases, [ransac], workers=2)["ransac"]))
    pooled = quantile(np.concatenate([np.where(o.ok, o.position * 100, np.inf)
                                      for _, o in runs]), 0.75)
    covered, ratios = 0, []
    for cases, outcome in runs:
        times = [case.time for case in cases]
        blocks = confidence_intervals(outcome.position, outcome.ok, bootstrap_blocks(
            [case.sequence for case in cases], times))["p75_all_cm"]
        frames = confidence_intervals(outcome.position, outcome.ok, bootstrap_blocks(
            [""] * len(cases), times))["p75_all_cm"]
        covered += blocks[0] <= pooled <= blocks[1]
        ratios.append((blocks[1] - blocks[0]) / (frames[1] - frames[0]))
    assert covered >= 0.85 * len(SEEDS)
    assert min(ratios) >= 2.0
