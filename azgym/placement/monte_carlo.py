"""The Monte Carlo check of a prediction: noisy frames at each cell, through a localizer.

At each cell, N frames as the paper's protocol draws them (Rátosi & Simon 2021, Sec. 3.1; the
``paper`` suite with K = 0): a uniformly random heading, each beacon seen from the cell
(:mod:`azgym.placement.visibility`) measured at its true azimuth plus the errors of eq. 3 drawn from
the scenario's error model (:meth:`~azgym.site.error_model.ErrorModel.sample`), no outliers.
Each frame goes to the localizer with the whole map, through the benchmark's runner
(:func:`azgym.bench.run.runner.run_contenders`): the localizer runs in worker processes of its own,
and a frame on which it raises (``SystemExit`` too), overruns the time limit, crashes its worker
or answers no finite pose (:func:`azgym.core.estimated_pose`) has no fix, with the reason kept,
as in ``azgym bench``. The error of a fix is its position minus the cell; over a cell's fixes:

* ``rms`` = sqrt(mean |e|²), comparable with σ_pos = sqrt(C_xx + C_yy), which it equals for an
  unbiased estimator;
* ``std`` = sqrt(trace of the sample covariance of e), the spread without the bias;
* ``bias`` = |mean e|; ``failed`` the share of frames without a fix (1 at a cell seeing fewer
  than three beacons, where the localizer is not asked).

With N frames, the sampling error of ``rms`` is about 1/(2√N) of it for a round error
(2.5 % at N = 400) and up to 1/√(2N) for an elongated one (3.5 %). Each cell draws from its own
stream of the seed, so a cell's figures do not depend on the grid around it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from azgym import arguments
from azgym.bench.run.contenders import contender
from azgym.bench.run.isolation import DEFAULT_TIME_LIMIT
from azgym.bench.run.runner import run_contenders
from azgym.bench.suites import Case
from azgym.core import BeaconMap, BoolArray, FloatArray, Measurements, wrap_angle
from azgym.placement.information import MIN_BEACONS
from azgym.progress import Progress, counter
from azgym.sensing.synthetic import ideal_azimuths
from azgym.site import Scenario

__all__ = ["MonteCarlo", "monte_carlo"]

CHUNK_FRAMES = 100_000
"""Frames handed to the runner at once (bounds the memory of a large analysis)."""


@dataclass(frozen=True)
class MonteCarlo:
    """A localizer's errors, cell by cell (NaN where no frame gave a fix).

    Attributes:
        localizer: The spec that built it.
        frames: Frames per cell.
        rms, std, bias: See the module's docstring, shape (P,) [m].
        failed: Share of frames without a fix, shape (P,).
        asked: Whether the localizer was asked at each cell (it sees three beacons or more).
        problems: How many frames each reason cost (an exception, a time-out), over all cells.
    """

    localizer: str
    frames: int
    rms: FloatArray
    std: FloatArray
    bias: FloatArray
    failed: FloatArray
    asked: BoolArray
    problems: dict[str, int]


def monte_carlo(scenario: Scenario, points: FloatArray, seen: BoolArray, localizer: str,
                frames: int, seed: int = 0,
                progress: Progress | None = None, *, workers: int = 1,
                time_limit: float = DEFAULT_TIME_LIMIT) -> MonteCarlo:
    """Run ``frames`` frames at each point through ``localizer`` (module docstring).

    Args:
        scenario: The site (its map and error model).
        points: Camera positions (x, y), shape (P, 2) [m].
        seen: Which beacon each point sees, shape (P, N) over the map's beacons.
        localizer: A localizer spec (``ransac``, ``ransac:weighted=true``, ...).
        frames: Frames per cell, >= 1.
        seed: Seed of every draw, in [0, 2**31).
        progress: Hears the count of cells done (:func:`azgym.progress.counter`; the cells
            seeing three beacons or more, a batch of them at a time).
        workers: Worker processes running the localizer.
        time_limit: Seconds the localizer may take on one frame (or to be built).
    """
    arguments.seed("seed", seed)
    runs = contender(localizer)
    asked = np.count_nonzero(seen, axis=1) >= MIN_BEACONS
    figures = np.full((4, len(points)), np.nan)
    figures[3] = 1.0
    problems: dict[str, int] = {}
    cells = np.flatnonzero(asked)
    per_chunk = max(1, CHUNK_FRAMES // frames)
    with counter(progress, "Monte Carlo", len(cells), "cells") as done:
        for start in range(0, len(cells), per_chunk):
            part = cells[start:start + per_chunk]
            cases = [case for p in part for case in _cases(
                scenario, points[p], seen[p], frames, np.random.default_rng([seed, p]))]
            outcome = run_contenders(cases, [runs], workers=workers, time_limit=time_limit,
                                     maps={scenario.name: scenario.beacons})[runs.label]
            for error in filter(None, outcome.errors):
                problems[error] = problems.get(error, 0) + 1
            for k, p in enumerate(part):
                rows = slice(k * frames, (k + 1) * frames)
                fixed = outcome.estimate[rows][outcome.ok[rows], :2] - points[p]
                figures[:, p] = _figures(fixed, frames)
            done(start + len(part))
    rms, std, bias, failed = figures
    return MonteCarlo(localizer, frames, rms, std, bias, failed, asked, problems)


def _cases(scenario: Scenario, point: FloatArray, seen: BoolArray, frames: int,
           rng: np.random.Generator) -> list[Case]:
    """One cell's frames: a random heading, eq. 3's errors on the beacons it sees."""
    beacons = scenario.beacons
    x, y = float(point[0]), float(point[1])
    sub = BeaconMap(beacons.ids[seen], beacons.xyz[seen], beacons.width[seen])
    bearing, distance = ideal_azimuths(x, y, 0.0, sub)
    heading = rng.uniform(-math.pi, math.pi, size=frames)
    noise = scenario.error_model.sample(np.broadcast_to(distance, (frames, len(sub))),
                                        sub.width, rng)
    azimuth = wrap_angle(bearing[None, :] - heading[:, None] + noise)
    return [Case(scenario.name, Measurements(sub.ids, azimuth[f]), (x, y, float(heading[f])),
                 "clean", "layout") for f in range(frames)]


def _figures(errors: FloatArray, frames: int) -> tuple[float, float, float, float]:
    """(rms, std, bias, failed share) of one cell's position errors (fixes only), shape (F, 2)."""
    if not len(errors):
        return math.nan, math.nan, math.nan, 1.0
    with np.errstate(over="ignore", invalid="ignore"):  # a finite but absurd fix: an inf RMS
        rms = math.sqrt(float(np.mean(np.sum(errors * errors, axis=1))))
        std = (math.sqrt(float(np.sum(np.var(errors, axis=0, ddof=1)))) if len(errors) > 1
               else math.nan)
        bias = float(np.hypot(*errors.mean(axis=0)))
    return rms, std, bias, 1.0 - len(errors) / frames
