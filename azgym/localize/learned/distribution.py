"""What a learned model was trained on, and the frames unlike it, which it refuses.

A network answers anything it is given, and far from its training data it answers wrongly with
confidence: the shipped models, trained on all-round cameras in generated warehouses, put a
fifth of the frames of a 68° forward camera more than 1 m off. So a weight file records its
training distribution (the manifest's ``distribution``, which
:func:`azgym.learn.distribution.distribution_of` computes from the training frames) and
``learned`` and ``ng-ransac`` refuse, with the reason, what lies outside it
(:meth:`TrainingDistribution.settings_reason`, :meth:`TrainingDistribution.frame_reason`):

- **noise**: the features measure azimuth residuals in units of the consensus tolerance, which
  scales with the camera's Δα_d (:func:`azgym.localize.learned.features.consensus_tolerance`); a
  ``delta_alpha_d`` outside ``delta_alpha_d`` (:data:`SERVED_NOISE`, the range the normalised
  models were checked on) is refused;
- **field of view**: a camera whose ``field_of_view`` is narrower than ``view_spread`` (the
  azimuth spread that all but ``SPREAD_QUANTILE`` of the training frames exceed) makes only
  frames that training saw rarely or never: every frame is refused;
- **each frame**: an azimuth spread (the narrowest arc holding its usable azimuths) below
  ``min_azimuth_spread`` (narrower than any training frame's), or fewer distinct beacons than
  ``min_beacons``.

A frame's own spread cannot tell a narrow camera from an all-round one that sees few beacons
(1 % of the training frames span under 120°, and are answered as well as the rest), so the
per-frame test stops only what training never saw; the camera's ``field_of_view`` (a profile's
``[sensor]`` field) says the rest.

The record is the manifest's ``training.data.distribution`` (``azgym train localizer`` writes
it, :func:`azgym.learn.distribution.batch_distribution`). A weight file without one (written
before it existed) was trained on the same generated warehouses: :data:`GENERATED_WAREHOUSES`
stands for it.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from typing import Any

from azgym.core import Estimate
from azgym.errors import ModelFileError

__all__ = ["GENERATED_WAREHOUSES", "SERVED_NOISE", "SPREAD_QUANTILE", "TrainingDistribution"]

SPREAD_QUANTILE = 0.01
"""Share of the training frames whose azimuth spread may lie below ``view_spread``."""
SERVED_NOISE = (math.radians(0.1), math.radians(12.0))
"""The Δα_d [rad] a model trained on azgym's generated warehouses serves, its features scaled.

Measured with the shipped weights on the held-out layouts, 800 frames a level, the camera's and
the localizer's Δα_d both set to 0.1°, 0.4° (training), 1°, 2°, 4°, 6°, 8° and 12°: the share of
frames more than 1 m off stayed within 1.3 times ransac's at the same noise at every level
(ng-ransac 0.4-0.96 times, learned 1.09-1.53; 1.29 at the training noise). Outside the levels
measured a model is not trusted (docs/learned.md)."""


@dataclass(frozen=True)
class TrainingDistribution:
    """The frames a model was trained on, as the manifest's ``distribution`` records them.

    Attributes:
        trained_delta_alpha_d: Δα_d of the training frames' camera [rad]; the consensus
            tolerance scales from it.
        delta_alpha_d: (low, high), the Δα_d [rad] the model serves, its features normalised.
        view_spread: The azimuth spread [rad] all but SPREAD_QUANTILE of the training frames
            exceed.
        min_azimuth_spread: The narrowest azimuth spread of a training frame [rad].
        min_beacons: The fewest distinct usable beacons of a training frame.
    """

    trained_delta_alpha_d: float
    delta_alpha_d: tuple[float, float]
    view_spread: float
    min_azimuth_spread: float
    min_beacons: int

    @classmethod
    def of_manifest(cls, manifest: dict[str, Any]) -> TrainingDistribution:
        """The manifest's record; :data:`GENERATED_WAREHOUSES` for a file without one.

        Raises:
            ModelFileError: A record that is not what :meth:`to_manifest` writes.
        """
        record = manifest.get("training", {}).get("data", {}).get("distribution")
        if record is None:
            return GENERATED_WAREHOUSES
        try:
            low, high = (float(v) for v in record["delta_alpha_d"])
            made = cls(float(record["trained_delta_alpha_d"]), (low, high),
                       float(record["view_spread"]), float(record["min_azimuth_spread"]),
                       int(record["min_beacons"]))
        except (KeyError, TypeError, ValueError) as exc:
            raise ModelFileError(f"manifest field 'distribution' is not a training distribution "
                                 f"({type(exc).__name__}: {exc})") from None
        numbers = (made.trained_delta_alpha_d, low, high, made.view_spread,
                   made.min_azimuth_spread)
        if not all(math.isfinite(v) and v >= 0.0 for v in numbers) or low > high or \
                made.trained_delta_alpha_d <= 0.0:
            raise ModelFileError(f"manifest field 'distribution' holds impossible values: "
                                 f"{record!r}")
        return made

    def to_manifest(self) -> dict[str, Any]:
        """The manifest's ``distribution`` record (JSON values)."""
        record = asdict(self)
        record["delta_alpha_d"] = list(self.delta_alpha_d)
        return record

    def settings_reason(self, delta_alpha_d: float, field_of_view: float | None) -> str:
        """Why no frame of a camera with this noise and view is like the training frames ('')."""
        low, high = self.delta_alpha_d
        if not low <= delta_alpha_d <= high:
            return (f"delta_alpha_d {math.degrees(delta_alpha_d):.3g}° is outside the noise the "
                    f"model was trained for ({math.degrees(low):.3g}°-"
                    f"{math.degrees(high):.3g}°)")
        if field_of_view is not None and field_of_view < self.view_spread:
            return (f"field_of_view {math.degrees(field_of_view):.3g}° is narrower than the "
                    f"azimuth spread of {1 - SPREAD_QUANTILE:.0%} of the training frames "
                    f"({math.degrees(self.view_spread):.3g}°)")
        return ""

    def frame_reason(self, distinct: int, spread: float) -> str:
        """Why a frame is unlike the training frames ('' when it is like them).

        Args:
            distinct: The distinct beacons its usable measurements (ids in the map) measure.
            spread: Their azimuth spread [rad] (:func:`azgym.localize._angles.azimuth_spread`),
                which the localizers' compiled frame computes.
        """
        if distinct < self.min_beacons:
            return (f"{distinct} beacons in view, fewer than any training frame had "
                    f"({self.min_beacons})")
        if spread < self.min_azimuth_spread:
            return (f"the azimuths span {math.degrees(spread):.3g}°, narrower than any "
                    f"training frame's ({math.degrees(self.min_azimuth_spread):.3g}°)")
        return ""

    @staticmethod
    def refusal(reason: str, n_measurements: int) -> Estimate:
        """The refusal of a frame off the distribution for ``reason``: ``off_distribution``."""
        return Estimate.failure(f"off the model's training distribution: {reason}",
                                n_measurements, {"off_distribution": True})


GENERATED_WAREHOUSES = TrainingDistribution(
    trained_delta_alpha_d=math.radians(0.4), delta_alpha_d=SERVED_NOISE,
    view_spread=math.radians(120.0), min_azimuth_spread=math.radians(7.0), min_beacons=3)
"""The distribution of a weight file without a record: ``azgym train localizer``'s generated
warehouses (:mod:`azgym.learn.dataset`), rounded down from the shipped models' records."""
