"""The motion fits of ``azgym calibrate``: a read rate against the truth, with a wandering error.

Both the odometry's speed and a turn rate are fitted by one model, per interval k between two
consecutive frames of a sequence:

    y_k = a_k (x₀ + d_k) + e_k,   d_k = d_{k−1} + N(0, q² Δt_k),   e_k ~ N(0, σ² W_k),

where x₀ is the error's value at the sequence's start, d its random walk (scale walk, bias walk:
q), and e the white noise of the samples (σ per sample; W_k = Σ span² of the samples' holds in
the interval, so a sample's noise σ adds σ·span to the integral). The speed: y = the distance
the odometry read, a = the true distance along the heading, x₀ = the read scale (1 / the speed
factor), so that σ is in the odometry's own units and the truth is the regressor. The turn
rate: y = the true heading change minus the read one, a = −(seconds read), x₀ = the bias.

A sample holds its value until the next sample, for at most max(``HOLD_PERIODS`` median
periods, ``HOLD_FLOOR_S``): the trackers' rule (:class:`azgym.track.unicycle.MotionSteps`), so
that a logger's jitter is held over and a stopped stream is not; an interval the samples do not
cover whole is left out. The likelihood is exact: a Kalman filter on
d, with x₀ entering linearly and so solved in closed form (generalized least squares), evaluated
on a grid of (σ, q) and then on a finer grid around its peak. σ and q are fitted by restricted
maximum likelihood (x₀ integrated out, which takes away plain maximum likelihood's pull of the
walk towards zero), x₀ by maximum likelihood. Each 95 % interval is the profile likelihood's
(likelihood ratio under χ²₁'s 95 % point, 3.84): exact in the time dependence the model
states, and reaching q = 0 when the walk is not seen. Before the fit, an interval whose
residual stands out of its neighbours' by more than :data:`GROSS` robust standard deviations (a
glitch of the truth) is left out (:func:`not_gross`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from azgym.core import BoolArray, FloatArray
from azgym.track.unicycle import HOLD_FLOOR_S, HOLD_PERIODS

__all__ = ["GROSS", "Integrated", "WalkFit", "fit_walk", "integrate", "not_gross"]

CHI2_95 = 3.841458820694124
"""The likelihood-ratio bound of a 95 % interval for one parameter: ``scipy.stats.chi2.ppf(0.95,
1)``, written out (a test checks it) since importing scipy.stats would cost every command line
half a second."""
GRID = 41
"""Grid points per parameter, in each of the two passes."""
GROSS = 8.0
"""An interval whose residual lies more than this many robust standard deviations from its
neighbours' is a gross error (a glitch of the truth, a stuck sample), left out of the fit."""
NEIGHBOURS = 31
"""The intervals (centred) whose median residual an interval is compared with: the walk's slow
drift is theirs too."""


@dataclass(frozen=True, eq=False)
class Integrated:
    """A sampled rate integrated over each frame interval (forward hold, capped).

    Attributes:
        total: The integral of the rate over each interval (distance [m], angle [rad]).
        squares: Σ span² of the samples' holds in each interval [s²] (W_k above).
        seconds: The seconds the samples covered in each interval [s].
        covered: Whether the samples covered the interval whole.
    """

    total: FloatArray
    squares: FloatArray
    seconds: FloatArray
    covered: BoolArray


def integrate(frame_times: FloatArray, times: FloatArray, values: FloatArray) -> Integrated:
    """The rate ``values`` sampled at ``times``, integrated over the intervals of ``frame_times``.

    Each sample holds from its time until the next sample's, at most the trackers' limit (module
    docstring; the last one: one median period). Samples repeating a time stamp hold for
    nothing.
    """
    count = frame_times.size - 1
    if times.size < 2 or count < 1:
        empty = np.zeros(max(count, 0))
        return Integrated(empty, empty.copy(), empty.copy(), empty.astype(bool))
    gaps = np.diff(times)
    period = float(np.median(gaps[gaps > 0])) if (gaps > 0).any() else 0.0
    limit = max(HOLD_PERIODS * period, HOLD_FLOOR_S)
    ends = np.minimum(np.append(times[1:], times[-1] + period), times + limit)
    edges = np.unique(np.concatenate([times, ends, frame_times]))
    starts = edges[:-1]
    lengths = np.diff(edges)
    sample = np.searchsorted(times, starts, side="right") - 1
    interval = np.searchsorted(frame_times, starts, side="right") - 1
    use = (sample >= 0) & (interval >= 0) & (interval < count)
    use[use] &= starts[use] < ends[sample[use]]
    pair = sample[use].astype(np.int64) * count + interval[use]
    pairs, where = np.unique(pair, return_inverse=True)
    span = np.bincount(where, weights=lengths[use])
    pair_sample, pair_interval = pairs // count, pairs % count
    total = np.bincount(pair_interval, weights=span * values[pair_sample], minlength=count)
    squares = np.bincount(pair_interval, weights=span**2, minlength=count)
    seconds = np.bincount(pair_interval, weights=span, minlength=count)
    covered = seconds >= np.diff(frame_times) * (1.0 - 1e-9)
    # numpy's stub types bincount as intp even with weights; these are float64.
    return Integrated(total, squares, seconds, covered)  # type: ignore[arg-type]


@dataclass(frozen=True)
class WalkFit:
    """The model's maximum-likelihood parameters, each with its 95 % profile-likelihood interval.

    Attributes:
        start: x₀ and its interval.
        white: σ and its interval.
        walk: q and its interval (its lower end 0 when the walk is not seen).
        samples: Intervals used.
    """

    start: tuple[float, float, float]
    white: tuple[float, float, float]
    walk: tuple[float, float, float]
    samples: int


def not_gross(y: FloatArray, a: FloatArray, squares: FloatArray) -> BoolArray:
    """Which intervals are no gross error (:data:`GROSS`).

    The residual of one overall ratio, over its white noise's scale √W, minus the running
    median of :data:`NEIGHBOURS` intervals (which follows the walk), against its median
    absolute deviation, at least a thousandth of the data's own scale: in nearly exact data
    (a simulated camera's slide) the model's least imperfection is no gross error.
    """
    if y.size == 0:
        return np.zeros(0, dtype=bool)
    ratio = float(y @ a / (a @ a)) if np.any(a) else 0.0
    scaled = (y - ratio * a) / np.sqrt(squares)
    from scipy.ndimage import median_filter  # only a calibration pays for importing it

    wander = median_filter(scaled, size=NEIGHBOURS, mode="nearest")
    floor = 1e-3 * math.sqrt(float(np.mean(y**2 / squares)))
    spread = max(1.4826 * float(np.median(np.abs(scaled - wander))), floor)
    return np.abs(scaled - wander) <= GROSS * spread


def fit_walk(y: FloatArray, a: FloatArray, squares: FloatArray, seconds: FloatArray,
             first: BoolArray) -> WalkFit:
    """Fit the module's model to intervals in time order.

    Args:
        y: The observed y_k.
        a: The regressor a_k.
        squares: W_k [s²] (each > 0).
        seconds: Δt_k, the interval's length [s].
        first: Whether interval k starts a stretch (the walk restarts from x₀ there).
    """
    ratio = float(y @ a / (a @ a))
    sigma0 = max(math.sqrt(float(np.mean((y - ratio * a) ** 2 / squares))), 1e-12)
    walk0 = 3.0 * sigma0 * math.sqrt(float(np.mean(squares) / np.mean(seconds)
                                           / max(float(np.mean(a**2)), 1e-300)))
    sigma = sigma0 * np.logspace(-1.5, 0.5, GRID)
    walk = np.concatenate([[0.0], walk0 * np.logspace(-5, 0, GRID - 1)])
    loglik, _, information = _grid(y, a, squares, seconds, first, sigma, walk)  # coarse
    restricted = loglik - 0.5 * np.log(information)
    inside = 2.0 * (restricted.max() - restricted) <= CHI2_95 + 1.0
    sigma = _refined(sigma, inside.any(axis=1))  # then fine
    walk = _refined(walk, inside.any(axis=0))
    loglik, start, information = _grid(y, a, squares, seconds, first, sigma, walk)
    restricted = loglik - 0.5 * np.log(information)
    best = np.unravel_index(np.argmax(restricted), restricted.shape)
    deviance = 2.0 * (restricted.max() - restricted)
    full = 2.0 * (loglik.max() - loglik)
    room = np.sqrt(np.maximum(CHI2_95 - full, 0.0) / information)
    near = full <= CHI2_95
    return WalkFit(
        (float(start[best]), float((start - room)[near].min()), float((start + room)[near].max())),
        (float(sigma[best[0]]), *_interval(sigma, deviance.min(axis=1))),
        (float(walk[best[1]]), *_interval(walk, deviance.min(axis=0))), int(y.size))


def _grid(y: FloatArray, a: FloatArray, squares: FloatArray, seconds: FloatArray,
          first: BoolArray, sigma: FloatArray, walk: FloatArray
          ) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Profile log-likelihood, x̂₀ and x₀'s information at each (σ, q) of the grid.

    One Kalman filter on d per grid point, all at once: two right-hand sides (y and a) give
    the innovations as v^y − x₀ v^a, so x₀ is profiled out in closed form (generalized least
    squares on the innovations).
    """
    noise = (sigma**2)[:, None] * np.ones((1, walk.size))
    drift = np.ones((sigma.size, 1)) * (walk**2)[None, :]
    shape = noise.shape
    mean_y, mean_a, variance = np.zeros(shape), np.zeros(shape), np.zeros(shape)
    sum_yy, sum_ya, sum_aa, logdet = (np.zeros(shape) for _ in range(4))
    for k in range(y.size):
        if first[k]:
            mean_y[:], mean_a[:], variance[:] = 0.0, 0.0, 0.0
        variance += drift * seconds[k]
        innovation = a[k] * a[k] * variance + noise * squares[k]
        v_y = y[k] - a[k] * mean_y
        v_a = a[k] - a[k] * mean_a
        sum_yy += v_y * v_y / innovation
        sum_ya += v_y * v_a / innovation
        sum_aa += v_a * v_a / innovation
        logdet += np.log(innovation)
        gain = variance * a[k] / innovation
        mean_y += gain * v_y
        mean_a += gain * v_a
        variance -= gain * a[k] * variance
    information = np.maximum(sum_aa, 1e-300)
    loglik = -0.5 * (logdet + sum_yy - sum_ya**2 / information)
    return loglik, sum_ya / information, information


def _refined(values: FloatArray, inside: BoolArray) -> FloatArray:
    """A finer grid over the values inside (and one step beyond each side)."""
    where = np.flatnonzero(inside)
    low = values[max(where[0] - 1, 0)]
    high = values[min(where[-1] + 1, values.size - 1)]
    if low <= 0.0:
        return np.concatenate([[0.0], np.linspace(high / (GRID - 1), high, GRID - 1)])
    return np.geomspace(low, high, GRID)


def _interval(values: FloatArray, deviance: FloatArray) -> tuple[float, float]:
    """Where the profile deviance stays under :data:`CHI2_95`, its edges interpolated."""
    inside = np.flatnonzero(deviance <= CHI2_95)
    ends = []
    for edge, step in ((inside[0], -1), (inside[-1], 1)):
        outer = edge + step
        if not 0 <= outer < values.size:
            ends.append(float(values[edge]))
            continue
        share = (CHI2_95 - deviance[edge]) / (deviance[outer] - deviance[edge])
        ends.append(float(values[edge] + share * (values[outer] - values[edge])))
    return ends[0], ends[1]
