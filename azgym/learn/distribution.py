"""Measuring a model's training distribution from its frames, and its account on a model card.

The record itself, and the refusals of frames outside it, serve with the localizers
(:mod:`azgym.localize.learned.distribution`); training measures it here from the training frames
(:func:`batch_distribution`, which ``azgym train localizer`` writes into the manifest) and the
model card tells it (:func:`card_section`).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from azgym.core import FloatArray
from azgym.localize._angles import azimuth_spread
from azgym.localize.base import ROW_AZIMUTH
from azgym.localize.learned.distribution import (
    SERVED_NOISE,
    SPREAD_QUANTILE,
    TrainingDistribution,
)

__all__ = ["batch_distribution", "card_section", "distribution_of"]


def card_section(record: dict[str, Any] | None) -> list[str]:
    """A model card's account of the manifest's ``distribution`` record (markdown lines).

    None (data without the record, e.g. :func:`azgym.learn.train.fit` on frames of one's own)
    says which distribution stands for it.
    """
    if record is None:
        return ["## Training distribution (the frames it answers)", "",
                "Not recorded with the training data: the generated warehouses' stands for it "
                "(`azgym.localize.learned.distribution.GENERATED_WAREHOUSES`).", ""]
    made = TrainingDistribution.of_manifest({"training": {"data": {"distribution": record}}})
    low, high = made.delta_alpha_d
    return [
        "## Training distribution (the frames it answers)", "",
        "Recorded in the manifest (`training.data.distribution`, "
        "`azgym.localize.learned.distribution`); the localizer refuses, with the reason, a "
        "frame or a camera outside it:", "",
        f"- camera noise trained on: Δα_d {math.degrees(made.trained_delta_alpha_d):.2f}°; "
        f"served for Δα_d {math.degrees(low):.1f}°-{math.degrees(high):.0f}° (the consensus "
        "tolerance scales with the given `delta_alpha_d`; range measured on the held-out "
        "layouts, docs/learned.md)",
        f"- azimuth spread exceeded by {1 - SPREAD_QUANTILE:.0%} of the training frames: "
        f"{math.degrees(made.view_spread):.1f}° (a `field_of_view` narrower than this is "
        "refused)",
        f"- narrowest azimuth spread of a training frame: "
        f"{math.degrees(made.min_azimuth_spread):.1f}° (a narrower frame is refused)",
        f"- fewest distinct beacons in a training frame: {made.min_beacons}", ""]


def batch_distribution(floats: FloatArray, beacon_index: np.ndarray, mask: np.ndarray
                       ) -> TrainingDistribution:
    """The distribution of a FrameBatch's frames (:mod:`azgym.learn.dataset`, its arrays).

    The generated warehouses' camera has the simulator's default Δα_d (ErrorModel's).
    """
    from azgym.site.error_model import ErrorModel

    azimuths = [floats[n, ROW_AZIMUTH][mask[n]] for n in range(mask.shape[0])]
    distinct = [int(np.unique(beacon_index[n][mask[n]]).size) for n in range(mask.shape[0])]
    return distribution_of(azimuths, distinct, ErrorModel().delta_alpha_d, SERVED_NOISE)


def distribution_of(azimuths: list[FloatArray], distinct: list[int],
                    trained_delta_alpha_d: float, delta_alpha_d: tuple[float, float]
                    ) -> TrainingDistribution:
    """The training distribution of frames (each frame's usable azimuths and distinct beacons).

    Args:
        azimuths: Each training frame's usable azimuths [rad].
        distinct: Each training frame's distinct usable beacons.
        trained_delta_alpha_d: Δα_d of the training frames' camera [rad].
        delta_alpha_d: The Δα_d range [rad] the model is served for.
    """
    spreads = np.array([azimuth_spread(np.asarray(a, dtype=np.float64)) for a in azimuths])
    return TrainingDistribution(float(trained_delta_alpha_d),
                                (float(delta_alpha_d[0]), float(delta_alpha_d[1])),
                                float(np.quantile(spreads, SPREAD_QUANTILE)),
                                float(spreads.min()), int(min(distinct)))
