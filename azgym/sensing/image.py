"""Fisheye frames from the sensor geometry, and beacons detected back from the pixels (OpenCV).

``render`` draws every detection the geometry found — direct, partly covered or mirrored — as
an LED blob: the visible part of the beacon's width (its azimuth extent, from W and the
distance, times the visible share) at its elevation, blurred by the lens' point spread, as
bright as its flux (a ghost dimmer by the reflectivity), clipped at saturation, plus sensor
noise. A partly covered beacon is thereby really cut on the image: only its visible part is lit.

``detect`` finds the blobs again: threshold, contours, and an intensity-weighted sub-pixel
centroid per blob, whose azimuth comes from the camera model. With ids="oracle" each blob gets
the id of the light that made it (and the scenario's misread rate applies upstream).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numba
import numpy as np

from azgym.core import FloatArray, Measurements
from azgym.scenario import Scenario
from azgym.sensing.fisheye import FisheyeCamera
from azgym.sensing.sensor import Sensor

PSF_SIGMA_PX = 0.8
"""Standard deviation of the lens' point spread [px]."""
PEAK = 220.0
"""Grey level of an unsaturated point source at the detection threshold's flux × 100."""


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


@numba.njit(cache=True)
def _splat(image, u, v, sigma, amplitude):
    """Add a sub-pixel Gaussian of the given amplitude centred at (u, v) (pixel centres)."""
    radius = int(math.ceil(3.5 * sigma))
    height, width = image.shape
    u0 = int(math.floor(u))
    v0 = int(math.floor(v))
    inv = 1.0 / (2.0 * sigma * sigma)
    for row in range(max(0, v0 - radius), min(height, v0 + radius + 2)):
        dv = row - v
        for column in range(max(0, u0 - radius), min(width, u0 + radius + 2)):
            du = column - u
            image[row, column] += amplitude * math.exp(-(du * du + dv * dv) * inv)


@numba.njit(cache=True)
def _draw_strip(image, cx, cy, focal, distortion, polar, azimuth_lo, azimuth_hi, amplitude,
                sigma):
    """Light the arc of polar angle ``polar`` between two azimuths.

    The arc is a row of Gaussians a fifth of a pixel apart whose total is ``amplitude`` (a point
    source if the arc is tiny).
    """
    k1, k2, k3, k4 = distortion[0], distortion[1], distortion[2], distortion[3]
    t2 = polar * polar
    radius = focal * polar * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))
    length = radius * (azimuth_hi - azimuth_lo)
    count = max(1, int(math.ceil(length / 0.2)))
    for k in range(count):
        azimuth = azimuth_lo + (azimuth_hi - azimuth_lo) * (k + 0.5) / count
        _splat(image, cx + radius * math.cos(azimuth), cy + radius * math.sin(azimuth), sigma,
               amplitude / count)


def render(camera: FisheyeCamera, azimuth_lo: FloatArray, azimuth_hi: FloatArray,
           elevation: FloatArray, flux: FloatArray, noise: FloatArray | None = None) -> np.ndarray:
    """An 8-bit frame with one lit arc per light.

    Args:
        camera: The fisheye.
        azimuth_lo: Start of each light's visible azimuth extent, camera frame [rad].
        azimuth_hi: End of it [rad].
        elevation: Each light's elevation above the horizon [rad].
        flux: Each light's flux over the detection threshold (>= 1).
        noise: An image-sized float32 array of sensor noise to add (grey levels), or None; a
            bank of precomputed noise frames avoids the cost of fresh Gaussian noise.
    """
    width, height = camera.image_size
    image = np.zeros((height, width), dtype=np.float32)
    cx, cy = camera.principal_point
    distortion = np.array(camera.distortion, dtype=np.float64)
    # Total brightness of a blob: enough that a light at the threshold peaks near 60 grey levels.
    scale = 60.0 * 2.0 * math.pi * PSF_SIGMA_PX**2
    for lo, hi, e, f in zip(azimuth_lo, azimuth_hi, elevation, flux, strict=True):
        _draw_strip(image, cx, cy, camera.focal_px, distortion, math.pi / 2 - e, lo, hi,
                    scale * min(f, 40.0), PSF_SIGMA_PX)
    if noise is not None:
        image += noise
    np.clip(image, 0, 255, out=image)
    return image.astype(np.uint8)


def detect(image: np.ndarray, camera: FisheyeCamera, threshold: int = 25) -> list[Blob]:
    """Blobs above ``threshold``, with intensity-weighted sub-pixel centroids (OpenCV).

    Each blob's centroid weighs its pixels by their grey level above the threshold, within its
    bounding box (a neighbouring blob reaching into the box would bias it; lights are far apart
    on the image compared with their size).
    """
    _, mask = cv2.threshold(image, threshold, 255, cv2.THRESH_BINARY)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    cx, cy = camera.principal_point
    # Grey levels above the threshold, zero elsewhere: the weights of the centroid.
    weights = cv2.subtract(image, np.full_like(image, threshold))
    blobs = []
    for contour in contours:
        x, y, w, h = cv2.boundingRect(contour)
        patch = weights[y:y + h, x:x + w]
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


@dataclass(frozen=True, eq=False)
class ImageFrame:
    """One camera frame through the image path.

    Attributes:
        image: The 8-bit fisheye frame.
        measurements: The detected blobs' ids (``-1``: a blob no light explains), azimuths and
            quality (area, peak, elongation).
        labels: For each measurement, the cause label of the light that made it (-1: none).
        blobs: The detected blobs.
    """

    image: np.ndarray
    measurements: Measurements
    labels: np.ndarray
    blobs: list[Blob]


class ImageSensor:
    """The scenario's camera through pixels: render the geometry's lights, detect them, identify.

    With ``ids="oracle"`` a blob takes the (possibly misread) id of the light whose projected
    centre is nearest, within ``match_px``; the centre-detection error then comes from the pixels,
    not from eq. 1's draw.

    Args:
        scenario: The site; its ``fisheye`` is the camera.
        noise_sigma: Sensor noise [grey levels].
        noise_frames: Size of the bank of precomputed noise frames (drawn from ``seed``).
        threshold: Detection threshold [grey level].
        match_px: Largest blob-to-light distance for the oracle's identification [px].
        seed: Seed of the noise bank.
    """

    def __init__(self, scenario: Scenario, noise_sigma: float = 2.0, noise_frames: int = 8,
                 threshold: int = 25, match_px: float = 3.0, seed: int = 0) -> None:
        self.scenario = scenario
        self.camera = scenario.fisheye
        self.threshold = threshold
        self.match_px = match_px
        self._sensor = Sensor(scenario)
        self._buffers = self._sensor.new_buffers()
        width, height = self.camera.image_size
        bank = np.random.default_rng(seed)
        self._noise = [bank.normal(0.0, noise_sigma, (height, width)).astype(np.float32)
                       for _ in range(noise_frames)] if noise_sigma > 0 else [None]

    def observe(self, x: float, y: float, heading: float, rng: np.random.Generator,
                tilt: tuple[float, float] = (0.0, 0.0)) -> ImageFrame:
        """Render the frame at pose (x, y, heading), detect its blobs and identify them."""
        out = self._buffers
        count = self._sensor.observe_into(x, y, heading, rng, out, tilt=tilt)
        centre = out.true_azimuth[:count]
        half = out.visible[:count] * out.half_width[:count]
        elevation = out.elevation[:count]
        noise = self._noise[int(rng.integers(len(self._noise)))]
        image = render(self.camera, centre - half, centre + half, elevation,
                       10.0 ** out.quality[:count], noise)
        blobs = detect(image, self.camera, self.threshold)
        ids = np.full(len(blobs), -1, dtype=np.int64)
        labels = np.full(len(blobs), -1, dtype=np.int64)
        if count and blobs:
            c = np.cos(elevation)
            lights = self.camera.project(np.column_stack(
                [c * np.cos(centre), c * np.sin(centre), np.sin(elevation)]))
            found = np.array([(blob.u, blob.v) for blob in blobs])
            distance = np.hypot(found[:, None, 0] - lights[None, :, 0],
                                found[:, None, 1] - lights[None, :, 1])
            nearest = distance.argmin(axis=1)
            matched = distance[np.arange(len(blobs)), nearest] <= self.match_px
            ids[matched] = out.ids[nearest[matched]]
            labels[matched] = out.label[nearest[matched]]
        quality = np.array([(b.area, b.peak, b.elongation) for b in blobs],
                           dtype=np.float64).reshape(-1, 3)
        quality[~np.isfinite(quality)] = 1e6  # a one-pixel-wide blob: elongation without bound
        measurements = Measurements(ids, np.array([b.azimuth for b in blobs]), quality)
        return ImageFrame(image=image, measurements=measurements, labels=labels, blobs=blobs)
