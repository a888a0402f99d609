"""Fisheye frames from the sensor geometry: every light the camera sees drawn as OpenCV would.

``render`` draws every detection the geometry found — direct, partly covered or mirrored — as
an LED blob: the visible part of the beacon's width (its azimuth extent, from W and the
distance, times the visible share) at its elevation, blurred by the lens' point spread, as
bright as its flux (a ghost dimmer by the reflectivity), clipped at saturation, plus sensor
noise. A partly covered beacon is thereby really cut on the image: only its visible part is lit.

:mod:`azgym.sensing.image.detect` finds the blobs again; :mod:`azgym.sensing.image.sensor` puts
both behind a camera that identifies the blobs.
"""

from __future__ import annotations

import math

import cv2
import numpy as np

from azgym.core import FloatArray
from azgym.errors import InvalidInputError
from azgym.jit import jit
from azgym.site.fisheye import FisheyeCamera

__all__ = ["render"]

PSF_SIGMA_PX = 0.8
"""Standard deviation of the lens' point spread [px]."""


@jit(error_model="python")
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


def _draw_strips(image: np.ndarray, cx: float, cy: float, focal: float, distortion: FloatArray,
                 strips: list[tuple[float, float, float, float]]) -> None:
    """Light each strip (polar angle, azimuth from, azimuth to, amplitude) in order, in one call."""
    if strips:
        _draw_strip_rows(image, cx, cy, focal, distortion, np.array(strips, dtype=np.float64),
                         PSF_SIGMA_PX)


@jit(error_model="python")
def _draw_strip_rows(image, cx, cy, focal, distortion, strips, sigma):
    """:func:`_draw_strip` for each row (polar angle, azimuth from, azimuth to, amplitude)."""
    for k in range(strips.shape[0]):
        _draw_strip(image, cx, cy, focal, distortion, strips[k, 0], strips[k, 1], strips[k, 2],
                    strips[k, 3], sigma)


@jit(error_model="python")
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
           elevation: FloatArray, flux: FloatArray, noise: FloatArray | None = None,
           half_tall: FloatArray | None = None) -> np.ndarray:
    """An 8-bit frame with one lit arc (a beacon) or lit patch (a lamp, a window) per light.

    Args:
        camera: The fisheye.
        azimuth_lo: Start of each light's visible azimuth extent, camera frame [rad].
        azimuth_hi: End of it [rad].
        elevation: Each light's elevation above the horizon [rad].
        flux: Each light's flux over the detection threshold (>= 1).
        noise: An image-sized array of sensor noise to add (grey levels, taken as float32), or
            None; a bank of precomputed noise frames avoids the cost of fresh Gaussian noise.
        half_tall: Each light's angular half-extent in elevation [rad], or None for LEDs (whose
            height the point spread hides). A light taller than a pixel is drawn as a patch.

    Raises:
        InvalidInputError: Noise that is not one frame (the camera's image size) of grey levels.
    """
    width, height = camera.image_size
    if noise is not None:
        noise = np.asarray(noise, dtype=np.float32)
        if noise.shape != (height, width):
            raise InvalidInputError(f"render: noise must be one frame of {height} x {width} "
                                    f"grey levels, got shape {noise.shape}")
    image = np.zeros((height, width), dtype=np.float32)
    cx, cy = camera.principal_point
    distortion = np.array(camera.distortion, dtype=np.float64)
    # Total brightness of a blob: enough that a light at the threshold peaks near 60 grey levels.
    scale = 60.0 * 2.0 * math.pi * PSF_SIGMA_PX**2
    tall = [0.0] * len(elevation) if half_tall is None else np.asarray(half_tall).tolist()
    lights = zip(np.asarray(azimuth_lo).tolist(), np.asarray(azimuth_hi).tolist(),
                 np.asarray(elevation).tolist(), np.asarray(flux).tolist(), tall, strict=True)
    # Lights are added in their order (float sums where two overlap depend on it): each run of
    # strips, rows of (polar angle, azimuth from, azimuth to, amplitude), in one call.
    strips: list[tuple[float, float, float, float]] = []
    for lo, hi, e, f, t in lights:
        if t * camera.focal_px > 0.5:
            _draw_strips(image, cx, cy, camera.focal_px, distortion, strips)
            strips = []
            _draw_patch(image, camera, distortion, lo, hi, e - t, e + t, scale * f)
        else:
            strips.append((math.pi / 2 - e, lo, hi, scale * min(f, 40.0)))
    _draw_strips(image, cx, cy, camera.focal_px, distortion, strips)
    grey = np.empty((height, width), dtype=np.uint8)
    _to_grey(image, image if noise is None else noise, noise is not None, grey)
    return grey


@jit
def _to_grey(image, noise, add_noise, out):
    """``out`` = the 8-bit frame: ``image`` (+ ``noise``) clipped to [0, 255], then truncated.

    One pass over the frame, as numpy's ``(image + noise).clip(0, 255).astype(np.uint8)`` in
    float32 (three passes and a temporary there), bit for bit.
    """
    height, width = image.shape
    for row in range(height):
        for column in range(width):
            value = image[row, column] + noise[row, column] if add_noise else image[row, column]
            if value < 0.0:
                value = np.float32(0.0)
            elif value > 255.0:
                value = np.float32(255.0)
            out[row, column] = np.uint8(value)


@jit(error_model="python")
def _patch_outline(cx, cy, focal, distortion, azimuth_lo, azimuth_hi, elevation_lo,
                   elevation_hi, sides):
    """The outline of an azimuth × elevation patch on the image, (2 sides, 2) points [px]."""
    k1, k2, k3, k4 = distortion[0], distortion[1], distortion[2], distortion[3]
    outline = np.empty((2 * sides, 2))
    for edge in range(2):
        polar = math.pi / 2 - (elevation_hi if edge == 0 else elevation_lo)
        t2 = polar * polar
        radius = focal * polar * (1.0 + t2 * (k1 + t2 * (k2 + t2 * (k3 + t2 * k4))))
        for k in range(sides):
            step = k if edge == 0 else sides - 1 - k
            azimuth = azimuth_lo + (azimuth_hi - azimuth_lo) * step / (sides - 1)
            outline[edge * sides + k, 0] = cx + radius * math.cos(azimuth)
            outline[edge * sides + k, 1] = cy + radius * math.sin(azimuth)
    return outline


@jit(error_model="python")
def _patch_box(outline, margin, height, width, shift):
    """The image box around an outline, ``margin`` pixels wider, and the outline in it.

    Returns (x0, y0, x1, y1, points): the box's columns [x0, x1) and rows [y0, y1), clipped to
    the image, and the outline relative to (x0, y0) in fixed point (``shift`` fractional bits,
    rounded half to even), as ``cv2.fillPoly`` takes it; an empty box (x0 >= x1 or y0 >= y1)
    when the outline lies off the image, and x0 = −1 when it is not finite.
    """
    points = np.zeros((outline.shape[0], 2), dtype=np.int32)
    low_x = high_x = outline[0, 0]
    low_y = high_y = outline[0, 1]
    for k in range(outline.shape[0]):
        u = outline[k, 0]
        v = outline[k, 1]
        if not (math.isfinite(u) and math.isfinite(v)):
            return -1, 0, 0, 0, points
        low_x = min(low_x, u)
        high_x = max(high_x, u)
        low_y = min(low_y, v)
        high_y = max(high_y, v)
    # Whole pixels toward zero, as Python's int(); clamped first so that an outline far off the
    # image (its box then empty) cannot overflow the conversion.
    far = 2.0**30
    x0 = max(0, int(min(max(low_x, -far), far)) - margin)
    y0 = max(0, int(min(max(low_y, -far), far)) - margin)
    x1 = min(width, int(min(max(high_x, -far), far)) + margin + 2)
    y1 = min(height, int(min(max(high_y, -far), far)) + margin + 2)
    scale = float(2**shift)
    for k in range(outline.shape[0]):
        points[k, 0] = np.int32(np.rint((outline[k, 0] - x0) * scale))
        points[k, 1] = np.int32(np.rint((outline[k, 1] - y0) * scale))
    return x0, y0, x1, y1, points


def _draw_patch(image: np.ndarray, camera: FisheyeCamera, distortion: FloatArray,
                azimuth_lo: float, azimuth_hi: float, elevation_lo: float, elevation_hi: float,
                total: float) -> None:
    """Add an extended light: its outline on the image filled evenly, blurred by the spread.

    Its grey level is its total brightness over its area, so a bright lamp saturates.
    """
    cx, cy = camera.principal_point
    outline = _patch_outline(cx, cy, camera.focal_px, distortion, azimuth_lo, azimuth_hi,
                             elevation_lo, elevation_hi, 9)
    height, width = image.shape
    shift = 4  # sub-pixel vertices: 1/16 px
    x0, y0, x1, y1, points = _patch_box(outline, math.ceil(4 * PSF_SIGMA_PX), height, width,
                                        shift)
    if x0 < 0:
        raise InvalidInputError(f"render: a light's extent is not finite (azimuth {azimuth_lo!r} "
                                f"to {azimuth_hi!r}, elevation {elevation_lo!r} to "
                                f"{elevation_hi!r})")
    if x0 >= x1 or y0 >= y1:
        return
    area = max(1.0, abs(cv2.contourArea(points)) / 4**shift)
    patch = np.zeros((y1 - y0, x1 - x0), dtype=np.float32)
    cv2.fillPoly(patch, [points], total / area, lineType=cv2.LINE_8, shift=shift)
    image[y0:y1, x0:x1] += cv2.GaussianBlur(patch, (0, 0), PSF_SIGMA_PX)
