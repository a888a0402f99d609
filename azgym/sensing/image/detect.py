"""Beacons detected back from a fisheye frame's pixels (OpenCV).

Threshold, external contours, and an intensity-weighted sub-pixel centroid per blob, whose
azimuth is its direction around the principal point. OpenCV finds the blobs; their moments are
summed in one compiled pass over every blob's box (:func:`_box_moments`). The raw moments of
8-bit pixels are whole numbers, exact in a double, so the centroids are ``cv2.moments``' to the
last bit; the central moments (the elongation) follow OpenCV's own formulas, which an OpenCV
built with Intel's IPP (as the pip wheels are) rounds its own way: the elongations agree to
1e-13 (relative) over 175 524 blobs of random frames, 2e-15 on the warehouses' frames.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from azgym.errors import InvalidInputError
from azgym.jit import jit
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


# The columns of _box_moments' output, one row per blob box.
_M00, _M10, _M01, _MU20, _MU11, _MU02, _AREA, _PEAK = range(8)
_N_STATS = 8


def detect(image: np.ndarray, camera: FisheyeCamera, threshold: int = 25) -> list[Blob]:
    """Blobs above ``threshold``, with intensity-weighted sub-pixel centroids (OpenCV).

    Each blob's centroid weighs its pixels by their grey level above the threshold, within its
    bounding box (a neighbouring blob reaching into the box would bias it; lights are far apart
    on the image compared with their size).

    Raises:
        InvalidInputError: An image that is not a 2-D 8-bit frame, or a threshold that is not a
            grey level in (0, 255).
    """
    if not isinstance(image, np.ndarray) or image.dtype != np.uint8 or image.ndim != 2:
        raise InvalidInputError(
            "detect: image must be a 2-D 8-bit grey frame (numpy uint8), got "
            f"{getattr(image, 'dtype', type(image).__name__)} of shape "
            f"{getattr(image, 'shape', '?')}")
    if isinstance(threshold, bool) or not isinstance(threshold, int | np.integer) \
            or not 0 < threshold < 255:
        raise InvalidInputError(f"detect: threshold must be a grey level in (0, 255), got "
                                f"{threshold!r}")
    threshold = int(threshold)
    _, mask = cv2.threshold(image, threshold, 255, cv2.THRESH_BINARY)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    boxes = np.array([cv2.boundingRect(contour) for contour in contours],
                     dtype=np.int64).reshape(-1, 4)
    stats = np.empty((len(boxes), _N_STATS))
    _box_moments(image, boxes, threshold, stats)
    cx, cy = camera.principal_point
    blobs = []
    for (x, y, _, _), row in zip(boxes.tolist(), stats.tolist(), strict=True):
        m00 = row[_M00]
        if m00 <= 0:
            continue
        u = x + row[_M10] / m00
        v = y + row[_M01] / m00
        mu20, mu02, mu11 = row[_MU20] / m00, row[_MU02] / m00, row[_MU11] / m00
        spread = math.sqrt(max(0.0, (mu20 - mu02) ** 2 + 4 * mu11**2))
        major, minor = 0.5 * (mu20 + mu02 + spread), 0.5 * (mu20 + mu02 - spread)
        blobs.append(Blob(u=u, v=v, azimuth=math.atan2(v - cy, u - cx), area=int(row[_AREA]),
                          peak=row[_PEAK] + threshold,
                          elongation=math.sqrt(major / minor) if minor > 1e-12 else math.inf))
    return blobs


@jit
def _box_moments(image, boxes, threshold, stats):
    """Each box's moments of the grey levels above ``threshold`` (zero elsewhere), into ``stats``.

    Row b of ``stats`` gets, for box b = (x, y, w, h): the raw moments m00, m10, m01 and the
    central μ20, μ11, μ02 in the box's own pixel coordinates, of ``cv2.subtract(box,
    threshold)`` (whole-number sums, then OpenCV's ``cx = m10 · (1 / m00)``,
    ``μ20 = m20 − m10 · cx``, ``μ11 = m11 − m10 · cy``, ``μ02 = m02 − m01 · cy``); then how many
    pixels exceed the threshold and by how much at most.
    """
    for b in range(boxes.shape[0]):
        x0 = boxes[b, 0]
        y0 = boxes[b, 1]
        m00 = m10 = m01 = m20 = m11 = m02 = 0
        area = 0
        peak = 0
        for row in range(boxes[b, 3]):
            r00 = r10 = r20 = 0
            for column in range(boxes[b, 2]):
                level = np.int64(image[y0 + row, x0 + column]) - threshold
                if level > 0:
                    r00 += level
                    r10 += column * level
                    r20 += column * column * level
                    area += 1
                    peak = max(peak, level)
            m00 += r00
            m10 += r10
            m20 += r20
            m01 += row * r00
            m11 += row * r10
            m02 += row * row * r00
        stats[b, _M00] = m00
        stats[b, _M10] = m10
        stats[b, _M01] = m01
        inverse = 1.0 / m00 if m00 > 0 else 0.0
        centre_x = m10 * inverse
        centre_y = m01 * inverse
        stats[b, _MU20] = m20 - m10 * centre_x
        stats[b, _MU11] = m11 - m10 * centre_y
        stats[b, _MU02] = m02 - m01 * centre_y
        stats[b, _AREA] = area
        stats[b, _PEAK] = peak
