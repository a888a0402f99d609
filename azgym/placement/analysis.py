"""``azgym layout analyze``: the predicted σ, the beacons seen and a Monte Carlo check, per cell.

The prediction (:mod:`azgym.placement.information`) is computed for every cell at once; the Monte
Carlo check (:mod:`azgym.placement.monte_carlo`) runs frames through a localizer, cell by cell. Both
see the same beacons from each cell (:mod:`azgym.placement.visibility`).
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
from azgym.placement.information import contributions, position_sigma
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
    """

    floor: Floor
    seen: BoolArray
    sigma: FloatArray

    @property
    def visible(self) -> FloatArray:
        """Beacons seen from each cell, shape (P,)."""
        return self.seen.sum(axis=1)


def predict(scenario: Scenario, floor: Floor, progress: Progress | None = None) -> Prediction:
    """The prediction for the scenario's own beacons (their mapped places).

    ``progress`` hears the count of cells whose line of sight is tested.
    """
    points = floor.points
    beacons = scenario.beacons
    with counter(progress, "line of sight", len(points), "cells") as tested:
        seen = visible_beacons(scenario, points, beacons.xyz, beacons.width, tested)
    information = contributions(points, beacons.xy, beacons.width, scenario.error_model,
                                seen).sum(axis=1)
    return Prediction(floor, seen, position_sigma(information, seen.sum(axis=1)))


def analyze(scenario: Scenario, floor: Floor, localizer: str, frames: int, seed: int = 0,
            progress: Progress | None = None, *, workers: int = 1,
            time_limit: float = DEFAULT_TIME_LIMIT) -> tuple[Prediction, MonteCarlo | None]:
    """The prediction, and with ``frames`` > 0 the Monte Carlo check of ``localizer``.

    ``progress`` hears the cells counted, as the line of sight is tested and as the Monte Carlo
    check runs (:func:`azgym.progress.counter`); ``workers`` and ``time_limit`` are the
    runner's (:func:`~azgym.placement.monte_carlo.monte_carlo`).
    """
    prediction = predict(scenario, floor, progress)
    if frames <= 0:
        return prediction, None
    checked = monte_carlo(scenario, floor.points, prediction.seen, localizer, frames, seed,
                          progress, workers=workers, time_limit=time_limit)
    return prediction, checked


def summary(scenario: Scenario, prediction: Prediction,
            checked: MonteCarlo | None) -> dict[str, Any]:
    """The figures of an analysis (the command's printout and ``layout.json``)."""
    result: dict[str, Any] = {"scenario": scenario.name, "step_m": prediction.floor.step,
                              "beacons": len(scenario.beacons), "penalty_sigma_m": PENALTY_SIGMA,
                              "predicted": floor_figures(prediction.sigma, prediction.visible)}
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
                   checked: MonteCarlo | None, figures: bool = True) -> list[Path]:
    """``layout.json`` (the summary), ``layout.npz`` (the grids) and ``layout.png`` in ``folder``.

    The figure (:func:`~azgym.placement.figures.analysis_figure`, matplotlib) only with
    ``figures``.
    """
    floor = prediction.floor
    grids: dict[str, Any] = {"xs": floor.xs, "ys": floor.ys, "free": floor.free,
                             "sigma": floor.to_grid(prediction.sigma),
                             "visible": floor.to_grid(prediction.visible.astype(float))}
    if checked is not None:
        for name in ("rms", "std", "bias", "failed"):
            grids[f"mc_{name}"] = floor.to_grid(getattr(checked, name))
    buffer = io.BytesIO()
    np.savez_compressed(buffer, **grids)
    text = json.dumps(summary(scenario, prediction, checked), indent=2) + "\n"
    written = [write_file(folder / _SUMMARY, text), write_file(folder / _GRIDS, buffer.getvalue())]
    if figures:
        from azgym.placement.figures import analysis_figure

        written.append(analysis_figure(
            scenario, floor, prediction.sigma, prediction.visible,
            None if checked is None else checked.rms, folder / _FIGURE,
            "" if checked is None else checked.localizer))
    return written
