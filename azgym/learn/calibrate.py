"""Calibrating ng-ransac's answer test: how much inlier probability an answer's supporters need.

ng-ransac (:mod:`azgym.localize.learned.ng_ransac`) answers only when the summed inlier probability
of its winning pose's supporters reaches ``min_support_weight``. Too low a threshold keeps the wrong
answers that three ghosts agree on; too high a one drops right answers. The threshold shipped with
the weights is the largest that gives up at most ``max_right_lost`` of the right answers
(within 1 m) on frames of held-out generated warehouses: the test should refuse what cannot be
known, not what can.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from azgym.learn.dataset import FrameBatch
from azgym.localize import _kernels as K
from azgym.localize.base import INT_ROWS, ROW_BEACON_INDEX, ROW_SOURCE
from azgym.localize.learned.inlier_network import InlierScorer
from azgym.localize.learned.ng_ransac import MODEL_NAME
from azgym.localize.learned.ng_search import guided_settings, ng_ransac_search
from azgym.localize.learned.weights import load_weights, save_weights
from azgym.localize.ransac import OUT_SIZE, OUT_SUPPORT, settings_array

__all__ = ["GuidedRuns", "RIGHT_M", "calibrate_weights", "card_section", "choose_threshold",
           "guided_runs"]

RIGHT_M = 1.0
"""An answer within this distance of the truth [m] is right; beyond it, wrong."""
DEFAULT_RIGHT_LOST = 0.005
"""Share of the held-out right answers the shipped threshold may give up."""


@dataclass(frozen=True)
class GuidedRuns:
    """ng-ransac's search on each frame of a batch, before its answer test.

    Attributes:
        answered: The search found a pose with at least three supporters, (N,).
        error: That pose's position error [m] (inf where none), (N,).
        support_weight: Its supporters' summed inlier probability (0 where none; inf where the
            consensus settled the frame without the network, so the answer test does not
            apply), (N,).
        hypotheses: Triplets the guided search tried (the features' consensus triplets not
            counted; 0 where the consensus settled the frame), (N,).
    """

    answered: np.ndarray
    error: np.ndarray
    support_weight: np.ndarray
    hypotheses: np.ndarray


def guided_runs(batch: FrameBatch, scorer: InlierScorer) -> GuidedRuns:
    """ng-ransac's search (its default settings) on every frame, before its answer test.

    The frames come from the geometry sensor, which always reports quality: its first column is
    the batch's ``quality``.
    """
    settings = guided_settings(settings_array())
    count = batch.pose.shape[0]
    answered = np.zeros(count, dtype=bool)
    error = np.full(count, np.inf)
    weight = np.zeros(count)
    hypotheses = np.zeros(count, dtype=np.int64)
    out, cov = np.empty(OUT_SIZE), np.empty((3, 3))
    for n in range(count):
        size = int(batch.mask[n].sum())
        floats = np.ascontiguousarray(batch.floats[n][:, :size])
        ints = np.empty((INT_ROWS, size), dtype=np.int64)
        ints[ROW_SOURCE] = np.arange(size)
        ints[ROW_BEACON_INDEX] = batch.beacon_index[n, :size]
        distinct = int(np.unique(ints[ROW_BEACON_INDEX]).size)
        mask = np.zeros(size, dtype=np.bool_)
        hypotheses[n], tested = ng_ransac_search(
            floats, ints, distinct, np.ascontiguousarray(batch.quality[n, :size]), True,
            scorer.params, scorer.hidden, settings, out, mask, cov)
        if out[OUT_SUPPORT] < 3 or not np.isfinite(out[K.POSE_X]):
            continue
        answered[n] = True
        error[n] = float(np.hypot(out[K.POSE_X] - batch.pose[n, 0],
                                  out[K.POSE_Y] - batch.pose[n, 1]))
        weight[n] = np.inf if np.isnan(tested) else tested
    return GuidedRuns(answered, error, weight, hypotheses)


def choose_threshold(runs: GuidedRuns,
                     max_right_lost: float = DEFAULT_RIGHT_LOST) -> dict[str, Any]:
    """The largest support threshold losing at most ``max_right_lost`` of the right answers.

    The share is of every right answer, those of a confident consensus too: the test never sees
    them (their weight is inf), so the answers it gives up all come from the frames the network
    decided. Returns the threshold and what it does on these frames: right and wrong answers
    kept, out of those the search gave.
    """
    right = runs.answered & (runs.error <= RIGHT_M)
    wrong = runs.answered & (runs.error > RIGHT_M)
    tested = np.isfinite(runs.support_weight)
    weights = np.sort(runs.support_weight[right])
    allowed = int(np.floor(max_right_lost * weights.size))
    tested_right = int((right & tested).sum())  # the finite weights lead the sorted ones
    # Never above the heaviest tested right answer: a finite threshold that keeps it.
    threshold = float(weights[min(allowed, tested_right - 1)]) if tested_right else 0.0
    kept = runs.support_weight >= threshold
    return {
        "min_support_weight": threshold,
        "max_right_lost": max_right_lost,
        "frames": int(runs.answered.size),
        "right_before": int(right.sum()), "wrong_before": int(wrong.sum()),
        "right_kept": int((right & kept).sum()), "wrong_kept": int((wrong & kept).sum()),
        "untested": int((runs.answered & ~tested).sum()),
    }



def calibrate_weights(path: Path, held_out: FrameBatch,
                      max_right_lost: float = DEFAULT_RIGHT_LOST) -> dict[str, Any]:
    """Write the calibrated answer test into a weight file's manifest (``calibration``).

    Returns the calibration: the threshold and what it did on ``held_out``, the median number of
    triplets the guided search tried there, and how many frames it had.
    """
    arrays, manifest = load_weights(path, MODEL_NAME)
    runs = guided_runs(held_out, InlierScorer(arrays, manifest))
    calibration = choose_threshold(runs, max_right_lost)
    calibration["search_hypotheses_median"] = float(np.median(runs.hypotheses))
    kept = {key: value for key, value in manifest.items()
            if key not in ("format", "model", "azgym_version")}
    save_weights(path, MODEL_NAME, arrays, {**kept, "calibration": calibration})
    return calibration


def card_section(calibration: dict[str, Any]) -> str:
    """The model card's account of the calibration (markdown)."""
    return "\n".join([
        "## Calibration of the answer test", "",
        f"- min_support_weight: {calibration['min_support_weight']:.3f}, the largest threshold "
        f"that gives up at most {calibration['max_right_lost']:.1%} of the right answers "
        "(within 1 m) on the held-out frames",
        f"- held-out frames: {calibration['frames']}; the guided search alone answered "
        f"{calibration['right_before']} right and {calibration['wrong_before']} wrong; with the "
        f"test {calibration['right_kept']} right and {calibration['wrong_kept']} wrong; "
        f"{calibration['untested']} answers came from a confident consensus, which the test "
        "does not see",
        f"- median triplets tried by the search (beyond the features' consensus): "
        f"{calibration['search_hypotheses_median']:.0f}", ""])
