"""Beacons detected back from a fisheye frame's pixels (OpenCV).

Threshold, external contours, and an intensity-weighted sub-pixel centroid per blob, whose
azimuth is its direction around the principal point.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from azgym.site.fisheye import FisheyeCamera

__all__ = ["Blob", "detect"]


@dataclass(frozen=True)
class Blob:
    """A detected blob: its sub-pixel centroid, azimuth in the camera frame and quality.

    Attributes:
        u: Centroid column [px].
        v: Centroid row [px].
        azimuth: Azimuth in the camera frame [rad].
        area: Pixels above the threshold.
        peak: Brightest grey level.
        elongation: Ratio of the blob's principal axes (1 for a round blob).
    """

    u: float
    v: float
    azimuth: float
    area: int
    peak: float
    elongation: float


def detect(image: np.ndarray, camera: FisheyeCamera, threshold: int = 25) -> list[Blob]:
    """Blobs above ``threshold``, with intensity-weighted sub-pixel centroids (OpenCV).

    Each blob's centroid weighs its pixels by their grey level above the threshold, within its
    bounding box (a neighbouring blob reaching into the box would bias it; lights are far apart
    on the image compared with their size).
    """
    _, mask = cv2.threshold(image, threshold, 255, cv2.THRESH_BINARY)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    cx, cy = camera.principal_point
    blobs = []
    for contour in contours:
        x, y, w, h = cv2.boundingRect(contour)
        # Grey levels above the threshold, zero elsewhere: the weights of the centroid (the
        # box's only: a whole frame's subtraction would cost more than every box's together).
        patch = cv2.subtract(image[y:y + h, x:x + w], np.full((h, w), threshold, np.uint8))
        moments = cv2.moments(patch, binaryImage=False)
        if moments["m00"] <= 0:
            continue
        u = x + moments["m10"] / moments["m00"]
        v = y + moments["m01"] / moments["m00"]
        mu20, mu02, mu11 = (moments["mu20"] / moments["m00"], moments["mu02"] / moments["m00"],
                            moments["mu11"] / moments["m00"])
        spread = math.sqrt(max(0.0, (mu20 - mu02) ** 2 + 4 * mu11**2))
        major, minor = 0.5 * (mu20 + mu02 + spread), 0.5 * (mu20 + mu02 - spread)
        blobs.append(Blob(u=u, v=v, azimuth=math.atan2(v - cy, u - cx),
                          area=int(cv2.countNonZero(patch)), peak=float(patch.max()) + threshold,
                          elongation=math.sqrt(major / minor) if minor > 1e-12 else math.inf))
    return blobs
