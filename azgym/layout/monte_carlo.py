"""The Monte Carlo check of a prediction: noisy frames at each cell, through a localizer.

At each cell, N frames as the paper's protocol draws them (Rátosi & Simon 2021, Sec. 3.1; the
``paper`` suite with K = 0): a uniformly random heading, each beacon seen from the cell
(:mod:`azgym.layout.visibility`) measured at its true azimuth plus the errors of eq. 3 drawn from
the scenario's error model (:meth:`~azgym.site.error_model.ErrorModel.sample`), no outliers.
Each frame goes to the localizer with the whole map. The error of a fix is its position minus
the cell; over a cell's fixes:

* ``rms`` = sqrt(mean |e|²), comparable with σ_pos = sqrt(C_xx + C_yy), which it equals for an
  unbiased estimator;
* ``std`` = sqrt(trace of the sample covariance of e), the spread without the bias;
* ``bias`` = |mean e|; ``failed`` the share of frames without a fix (``ok`` False).

With N frames, the sampling error of ``rms`` is about 1/(2√N) of it for a round error
(2.5 % at N = 400) and up to 1/√(2N) for an elongated one (3.5 %). Each cell draws from its own
stream of the seed, so a cell's figures do not depend on the grid around it.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from azgym.core import BeaconMap, BoolArray, FloatArray, Measurements, wrap_angle
from azgym.layout.information import MIN_BEACONS
from azgym.localize.registry import SupportsLocalize
from azgym.sensing.synthetic import ideal_azimuths
from azgym.site import Scenario


@dataclass(frozen=True)
class MonteCarlo:
    """A localizer's errors, cell by cell (NaN where no frame gave a fix).

    Attributes:
        localizer: The spec that built it.
        frames: Frames per cell.
        rms, std, bias: See the module's docstring, shape (P,) [m].
        failed: Share of frames without a fix, shape (P,).
    """

    localizer: str
    frames: int
    rms: FloatArray
    std: FloatArray
    bias: FloatArray
    failed: FloatArray


def monte_carlo(scenario: Scenario, points: FloatArray, seen: BoolArray, localizer: str,
                frames: int, seed: int = 0,
                progress: Callable[[int, int], None] | None = None) -> MonteCarlo:
    """Run ``frames`` frames at each point through ``localizer`` (module docstring).

    Args:
        scenario: The site (its map and error model).
        points: Camera positions (x, y), shape (P, 2) [m].
        seen: Which beacon each point sees, shape (P, N) over the map's beacons.
        localizer: A localizer spec (``ransac``, ``ransac:weighted=true``, ...).
        frames: Frames per cell, >= 1.
        seed: Seed of every draw.
        progress: Called with (cells done, cells) after every tenth of the cells.
    """
    from azgym.localize.registry import make_localizer

    built = make_localizer(localizer)
    figures = np.full((4, len(points)), np.nan)
    for p, (x, y) in enumerate(points):
        rng = np.random.default_rng([seed, p])
        figures[:, p] = _cell(scenario, built, float(x), float(y), seen[p], frames, rng)
        if progress is not None and (p + 1) * 10 // len(points) > p * 10 // len(points):
            progress(p + 1, len(points))
    rms, std, bias, failed = figures
    return MonteCarlo(localizer, frames, rms, std, bias, failed)


def _cell(scenario: Scenario, localizer: SupportsLocalize, x: float, y: float, seen: BoolArray,
          frames: int, rng: np.random.Generator) -> tuple[float, float, float, float]:
    """(rms, std, bias, failed share) of one cell's frames."""
    beacons = scenario.beacons
    if np.count_nonzero(seen) < MIN_BEACONS:  # no fix possible: the localizer is not asked
        return math.nan, math.nan, math.nan, 1.0
    sub = BeaconMap(beacons.ids[seen], beacons.xyz[seen], beacons.width[seen])
    bearing, distance = ideal_azimuths(x, y, 0.0, sub)
    heading = rng.uniform(-math.pi, math.pi, size=frames)
    noise = scenario.error_model.sample(np.broadcast_to(distance, (frames, len(sub))),
                                        sub.width, rng)
    azimuth = wrap_angle(bearing[None, :] - heading[:, None] + noise)
    errors = []
    for f in range(frames):
        estimate = localizer.localize(Measurements(sub.ids, azimuth[f]), beacons)
        if estimate.ok:
            errors.append((estimate.x - x, estimate.y - y))
    if not errors:
        return math.nan, math.nan, math.nan, 1.0
    e = np.array(errors)
    rms = math.sqrt(float(np.mean(np.sum(e * e, axis=1))))
    std = math.sqrt(float(np.sum(np.var(e, axis=0, ddof=1)))) if len(e) > 1 else math.nan
    return rms, std, float(np.hypot(*e.mean(axis=0))), 1.0 - len(e) / frames
