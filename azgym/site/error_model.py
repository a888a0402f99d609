"""The paper's azimuth error model (Rátosi & Simon 2021, Sec. 2.2, eq. 1-3) and tolerance (eq. 25).

A measured azimuth is the true one plus two independent uniform errors (eq. 3):

* the centre-detection error, uniform on ±Δα_d, with Δα_d = atan2(ΔC_p, R_p) (eq. 1): a blob
  centre found ΔC_p pixels off on a horizon circle of R_p pixels;
* the coverage error of a partly occluded beacon, uniform on ±Δα_c,i with
  Δα_c,i = atan2(W_i / 2, D_i) (eq. 2): at worst the visible centre is half a beacon width away.

The inlier tolerance of RANSAC is Δα_i = 2 (Δα_d + Δα_c,i) (eq. 25).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from azgym.core import FloatArray
from azgym.errors import InvalidInputError

__all__ = ["LEAST_AZIMUTH_NOISE", "ErrorModel", "check_azimuth_noise"]


@dataclass(frozen=True)
class ErrorModel:
    """Bounds of the two uniform azimuth errors of eq. 3.

    Attributes:
        delta_alpha_d: Half-width Δα_d of the centre-detection error [rad] (eq. 1).
        coverage: Whether the coverage error of eq. 2 is drawn (the paper's protocol: yes).
    """

    delta_alpha_d: float = math.radians(0.4)
    coverage: bool = True

    def __post_init__(self) -> None:
        if not (math.isfinite(self.delta_alpha_d) and 0.0 <= self.delta_alpha_d < math.pi / 2):
            raise InvalidInputError(
                f"ErrorModel.delta_alpha_d must be in [0, π/2) rad, got {self.delta_alpha_d}"
            )
        if not isinstance(self.coverage, (bool, np.bool_)):  # "no" would read as True
            raise InvalidInputError(
                f"ErrorModel.coverage must be True or False, got {self.coverage!r}"
            )

    @classmethod
    def from_camera(
        cls, center_error_px: float, horizon_radius_px: float, coverage: bool = True
    ) -> ErrorModel:
        """Δα_d from the camera: eq. 1, Δα_d = atan2(ΔC_p, R_p).

        Args:
            center_error_px: Centre-detection error ΔC_p [px].
            horizon_radius_px: Radius R_p of the horizon on the image [px].
            coverage: Whether the coverage error of eq. 2 is drawn.
        """
        if not center_error_px >= 0:
            raise InvalidInputError(f"center_error_px must be >= 0, got {center_error_px}")
        if not horizon_radius_px > 0:
            raise InvalidInputError(f"horizon_radius_px must be > 0, got {horizon_radius_px}")
        return cls(delta_alpha_d=math.atan2(center_error_px, horizon_radius_px),
                   coverage=coverage)

    def coverage_bound(self, distance: ArrayLike, width: ArrayLike) -> FloatArray:
        """Δα_c,i = atan2(W_i / 2, D_i) (eq. 2) [rad]; zero when coverage errors are off."""
        bound = np.arctan2(0.5 * np.asarray(width, dtype=float), np.asarray(distance, dtype=float))
        return bound if self.coverage else np.zeros_like(bound)

    def tolerance(self, distance: ArrayLike, width: ArrayLike) -> FloatArray:
        """RANSAC's inlier tolerance Δα_i = 2 (Δα_d + Δα_c,i) (eq. 25) [rad]."""
        return 2.0 * (self.delta_alpha_d + self.coverage_bound(distance, width))

    def variance(self, distance: ArrayLike, width: ArrayLike) -> FloatArray:
        """Variance of the total azimuth error of eq. 3 [rad²]: the two uniforms add, Δ²/3 each."""
        return (self.delta_alpha_d**2 + self.coverage_bound(distance, width) ** 2) / 3.0

    def sample(
        self, distance: ArrayLike, width: ArrayLike, rng: np.random.Generator
    ) -> FloatArray:
        """Draw the azimuth errors α̃^(d) + α̃_i^(c) of eq. 3, one per measurement [rad].

        Args:
            distance: Horizontal distance D_i from camera to beacon [m], shape (M,).
            width: Beacon width W_i [m], shape (M,).
            rng: The generator every draw comes from.
        """
        coverage = self.coverage_bound(distance, width)
        d = rng.uniform(-self.delta_alpha_d, self.delta_alpha_d, size=coverage.shape)
        c = rng.uniform(-1.0, 1.0, size=coverage.shape) * coverage
        return d + c


LEAST_AZIMUTH_NOISE = 1e-6
"""Least azimuth noise a filter weighs azimuths by, Δα_d or the extra noise [rad] (0.2″): no
camera measures azimuths finer, and below it a gated filter's matrices are singular to machine
precision (at 1e-9 rad, a route's first frame)."""


def check_azimuth_noise(owner: str, delta_alpha_d: float, extra_sigma: float) -> None:
    """Refuse, naming ``owner``, a Δα_d and an extra noise both below :data:`LEAST_AZIMUTH_NOISE`.

    Raises:
        InvalidInputError: If neither reaches it.
    """
    if not (delta_alpha_d >= LEAST_AZIMUTH_NOISE or extra_sigma >= LEAST_AZIMUTH_NOISE):
        raise InvalidInputError(
            f"{owner}: delta_alpha_d ({delta_alpha_d}) and extra_sigma ({extra_sigma}) are both "
            f"below {LEAST_AZIMUTH_NOISE} rad, which gives the azimuths no noise to weigh them by")
