"""Error statistics of a set of estimates, the way EvAAL and ISO/IEC 18305 report them.

A missing estimate (``ok=False``) is never a zero error. The **headline**, ``p75_all_cm``, is the
75th percentile of the position error over *every* frame, a frame without an estimate counting as an
infinite error (the EvAAL competitions' rule): a method cannot improve it by refusing the frames it
would get wrong, and it is infinite when more than a quarter of the frames got no estimate. Boards
rank by it (:func:`azgym.bench.report.table.rank_key`). Beside it, availability says how many frames
got an estimate, the failure rate counts a missing estimate or one more than
:data:`FAILURE_DISTANCE` off as a failure, and the other error statistics (mean, median, p75, p95,
...) describe the frames that got an estimate. Heading errors are NaN where the truth has no heading
(a log's position-only truth): the heading figures leave them out, and are None (``null`` in
results.json) when no answered frame has a true heading to score against.

Intervals (:func:`confidence_intervals`) come from a bootstrap that respects how the frames
were drawn: frames on their own are resampled one by one, the frames of a driven route in
blocks of :data:`BLOCK_SECONDS` (:func:`bootstrap_blocks`), since consecutive frames of a route
share the pose, the occlusions and the tracker's state and are far from independent.

Drift (:func:`relative_pose_errors`, :func:`summarize_drift`) is evo's relative pose error (RPE)
per distance travelled, as ``evo_rpe tum TRUTH EST --delta D --delta_unit m --all_pairs
--pairs_from_reference`` computes it (no alignment): between the poses of every pair of frames
whose path along the truth is D metres (within :data:`DRIFT_TOLERANCE` of D, the pair nearest to
D from each start), the error of the estimated motion against the true one, expressed in the
first pose's frame. Pairs are chosen on the truth, so that every contender is scored over the
same stretches, however its estimates jitter; from every start (``all_pairs``), not in
back-to-back segments, so that a figure does not depend on where a route begins and a
segment's path is D within the tolerance rather than D plus up to one frame's step.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Final, Generic, TypedDict, TypeVar

import numpy as np
from numpy.typing import ArrayLike

from azgym.core import wrap_angle

__all__ = ["BLOCK_SECONDS", "DRIFT_DISTANCES", "DRIFT_TOLERANCE", "FAILURE_DISTANCE", "HEADLINE",
           "Drift", "ErrorStats", "Figure", "Intervals", "bootstrap_blocks",
           "confidence_intervals", "path_pairs", "quantile", "relative_pose_errors",
           "summarize_drift", "summarize_errors"]

FAILURE_DISTANCE = 1.0
"""An estimate further than this from the truth [m] is a failure."""
HEADLINE: Final = "p75_all_cm"
"""The headline figure: the p75 position error over every frame, a refusal infinite [cm]."""
BLOCK_SECONDS = 5.0
"""The length of a route's bootstrap blocks [s]: consecutive frames of a route closer than this
in time are resampled together (a block bootstrap). The errors of a route stay correlated over
seconds (the same aisle, the same occluding rack, a tracker's state); with shorter blocks the
intervals on the route suites are too narrow (docs/leaderboard.md gives the coverage check)."""
RESAMPLES = 400
"""Bootstrap resamples per interval."""
_BATCH = 50
"""Resamples drawn at a time, to bound memory."""
DRIFT_DISTANCES: Final = (1.0, 5.0, 10.0)
"""The distances travelled of the drift figures [m] (:func:`relative_pose_errors`)."""
DRIFT_TOLERANCE: Final = 0.1
"""A pair's path along the truth may miss its distance by this share of it (evo's
``--delta_tol``, 0.1 by default)."""

Figure = TypeVar("Figure", bound=float | None)
"""How a figure is held: ``float`` as computed (NaN where there is none, inf where it is
infinite), ``float | None`` as JSON keeps it (a leaderboard entry: null for either)."""


class ErrorStats(TypedDict, Generic[Figure]):
    """Error statistics of a set of estimates (:func:`summarize_errors`).

    ``p75_all_cm`` is over every run, a missing estimate infinite; the others (position errors
    [cm], heading errors [deg]) over the runs with an estimate. A heading figure is None when
    estimates were given but the truth has no heading to score them against.
    """

    n: int
    availability: Figure
    failure_rate: Figure
    p75_all_cm: Figure
    mean_cm: Figure
    rmse_cm: Figure
    median_cm: Figure
    p75_cm: Figure
    p90_cm: Figure
    p95_cm: Figure
    max_cm: Figure
    heading_mean_deg: Figure | None
    heading_median_deg: Figure | None


class Intervals(TypedDict, Generic[Figure]):
    """95 % intervals [low, high] of three figures (:func:`confidence_intervals`)."""

    p75_all_cm: list[Figure]
    mean_cm: list[Figure]
    failure_rate: list[Figure]


def quantile(errors: ArrayLike, q: float) -> float:
    """The ``q``-quantile of errors that may be infinite (a refusal), linearly interpolated.

    Equal to ``numpy.percentile(errors, 100 q)`` (the "linear" method) when every error is
    finite; a quantile that falls at or past the first infinite error is infinite (NumPy's
    interpolation gives NaN there).

    Args:
        errors: The errors, ``inf`` for a refusal; NaN is not allowed.
        q: The quantile, in [0, 1].
    """
    values = np.sort(np.asarray(errors, dtype=float).ravel())
    if values.size == 0:
        return math.nan
    return float(_sorted_quantile(values[None, :], np.array([values.size]), q)[0])


def _sorted_quantile(rows: np.ndarray, counts: np.ndarray, q: float) -> np.ndarray:
    """The ``q``-quantile of each row's first ``counts`` values, each row sorted ascending."""
    position = (counts - 1) * q
    below = np.floor(position).astype(int)
    above = np.minimum(below + 1, counts - 1)
    index = np.arange(rows.shape[0])
    return _interpolated(rows[index, below], rows[index, above], position - below)


def _resampled_quantile(chosen: np.ndarray, ranked: np.ndarray, ranked_block: np.ndarray,
                        count: int, q: float) -> np.ndarray:
    """The ``q``-quantile of each resample's frames, without sorting them.

    A resample (a row of ``chosen``, the blocks it draws) takes each block ``m`` times; its
    k-th smallest error is where the running count of the frames ranked by error (``ranked``,
    ascending, each of block ``ranked_block``), each counted ``m`` times, first passes k: the
    very value a sort of the resample's frames puts at k.
    """
    chosen = chosen.reshape(chosen.shape[0], -1)
    rows = chosen.shape[0]
    taken = np.bincount((chosen + count * np.arange(rows)[:, None]).ravel(),
                        minlength=rows * count).reshape(rows, count)
    running = np.cumsum(taken[:, ranked_block], axis=1)
    position = (running[:, -1] - 1) * q
    below = np.floor(position).astype(int)
    above = np.minimum(below + 1, running[:, -1] - 1)
    return _interpolated(ranked[(running <= below[:, None]).sum(axis=1)],
                         ranked[(running <= above[:, None]).sum(axis=1)], position - below)


def _interpolated(low: np.ndarray, high: np.ndarray, fraction: np.ndarray) -> np.ndarray:
    """Linear interpolation between neighbouring order statistics; infinite past a refusal."""
    with np.errstate(invalid="ignore"):  # inf - inf where both are refusals: chosen below
        between = low + fraction * (high - low)
    return np.where(fraction == 0.0, low, np.where(np.isinf(high), np.inf, between))


def summarize_errors(
    position_error: ArrayLike, heading_error: ArrayLike, ok: ArrayLike
) -> ErrorStats[float]:
    """Statistics of position errors [m → cm] and heading errors [rad → deg].

    Args:
        position_error: 2-D position error of each run [m]; ignored where not ``ok``.
        heading_error: Absolute heading error of each run [rad]; ignored where not ``ok``.
        ok: Whether each run produced an estimate.

    Returns:
        n, availability, failure_rate, the headline ``p75_all_cm`` (every run, a missing
        estimate infinite; NaN without runs), and over the runs with an estimate:
        mean/rmse/median/p75/p90/p95/max position error in cm and mean/median heading error in
        degrees (NaN when no run produced an estimate). The heading figures are over the runs
        whose heading error is known (not NaN: the truth has a heading), and None when an
        estimate was produced but none of them is: position-only truth, heading not scored.
    """
    ok = np.asarray(ok, dtype=bool)
    position = np.asarray(position_error, dtype=float)[ok] * 100.0
    heading = np.degrees(np.asarray(heading_error, dtype=float)[ok])
    heading = heading[~np.isnan(heading)]
    n = int(ok.size)
    failures = int(np.count_nonzero(~ok)) + int(np.count_nonzero(position > FAILURE_DISTANCE * 100))
    heading_mean: float | None
    heading_median: float | None
    if position.size:
        q50, q75, q90, q95 = (float(q) for q in np.percentile(position, [50, 75, 90, 95]))
        mean, rmse = float(position.mean()), float(np.sqrt(np.mean(position**2)))
        worst = float(position.max())
        heading_mean = float(heading.mean()) if heading.size else None
        heading_median = float(np.median(heading)) if heading.size else None
    else:
        q50 = q75 = q90 = q95 = mean = rmse = worst = heading_mean = heading_median = math.nan
    return {
        "n": n,
        "availability": float(ok.mean()) if n else math.nan,
        "failure_rate": failures / n if n else math.nan,
        HEADLINE: quantile(np.concatenate([position, np.full(n - position.size, np.inf)]), 0.75),
        "mean_cm": mean,
        "rmse_cm": rmse,
        "median_cm": q50,
        "p75_cm": q75,
        "p90_cm": q90,
        "p95_cm": q95,
        "max_cm": worst,
        "heading_mean_deg": heading_mean,
        "heading_median_deg": heading_median,
    }


def bootstrap_blocks(sequences: Sequence[str], times: ArrayLike,
                     block_seconds: float = BLOCK_SECONDS) -> np.ndarray:
    """The bootstrap block of each frame, numbered from 0 in order of first appearance.

    A frame on its own (sequence "") is a block of one. The frames of a sequence are cut into
    blocks of ``block_seconds`` counted from the sequence's earliest frame; a frame without a
    time (NaN) is a block of one.

    Args:
        sequences: Each frame's sequence ("" for none).
        times: Each frame's time in its sequence [s].
        block_seconds: The block length [s].
    """
    times = np.asarray(times, dtype=float)
    starts: dict[str, float] = {}
    for name, time in zip(sequences, times, strict=True):
        if name and math.isfinite(time):
            starts[name] = min(starts.get(name, time), time)
    numbers: dict[tuple[str, int], int] = {}
    blocks = np.empty(len(times), dtype=np.int64)
    for k, (name, time) in enumerate(zip(sequences, times, strict=True)):
        key = (name, int((time - starts[name]) // block_seconds)) \
            if name and math.isfinite(time) else ("", -1 - k)
        blocks[k] = numbers.setdefault(key, len(numbers))
    return blocks


def confidence_intervals(position: np.ndarray, ok: np.ndarray, blocks: np.ndarray,
                         seed: int = 0) -> Intervals[float]:
    """95 % percentile-bootstrap intervals of the headline, the mean error [cm] and failure rate.

    Whole blocks (:func:`bootstrap_blocks`) are resampled with replacement, as many as there
    are: of ``n`` blocks, each resample's block numbers are a row of ``Generator.integers(0,
    n)`` drawn :data:`_BATCH` rows at a time, the draws of ``scipy.stats.bootstrap`` (so the
    intervals are the ones its percentile method gives, without its half-second import); a
    missing estimate stays a refusal. The headline's bounds may be infinite. With fewer than two
    blocks there is no interval (NaN). The generator is seeded, so the intervals repeat like the
    figures.

    Args:
        position: Each frame's position error [m] (ignored where not ``ok``).
        ok: Whether each frame got an estimate.
        blocks: Each frame's block, numbered 0, 1, ... (:func:`bootstrap_blocks`).
        seed: The bootstrap's seed.
    """
    count = int(blocks.max()) + 1 if blocks.size else 0
    if count < 2:
        return {HEADLINE: [math.nan, math.nan], "mean_cm": [math.nan, math.nan],
                "failure_rate": [math.nan, math.nan]}
    error = np.where(ok, position * 100.0, np.inf)
    by_error = np.argsort(error, kind="stable")
    order = np.argsort(blocks, kind="stable")
    sizes = np.bincount(blocks, minlength=count)
    padded = np.full((count, int(sizes.max())), np.nan)  # block × frame, NaN past its end
    padded[blocks[order], np.arange(blocks.size) - np.repeat(np.cumsum(sizes) - sizes, sizes)] \
        = error[order]

    def statistics(chosen: np.ndarray) -> np.ndarray:
        frames = padded[chosen].reshape(chosen.shape[0], -1)  # resample × frames (NaN-padded)
        counts = np.count_nonzero(~np.isnan(frames), axis=1)
        answered = np.isfinite(frames)
        mean = np.where(answered, frames, 0.0).sum(axis=1) / np.maximum(answered.sum(axis=1), 1)
        failed = (np.isinf(frames) | (frames > FAILURE_DISTANCE * 100)).sum(axis=1) / counts
        headline = _resampled_quantile(chosen, error[by_error], blocks[by_error], count, 0.75)
        return np.stack([headline, np.where(answered.any(axis=1), mean, np.nan), failed])

    draws = np.random.default_rng(seed)
    distribution = np.concatenate(
        [statistics(draws.integers(0, count, size=(min(_BATCH, RESAMPLES - done), count)))
         for done in range(0, RESAMPLES, _BATCH)], axis=1)
    headline, mean, failed = (_percentile_interval(values) for values in distribution)
    return {HEADLINE: headline, "mean_cm": mean, "failure_rate": failed}


def _percentile_interval(values: np.ndarray) -> list[float]:
    """The 2.5 % and 97.5 % quantiles of a bootstrap distribution (NaN resamples left out)."""
    values = values[~np.isnan(values)]
    if values.size == 0:  # no estimate in any resample: no interval either
        return [math.nan, math.nan]
    return [quantile(values, 0.025), quantile(values, 0.975)]


class Drift(TypedDict, Generic[Figure]):
    """The drift over one distance travelled (:func:`summarize_drift`).

    Attributes:
        distance_m: The distance D [m].
        pairs: The pairs of frames D apart along the truth.
        translation_pct: The mean translation error of the relative poses, as a share of D [%]
            (NaN without pairs, or without a true heading).
        heading_deg_per_m: The mean heading error of the relative poses over D [°/m] (NaN
            likewise).
    """

    distance_m: float
    pairs: int
    translation_pct: Figure
    heading_deg_per_m: Figure


def path_pairs(xy: ArrayLike, distance: float, tolerance: float = DRIFT_TOLERANCE
               ) -> np.ndarray:
    """The pairs (i, j) of points whose path from i to j is ``distance`` long, evo's way.

    evo's ``filter_pairs_by_path`` with ``all_pairs``: from each start i, the later point j
    whose path length is nearest to ``distance`` (the first such point, e.g. where the vehicle
    stood), kept when it misses ``distance`` by at most ``tolerance · distance``. The path
    length is summed from straight steps between consecutive points, as evo sums it. Found by
    bisection on the summed path (the candidates round the crossing are then compared with
    evo's very expression), so a long recording costs n log n, not evo's n².

    Args:
        xy: The points, shape (n, 2) [m].
        distance: The path length D [m].
        tolerance: The share of D a pair may miss it by.

    Returns:
        The pairs, shape (P, 2), in order of their start.
    """
    points = np.asarray(xy, dtype=float).reshape(-1, 2)
    count = len(points)
    if count < 2:
        return np.zeros((0, 2), dtype=np.int64)
    travelled = np.concatenate(([0.0], np.cumsum(np.linalg.norm(points[:-1] - points[1:],
                                                                axis=1))))
    start = np.arange(count - 1)
    crossing = np.searchsorted(travelled, travelled[start] + distance, side="right")
    window = np.clip(crossing[:, None] + np.arange(-2, 2), start[:, None] + 1, count - 1)
    # The first point of a stop (equal path lengths), which evo's argmin picks among them.
    window = np.maximum(np.searchsorted(travelled, travelled[window], side="left"),
                        start[:, None] + 1)
    miss = np.abs((travelled[window] - travelled[start][:, None]) - distance)
    best = np.argmin(miss, axis=1)  # the first of equal misses: the earliest point
    rows = np.arange(count - 1)
    keep = miss[rows, best] <= distance * tolerance
    return np.column_stack([start[keep], window[rows, best][keep]])


def relative_pose_errors(truth: ArrayLike, estimate: ArrayLike, distance: float
                         ) -> tuple[np.ndarray, np.ndarray]:
    """The relative pose errors (evo's RPE) of the pairs ``distance`` apart along the truth.

    For a pair (i, j) (:func:`path_pairs` on the true positions), E = (Qᵢ⁻¹ Qⱼ)⁻¹ (Pᵢ⁻¹ Pⱼ)
    with Q the true poses and P the estimated ones: its translation part's length is that of
    the estimated motion minus the true one, each in its first pose's frame, and its rotation
    angle the estimated turn minus the true one, wrapped. A true heading of NaN
    (position-only truth) gives NaN: the translation part is not defined without it.

    Args:
        truth: The true poses (x, y, heading), shape (n, 3) [m, m, rad].
        estimate: The estimated poses at the same frames, shape (n, 3).
        distance: The path length D [m].

    Returns:
        Each pair's translation error [m] and rotation error [rad, in [0, π]].
    """
    true_poses, estimated = (np.asarray(poses, dtype=float).reshape(-1, 3)
                             for poses in (truth, estimate))
    first, last = path_pairs(true_poses[:, :2], distance).T

    def motion(poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Each pair's step in its first pose's frame, and its turn."""
        step = poses[last, :2] - poses[first, :2]
        cos, sin = np.cos(poses[first, 2]), np.sin(poses[first, 2])
        return (np.column_stack([cos * step[:, 0] + sin * step[:, 1],
                                 cos * step[:, 1] - sin * step[:, 0]]),
                poses[last, 2] - poses[first, 2])

    (true_step, true_turn), (step, turn) = motion(true_poses), motion(estimated)
    return (np.linalg.norm(step - true_step, axis=1),
            np.abs(wrap_angle(turn - true_turn)).reshape(-1))


def summarize_drift(translation: ArrayLike, rotation: ArrayLike, distance: float
                    ) -> Drift[float]:
    """The drift over ``distance``: the mean errors of its pairs (:func:`relative_pose_errors`).

    ``translation_pct`` is evo's mean translation error over D, in %; ``heading_deg_per_m``
    its mean rotation angle in degrees over D. Pairs pooled from several routes count alike.

    Args:
        translation: Each pair's translation error [m].
        rotation: Each pair's rotation error [rad].
        distance: The path length D [m].
    """
    moved, turned = (np.asarray(values, dtype=float).reshape(-1) for values in
                     (translation, rotation))
    if moved.size == 0:
        return {"distance_m": distance, "pairs": 0, "translation_pct": math.nan,
                "heading_deg_per_m": math.nan}
    return {"distance_m": distance, "pairs": int(moved.size),
            "translation_pct": 100.0 * float(np.mean(moved)) / distance,
            "heading_deg_per_m": float(np.degrees(np.mean(turned))) / distance}
