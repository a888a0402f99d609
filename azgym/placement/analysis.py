"""``azgym layout analyze``: the predicted σ, the beacons seen and a Monte Carlo check, per cell.

The prediction (:mod:`azgym.placement.information`) is computed for every cell at once; the Monte
Carlo check (:mod:`azgym.placement.monte_carlo`) runs frames through a localizer, cell by cell. Both
see the same beacons from each cell (:mod:`azgym.placement.visibility`). With a surveyed map's
covariances (:mod:`azgym.placement.surveyed`) the prediction adds the map's bias floor σ_map
(:func:`~azgym.placement.information.map_sigma`) and σ_total = sqrt(σ_pos² + σ_map²).
"""

from __future__ import annotations

import io
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from azgym.bench.run.isolation import DEFAULT_TIME_LIMIT
from azgym.core import BoolArray, FloatArray
from azgym.files import write_file
from azgym.placement.floor import Floor
from azgym.placement.information import (
    contributions,
    map_contributions,
    map_sigma,
    position_sigma,
)
from azgym.placement.monte_carlo import MonteCarlo, monte_carlo
from azgym.placement.objective import PENALTY_SIGMA, floor_figures
from azgym.placement.visibility import visible_beacons
from azgym.progress import Progress, counter
from azgym.site import Scenario

__all__ = ["ANALYSIS_FILES", "Prediction", "agreement", "analyze", "predict", "summary",
           "write_analysis"]

AGREEMENT = 0.10
"""A cell's Monte Carlo RMS agrees with the prediction within this relative difference."""
MAX_REASONS = 5
"""The most reasons for lost frames the summary lists (a plug-in may word each one apart)."""
_SUMMARY, _GRIDS, _FIGURE = "layout.json", "layout.npz", "layout.png"
ANALYSIS_FILES = (_SUMMARY, _GRIDS, _FIGURE)
"""What :func:`write_analysis` writes into its folder: what ``azgym layout analyze`` claims in
``--out``."""


@dataclass(frozen=True)
class Prediction:
    """The predicted accuracy of a layout over the floor's cells.

    Attributes:
        floor: The grid.
        seen: Which beacon each cell sees, shape (P, B).
        sigma: Predicted σ_pos = sqrt(C_xx + C_yy) [m], inf where undetermined, shape (P,).
        map_sigma: The surveyed map's bias floor σ_map [m], shape (P,), or None without a
            survey's covariances.
    """

    floor: Floor
    seen: BoolArray
    sigma: FloatArray
    map_sigma: FloatArray | None = None

    @property
    def total(self) -> FloatArray | None:
        """σ_total = sqrt(σ_pos² + σ_map²) [m], or None without a survey's covariances."""
        return None if self.map_sigma is None else np.hypot(self.sigma, self.map_sigma)

    @property
    def visible(self) -> FloatArray:
        """Beacons seen from each cell, shape (P,)."""
        return self.seen.sum(axis=1)


def predict(scenario: Scenario, floor: Floor, progress: Progress | None = None,
            covariance: FloatArray | None = None) -> Prediction:
    """The prediction for the scenario's own beacons (their mapped places).

    ``progress`` hears the count of cells whose line of sight is tested; ``covariance``, each
    beacon position's Σ_b of a surveyed map, shape (B, 2, 2) [m²], adds the map's bias floor.
    """
    points = floor.points
    beacons = scenario.beacons
    with counter(progress, "line of sight", len(points), "cells") as tested:
        seen = visible_beacons(scenario, points, beacons.xyz, beacons.width, tested)
    information = contributions(points, beacons.xy, beacons.width, scenario.error_model,
                                seen).sum(axis=1)
    count = seen.sum(axis=1)
    floor_sigma = None if covariance is None else map_sigma(
        information, map_contributions(points, beacons.xy, beacons.width, covariance,
                                       scenario.error_model, seen).sum(axis=1), count)
    return Prediction(floor, seen, position_sigma(information, count), floor_sigma)


def analyze(scenario: Scenario, floor: Floor, localizer: str, frames: int, seed: int = 0,
            progress: Progress | None = None, *, workers: int = 1,
            time_limit: float = DEFAULT_TIME_LIMIT,
            covariance: FloatArray | None = None) -> tuple[Prediction, MonteCarlo | None]:
    """The prediction, and with ``frames`` > 0 the Monte Carlo check of ``localizer``.

    ``progress`` hears the cells counted, as the line of sight is tested and as the Monte Carlo
    check runs (:func:`azgym.progress.counter`); ``workers`` and ``time_limit`` are the
    runner's (:func:`~azgym.placement.monte_carlo.monte_carlo`); ``covariance`` is
    :func:`predict`'s. The Monte Carlo check draws the frames' noise only, on the true map.
    """
    prediction = predict(scenario, floor, progress, covariance)
    if frames <= 0:
        return prediction, None
    checked = monte_carlo(scenario, floor.points, prediction.seen, localizer, frames, seed,
                          progress, workers=workers, time_limit=time_limit)
    return prediction, checked


def summary(scenario: Scenario, prediction: Prediction, checked: MonteCarlo | None,
            absent: tuple[int, ...] = ()) -> dict[str, Any]:
    """The figures of an analysis (the command's printout and ``layout.json``).

    With a survey's covariances, ``survey`` holds the map's bias floor σ_map and σ_total over
    the floor, the median share σ_map² / σ_total² of the cells with a fix, and the ``absent``
    ids (the scenario's beacons the surveyed map lacks).
    """
    result: dict[str, Any] = {"scenario": scenario.name, "step_m": prediction.floor.step,
                              "beacons": len(scenario.beacons), "penalty_sigma_m": PENALTY_SIGMA,
                              "predicted": floor_figures(prediction.sigma, prediction.visible)}
    total = prediction.total
    if prediction.map_sigma is not None and total is not None:
        fixed = np.isfinite(total) & (total > 0)
        share = prediction.map_sigma[fixed] ** 2 / total[fixed] ** 2
        result["survey"] = {"absent_ids": list(absent),
                            "map_bias_floor": floor_figures(prediction.map_sigma),
                            "total": floor_figures(total, prediction.visible),
                            "map_share_of_variance_median":
                                float(np.median(share)) if share.size else None}
    if checked is not None:
        result["monte_carlo"] = agreement(prediction.sigma, checked)
    return result


def agreement(sigma: FloatArray, checked: MonteCarlo) -> dict[str, Any]:
    """How the Monte Carlo RMS compares with the prediction.

    The ratios are over the cells where both are finite; ``rms`` holds the RMS's floor figures
    as :func:`~azgym.placement.objective.floor_figures` computes the prediction's (a cell without a
    fix counting as the penalty), so that the two p95 compare. ``failed_share`` is the share of
    frames without a fix over the cells the localizer was run at (``cells_run``, those seeing
    three beacons or more; the ``cells_not_run`` have no fix); ``lost_frames`` counts the frames
    lost to an exception or a time-out by reason (the most frequent :data:`MAX_REASONS`).
    """
    both = np.isfinite(sigma) & np.isfinite(checked.rms)
    ratio = checked.rms[both] / sigma[both]
    std_ratio = checked.std[both] / sigma[both]
    rms = np.where(np.isnan(checked.rms), np.inf, checked.rms)
    asked = checked.asked
    lost = sorted(checked.problems.items(), key=lambda item: -item[1])
    return {"localizer": checked.localizer, "frames": checked.frames,
            "rms": floor_figures(rms),
            "cells_compared": int(both.sum()),
            "ratio_median": float(np.median(ratio)) if both.any() else None,
            "share_within_10pct": float(np.mean(np.abs(ratio - 1) <= AGREEMENT))
            if both.any() else None,
            "std_share_within_10pct": float(np.mean(np.abs(std_ratio - 1) <= AGREEMENT))
            if both.any() else None,
            "cells_run": int(asked.sum()), "cells_not_run": int((~asked).sum()),
            "failed_share": float(np.mean(checked.failed[asked])) if asked.any() else None,
            "lost_frames": {reason: count for reason, count in lost[:MAX_REASONS]},
            "lost_frames_other_reasons": sum(count for _, count in lost[MAX_REASONS:])}


def write_analysis(folder: Path, scenario: Scenario, prediction: Prediction,
                   checked: MonteCarlo | None, figures: bool = True,
                   absent: tuple[int, ...] = ()) -> list[Path]:
    """``layout.json`` (the summary), ``layout.npz`` (the grids) and ``layout.png`` in ``folder``.

    The figure (:func:`~azgym.placement.figures.analysis_figure`, matplotlib) only with
    ``figures``; ``absent`` is :func:`summary`'s. With a survey's covariances the grids add
    ``map_sigma`` and ``total_sigma``.
    """
    floor = prediction.floor
    grids: dict[str, Any] = {"xs": floor.xs, "ys": floor.ys, "free": floor.free,
                             "sigma": floor.to_grid(prediction.sigma),
                             "visible": floor.to_grid(prediction.visible.astype(float))}
    if prediction.map_sigma is not None and prediction.total is not None:
        grids["map_sigma"] = floor.to_grid(prediction.map_sigma)
        grids["total_sigma"] = floor.to_grid(prediction.total)
    if checked is not None:
        for name in ("rms", "std", "bias", "failed"):
            grids[f"mc_{name}"] = floor.to_grid(getattr(checked, name))
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **grids)
    text = json.dumps(summary(scenario, prediction, checked, absent), indent=2) + "\n"
    written = [write_file(folder / _SUMMARY, text), write_file(folder / _GRIDS, buffer.getvalue())]
    if figures:
        from azgym.placement.figures import analysis_figure

        written.append(analysis_figure(
            scenario, floor, prediction.sigma, prediction.visible,
            None if checked is None else checked.rms, folder / _FIGURE,
            "" if checked is None else checked.localizer, prediction.map_sigma))
    return written
