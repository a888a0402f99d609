"""Does the paper's azimuth error model hold on the image? ``azgym study error-model``.

Rátosi & Simon model a measured azimuth as the truth plus two uniform errors (eq. 1-3): a
centre-detection error of ±Δα_d, with Δα_d = atan(ΔC_p / R_p) for a blob centre found ΔC_p ≈ 1 px
off on a horizon circle of R_p pixels (eq. 1), and a coverage error of at most atan(W / 2D) for
a partly covered beacon (eq. 2). This study renders frames at random poses of a scenario, detects
the beacons from pixels (``ImageSensor``, ids by the oracle) and measures, per detected beacon:

* the **centre error**: the blob centroid's offset from the projected centre of the visible part
  of the beacon, along the azimuth direction (the component that moves the azimuth) [px];
* the **azimuth error** against the beacon's true centre direction, and its split into centre
  error and **coverage error** (visible centroid minus the whole beacon's centre);
* the same azimuth errors when the principal point used to turn pixels into azimuths is off by
  ``calibration_px`` (a calibration error: it shifts a blob at radius r by up to δc / r rad).

It writes ``error_model.json`` and ``error_model.png`` (three panels: the centre error's
histogram beside the ±ΔC_p model; the azimuth error against the blob's radius on the image with
eq. 1's band and the 1/r law; the coverage error against distance with eq. 2's bound).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from azgym.core import FloatArray, wrap_angle
from azgym.files import prepare_folder, write_file
from azgym.progress import Progress, counter
from azgym.sensing.image.sensor import ImageSensor
from azgym.sensing.labels import MOVED
from azgym.site import Scenario, load_scenario
from azgym.site.sampling import random_free_pose

__all__ = ["ERROR_MODEL_FILES", "measure_detections", "plot", "run", "summarize"]

_SUMMARY, _FIGURE = "error_model.json", "error_model.png"
ERROR_MODEL_FILES = (_SUMMARY, _FIGURE)
"""What :func:`run` writes into its folder: what ``azgym study error-model`` claims in
``--out``."""


def measure_detections(scenario: Scenario | str, frames: int = 300, noise_sigma: float = 2.0,
                       calibration_px: float = 1.0, seed: int = 0,
                       progress: Progress | None = None) -> dict[str, FloatArray]:
    """Per-detection errors of the image path at random poses (beacons only, ghosts left out).

    ``progress`` hears the count of frames rendered (:func:`azgym.progress.counter`).

    Returns:
        Arrays, one entry per detected beacon: ``distance`` [m], ``radius_px`` (blob's distance
        from the principal point), ``visible`` share, ``centre_px`` (tangential centre error),
        ``azimuth`` (measured minus the whole beacon's true azimuth), ``coverage`` (visible
        centroid minus the whole beacon's azimuth) and ``azimuth_calibrated`` (the azimuth error
        with the principal point off by ``calibration_px``, in a random direction per frame)
        [rad].
    """
    scenario = load_scenario(scenario)
    sensor = ImageSensor(scenario, noise_sigma=noise_sigma)
    sensor.reset(seed)
    rng = np.random.default_rng(seed)
    rows: dict[str, list[float]] = {key: [] for key in (
        "distance", "radius_px", "visible", "centre_px", "azimuth", "coverage",
        "azimuth_calibrated")}
    with counter(progress, "rendering", frames, "frames") as rendered:
        for done in range(1, frames + 1):
            _measure_frame(scenario, sensor, calibration_px, rng, rows)
            rendered(done)
    return {key: np.array(values) for key, values in rows.items()}


def _measure_frame(scenario: Scenario, sensor: ImageSensor, calibration_px: float,
                   rng: np.random.Generator, rows: dict[str, list[float]]) -> None:
    """One frame at a random pose: each detected beacon's errors appended to ``rows``."""
    cx, cy = sensor.camera.principal_point
    positions = scenario.beacon_positions
    x, y, heading = random_free_pose(scenario, rng)
    frame = sensor.observe((x, y, heading), rng)
    truth = frame.truth
    offset_angle = rng.uniform(-math.pi, math.pi)
    bx, by = cx + calibration_px * math.cos(offset_angle), cy + calibration_px * math.sin(
        offset_angle)
    real = np.flatnonzero((truth.beacon >= 0) & ~truth.mirrored & (truth.label != MOVED))
    for k in real:
        blob = frame.blobs[k]
        beacon = positions[truth.beacon[k]]
        dx, dy = beacon[0] - x, beacon[1] - y
        whole = math.atan2(dy, dx) - heading
        radius = math.hypot(blob.u - cx, blob.v - cy)
        centre = wrap_angle(blob.azimuth - truth.azimuth[k])
        rows["distance"].append(math.hypot(dx, dy))
        rows["radius_px"].append(radius)
        rows["visible"].append(float(truth.visible[k]))
        rows["centre_px"].append(centre * radius)
        rows["azimuth"].append(wrap_angle(blob.azimuth - whole))
        rows["coverage"].append(wrap_angle(truth.azimuth[k] - whole))
        shifted = math.atan2(blob.v - by, blob.u - bx)
        rows["azimuth_calibrated"].append(wrap_angle(shifted - whole))


def summarize(scenario: Scenario, errors: dict[str, FloatArray],
              calibration_px: float) -> dict[str, Any]:
    """The study's figures beside the model's (see the module's docstring)."""
    model = scenario.error_model
    whole = errors["visible"] == 1.0
    centre = np.abs(errors["centre_px"][whole])
    bound = np.degrees(model.delta_alpha_d)
    azimuth = np.degrees(np.abs(errors["azimuth"][whole]))
    calibrated = np.degrees(np.abs(errors["azimuth_calibrated"][whole]))
    partial = ~whole
    width = float(np.median(scenario.beacons.width))
    coverage_ratio = np.abs(errors["coverage"][partial]) / np.arctan2(
        0.5 * width, errors["distance"][partial])
    return {
        "scenario": scenario.name,
        "detections": int(whole.size),
        "whole_beacons": int(whole.sum()),
        "partly_covered": int(partial.sum()),
        "model_delta_alpha_d_deg": bound,
        "model_center_error_px": math.tan(model.delta_alpha_d) * scenario.fisheye.horizon_radius_px,
        "centre_error_px": _quantiles(centre),
        "azimuth_error_deg": _quantiles(azimuth),
        "azimuth_error_within_model": float(np.mean(azimuth <= bound)),
        "calibration_px": calibration_px,
        "azimuth_error_calibrated_deg": _quantiles(calibrated),
        "calibrated_within_model": float(np.mean(calibrated <= bound)),
        "coverage_over_eq2_bound": _quantiles(coverage_ratio) if partial.any() else None,
        "coverage_within_eq2_bound": float(np.mean(coverage_ratio <= 1.0 + 1e-9))
        if partial.any() else None,
    }


def _quantiles(values: FloatArray) -> dict[str, float]:
    if not values.size:
        return {}
    return {"mean": float(values.mean()), "median": float(np.median(values)),
            "p95": float(np.percentile(values, 95)), "max": float(values.max())}


def plot(scenario: Scenario, errors: dict[str, FloatArray], calibration_px: float,
         path: Path) -> None:
    """The three panels (see the module's docstring)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    model = scenario.error_model
    whole = errors["visible"] == 1.0
    figure, axes = plt.subplots(1, 3, figsize=(15, 4.2))
    centre = errors["centre_px"][whole]
    model_px = math.tan(model.delta_alpha_d) * scenario.fisheye.horizon_radius_px
    axes[0].hist(centre, bins=60, density=True, color="tab:blue", alpha=0.8,
                 label="rendered and detected")
    axes[0].plot([-model_px, -model_px, model_px, model_px],
                 [0, 0.5 / model_px, 0.5 / model_px, 0], color="k",
                 label=f"eq. 1 model: uniform ±{model_px:.2g} px")
    axes[0].set(xlabel="centre error along the azimuth [px]", ylabel="density",
                title="Centre-detection error")
    axes[0].legend(fontsize=8)
    radius = errors["radius_px"][whole]
    axes[1].scatter(radius, np.degrees(np.abs(errors["azimuth"][whole])), s=3,
                    label="pixels only", color="tab:blue")
    axes[1].scatter(radius, np.degrees(np.abs(errors["azimuth_calibrated"][whole])), s=3,
                    label=f"principal point off by {calibration_px:g} px", color="tab:orange",
                    alpha=0.5)
    grid = np.linspace(max(10.0, radius.min(initial=10.0)), scenario.fisheye.horizon_radius_px, 100)
    axes[1].axhline(np.degrees(model.delta_alpha_d), color="k",
                    label=f"eq. 1: Δα_d = {np.degrees(model.delta_alpha_d):.2f}°")
    axes[1].plot(grid, np.degrees(calibration_px / grid), "k--", label="δc / r")
    axes[1].set(xlabel="blob's radius on the image r [px]", ylabel="|azimuth error| [deg]",
                yscale="log", title="Azimuth error of whole beacons")
    axes[1].legend(fontsize=8)
    partial = ~whole
    distance = errors["distance"]
    axes[2].scatter(distance[partial], np.degrees(np.abs(errors["coverage"][partial])), s=6,
                    color="tab:green", label="partly covered beacons")
    width = float(np.median(scenario.beacons.width))
    grid = np.linspace(0.5, max(1.0, distance.max(initial=1.0)), 100)
    axes[2].plot(grid, np.degrees(np.arctan2(0.5 * width, grid)), "k",
                 label=f"eq. 2 bound, W = {width * 100:g} cm")
    axes[2].set(xlabel="distance D [m]", ylabel="|coverage error| [deg]", yscale="log",
                title="Coverage error")
    axes[2].legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(path, dpi=110)
    plt.close(figure)


def run(scenario: str = "warehouse-small", frames: int = 300, noise_sigma: float = 2.0,
        calibration_px: float = 1.0, seed: int = 0, out: Path | None = None,
        figures: bool = True, progress: Progress | None = None) -> dict[str, Any]:
    """Measure, summarize and (with ``out``) write the study (:data:`ERROR_MODEL_FILES`).

    ``progress`` hears the count of frames rendered.
    """
    loaded = load_scenario(scenario)
    errors = measure_detections(loaded, frames, noise_sigma, calibration_px, seed, progress)
    summary = summarize(loaded, errors, calibration_px)
    summary.update(frames=frames, noise_sigma=noise_sigma, seed=seed)
    if out is not None:
        write_file(prepare_folder(out) / _SUMMARY, json.dumps(summary, indent=2) + "\n")
        if figures:
            plot(loaded, errors, calibration_px, out / _FIGURE)
    return summary
