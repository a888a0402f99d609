"""The upward fisheye camera: OpenCV's fisheye model (equidistant, with k1..k4 distortion).

Camera frame: x forward (the forklift's heading), y left, z up along the optical axis. A
direction at polar angle θ from the axis and azimuth α from x lands at radius r = f θ_d on the
image, with θ_d = θ (1 + k1 θ² + k2 θ⁴ + k3 θ⁶ + k4 θ⁸) (OpenCV's ``cv2.fisheye`` model), at
(u, v) = (c_x + r cos α, c_y + r sin α). The horizon (θ = 90°) is the circle of radius
R_p = f θ_d(π/2): the R_p of eq. 1. Distortion is radial, so the azimuth of a pixel is
atan2(v − c_y, u − c_x) whatever f and k are: only the principal point matters for azimuths.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from azgym.core import FloatArray
from azgym.errors import InvalidInputError

__all__ = ["MAX_IMAGE_SIDE", "FisheyeCamera"]

MAX_IMAGE_SIDE = 4096
"""The widest and tallest image the fisheye may have [px]: a 16-megapixel frame. The image
sensor keeps a bank of noise frames of this size, so a larger one would be refused only once
gigabytes were allocated."""


@dataclass(frozen=True)
class FisheyeCamera:
    """Intrinsics of the upward fisheye.

    Attributes:
        focal_px: Focal length f [px] (equal in x and y).
        principal_point: (c_x, c_y) [px], the optical axis on the image.
        image_size: (width, height) [px].
        distortion: OpenCV's fisheye coefficients (k1, k2, k3, k4).
    """

    focal_px: float = 150.0
    principal_point: tuple[float, float] = (240.0, 240.0)
    image_size: tuple[int, int] = (480, 480)
    distortion: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        name = "FisheyeCamera"
        if not (isinstance(self.focal_px, (int, float)) and math.isfinite(self.focal_px)
                and self.focal_px > 0):
            raise InvalidInputError(f"{name}.focal_px must be > 0, got {self.focal_px!r}")
        width, height = self.image_size
        if not all(isinstance(side, int) and not isinstance(side, bool)
                   and 0 < side <= MAX_IMAGE_SIDE for side in (width, height)):
            raise InvalidInputError(
                f"{name}.image_size must be two integers in [1, {MAX_IMAGE_SIDE}] px, got "
                f"{self.image_size!r}"
            )
        cx, cy = self.principal_point
        if not (0.0 <= cx <= width and 0.0 <= cy <= height):
            raise InvalidInputError(
                f"{name}.principal_point {self.principal_point!r} is off the {width} x {height} "
                "image"
            )
        if len(self.distortion) != 4 or not all(math.isfinite(k) for k in self.distortion):
            raise InvalidInputError(
                f"{name}.distortion must be four finite numbers (k1, k2, k3, k4), got "
                f"{self.distortion!r}"
            )
        theta = np.linspace(0.0, math.pi / 2, 2001)
        if not (np.diff(self._distort(theta)) > 0).all():
            raise InvalidInputError(
                f"{name}.distortion {self.distortion!r} makes the projection non-monotonic "
                "inside the horizon (θ_d(θ) must increase up to 90°)"
            )

    @property
    def horizon_radius_px(self) -> float:
        """R_p: the radius of the horizon circle on the image [px]."""
        return float(self.focal_px * self._distort(np.array([math.pi / 2]))[0])

    @property
    def camera_matrix(self) -> FloatArray:
        """OpenCV's K."""
        cx, cy = self.principal_point
        return np.array([[self.focal_px, 0.0, cx], [0.0, self.focal_px, cy], [0.0, 0.0, 1.0]])

    @property
    def distortion_vector(self) -> FloatArray:
        """OpenCV's D, shape (4, 1)."""
        return np.array(self.distortion, dtype=np.float64).reshape(4, 1)

    def _distort(self, theta: FloatArray) -> FloatArray:
        k1, k2, k3, k4 = self.distortion
        t2 = theta * theta
        return theta * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))

    def _undistort(self, theta_d: FloatArray) -> FloatArray:
        """θ from θ_d by Newton's method (θ_d(θ) is increasing, checked at construction)."""
        k1, k2, k3, k4 = self.distortion
        theta = np.array(theta_d, dtype=np.float64)
        for _ in range(30):
            t2 = theta * theta
            value = theta * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4)))) - theta_d
            slope = 1.0 + t2 * (3 * k1 + t2 * (5 * k2 + t2 * (7 * k3 + t2 * 9 * k4)))
            step = value / slope
            theta = theta - step
            if np.all(np.abs(step) < 1e-15):
                break
        return theta

    def project(self, directions: ArrayLike) -> FloatArray:
        """Pixels (u, v) of directions (x, y, z) in the camera frame, shape (N, 3) → (N, 2)."""
        d = np.atleast_2d(np.asarray(directions, dtype=np.float64))
        if d.shape[1] != 3:
            raise InvalidInputError(f"directions must have shape (N, 3), got {d.shape}")
        rho = np.hypot(d[:, 0], d[:, 1])
        radius = self.focal_px * self._distort(np.arctan2(rho, d[:, 2]))
        azimuth = np.arctan2(d[:, 1], d[:, 0])
        cx, cy = self.principal_point
        return np.column_stack([cx + radius * np.cos(azimuth), cy + radius * np.sin(azimuth)])

    def unproject(self, pixels: ArrayLike) -> FloatArray:
        """Unit directions (x, y, z) of pixels (u, v), shape (N, 2) → (N, 3)."""
        p = np.atleast_2d(np.asarray(pixels, dtype=np.float64))
        if p.shape[1] != 2:
            raise InvalidInputError(f"pixels must have shape (N, 2), got {p.shape}")
        cx, cy = self.principal_point
        du, dv = p[:, 0] - cx, p[:, 1] - cy
        theta = self._undistort(np.hypot(du, dv) / self.focal_px)
        azimuth = np.arctan2(dv, du)
        return np.column_stack([np.sin(theta) * np.cos(azimuth), np.sin(theta) * np.sin(azimuth),
                                np.cos(theta)])

    def azimuth(self, pixels: ArrayLike) -> FloatArray:
        """Azimuth in the camera frame of pixels (u, v) [rad]: atan2(v − c_y, u − c_x)."""
        p = np.atleast_2d(np.asarray(pixels, dtype=np.float64))
        cx, cy = self.principal_point
        return np.arctan2(p[:, 1] - cy, p[:, 0] - cx)
