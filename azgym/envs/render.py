"""Drawings of the environments (OpenCV): the top-down view, and the camera's frame beside it.

The top-down view shows racks, walls (reflective ones in gold), beacons, lamps and windows
(yellow diamonds), the true pose, the last
estimate and a ray per detection, coloured by its cause. With the image sensor, the fisheye
frame is drawn on the right with every detected blob ringed: green if the last estimate explains
it (its id is a map beacon whose azimuth from the estimated pose is within the error model's
tolerance), red if it does not (an outlier to that estimate), yellow if it has no id, blue if
there is no estimate yet.
"""

from __future__ import annotations

import math
import os
import sys
from typing import Any, Protocol

import cv2
import numpy as np

from azgym.core import Pose, wrap_angle
from azgym.errors import AzgymError, require
from azgym.sensing.labels import DIRECT, DISTRACTOR, GHOST, MISIDENTIFIED, MOVED, PARTIAL
from azgym.sensing.protocol import Observation
from azgym.site import Scenario

__all__ = ["ACCEPTED", "BEACON", "Drawable", "REJECTED", "SIZE", "UNIDENTIFIED", "WALL",
           "blob_status", "draw", "render_frame", "require_display"]

SIZE = 640
BACKGROUND = (245, 245, 245)
RACK = (150, 150, 150)
WALL = (60, 60, 60)
MIRROR = (200, 160, 40)
BEACON = (40, 40, 200)
TRUE_POSE = (30, 140, 30)
ESTIMATE = (200, 60, 200)
LIGHT = (0, 190, 240)
ACCEPTED = (60, 200, 60)
REJECTED = (60, 60, 230)
UNIDENTIFIED = (0, 200, 230)
IDENTIFIED = (230, 160, 60)
RAY = {DIRECT: (80, 180, 80), PARTIAL: (40, 170, 230), GHOST: (40, 40, 220),
       MISIDENTIFIED: (160, 40, 160), MOVED: (20, 120, 240), DISTRACTOR: (120, 120, 120)}


class Drawable(Protocol):
    """What a drawing needs of an environment: its scenario, poses and camera frame."""

    @property
    def scenario(self) -> Scenario:
        """The scenario it runs in."""
        ...

    @property
    def last_observation(self) -> Observation | None:
        """The camera's last frame (None before the first)."""
        ...

    def true_pose(self) -> Pose:
        """The camera's true pose."""
        ...

    def last_estimate(self) -> Pose | None:
        """The pose last estimated (None before the first)."""
        ...


class _Canvas:
    """World metres to image pixels for a scenario's room (north up)."""

    def __init__(self, bounds: tuple[float, float, float, float], size: int = SIZE) -> None:
        x_min, y_min, x_max, y_max = bounds
        margin = 0.05 * max(x_max - x_min, y_max - y_min)
        self.x0, self.y1 = x_min - margin, y_max + margin
        self.scale = size / max(x_max - x_min + 2 * margin, y_max - y_min + 2 * margin)
        width = int(math.ceil((x_max - x_min + 2 * margin) * self.scale))
        height = int(math.ceil((y_max - y_min + 2 * margin) * self.scale))
        self.image = np.full((height, width, 3), BACKGROUND, dtype=np.uint8)

    def px(self, x: float, y: float) -> tuple[int, int]:
        return int(round((x - self.x0) * self.scale)), int(round((self.y1 - y) * self.scale))


def render_frame(env: Drawable, mode: str | None) -> np.ndarray | None:
    """Draw the environment: an RGB array ("rgb_array"), or a window ("human").

    Raises:
        AzgymError: For "human" where there is no display to open a window on.
    """
    if mode is None:
        return None
    image = draw(env)
    if mode == "human":
        _show(image)
        return None
    return image


def require_display() -> None:
    """Raise a clear error unless a window can be opened (for render_mode="human")."""
    if not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY")
            or sys.platform in ("darwin", "win32")):
        raise AzgymError(
            'render_mode="human" needs a display, and there is none (DISPLAY is not set). Use '
            'render_mode="rgb_array", or record episodes with gymnasium.wrappers.RecordVideo '
            '(pip install "azgym[video]").'
        )
    require("matplotlib", "plot")


def _show(image: np.ndarray) -> None:
    """Show the frame in a matplotlib window (OpenCV here is headless and opens none)."""
    require_display()
    import matplotlib.pyplot as plt

    global _WINDOW
    if _WINDOW is None or not plt.fignum_exists(_WINDOW[0].number):
        plt.ion()
        figure, axes = plt.subplots()
        axes.set_axis_off()
        _WINDOW = (figure, axes.imshow(image))
    else:
        _WINDOW[1].set_data(image)
    plt.pause(0.001)


_WINDOW: Any = None


def draw(env: Drawable) -> np.ndarray:
    """The environment's current state, top-down, as an RGB image."""
    scenario = env.scenario
    canvas = _Canvas(scenario.bounds)
    image = canvas.image
    for rack in scenario.racks:
        corners = np.array([canvas.px(*c) for c in rack.corners()], dtype=np.int32)
        cv2.fillPoly(image, [corners], RACK, lineType=cv2.LINE_AA)
        if rack.reflectivity > 0:
            cv2.polylines(image, [corners], True, MIRROR, 2, cv2.LINE_AA)
    for wall in scenario.walls:
        colour = MIRROR if wall.reflectivity > 0 else WALL
        cv2.line(image, canvas.px(*wall.start), canvas.px(*wall.end), colour, 3, cv2.LINE_AA)
    x, y, heading = env.true_pose()
    frame = env.last_observation
    truth = frame.truth if frame is not None else None
    shown = np.isfinite(truth.azimuth) if truth is not None else np.zeros(0, dtype=bool)
    rays = zip(truth.azimuth[shown], truth.label[shown], strict=True) if truth is not None else ()
    for camera_azimuth, label in rays:
        azimuth = heading + float(camera_azimuth)
        end = (x + 60.0 * math.cos(azimuth), y + 60.0 * math.sin(azimuth))
        colour = RAY.get(int(label), (0, 0, 0))
        cv2.line(image, canvas.px(x, y), canvas.px(*end), colour, 1, cv2.LINE_AA)
    for light in scenario.lights:
        cv2.drawMarker(image, canvas.px(*light.xyz[:2]), LIGHT, cv2.MARKER_DIAMOND, 12, 2)
    for bx, by, _ in scenario.beacon_positions:
        cv2.circle(image, canvas.px(bx, by), 4, BEACON, -1, cv2.LINE_AA)
    _arrow(canvas, x, y, heading, TRUE_POSE)
    estimate = env.last_estimate()
    if estimate is not None:
        _arrow(canvas, *estimate, ESTIMATE)
    if frame is not None and frame.image is not None:
        image = np.hstack([image, _camera_panel(scenario, frame, frame.image, estimate,
                                                image.shape[0])])
    return image[:, :, ::-1].copy()  # BGR drawing colours to RGB


def _camera_panel(scenario: Scenario, frame: Observation, fisheye: np.ndarray,
                  estimate: Pose | None, height: int) -> np.ndarray:
    """The frame's fisheye image, scaled to ``height``, with each blob ringed by its status."""
    panel = cv2.cvtColor(fisheye, cv2.COLOR_GRAY2BGR)
    scale = height / panel.shape[0]
    panel = cv2.resize(panel, (int(round(panel.shape[1] * scale)), height),
                       interpolation=cv2.INTER_AREA)
    for blob, status in zip(frame.blobs, blob_status(scenario, frame, estimate), strict=True):
        centre = (int(round(blob.u * scale)), int(round(blob.v * scale)))
        cv2.circle(panel, centre, max(6, int(round(math.sqrt(blob.area) * scale))),
                   status, 1, cv2.LINE_AA)
    return panel


def blob_status(scenario: Scenario, frame: Observation,
                estimate: Pose | None) -> list[tuple[int, int, int]]:
    """Each blob's ring colour: accepted, rejected by the estimate, unidentified, or identified.

    A blob is accepted when its id is a map beacon and its azimuth is within the error model's
    tolerance (eq. 25) of the azimuth of that beacon seen from the estimated pose.
    """
    beacons = scenario.beacons
    rows = {int(beacon_id): k for k, beacon_id in enumerate(beacons.ids)}
    colours = []
    for beacon_id, azimuth in zip(frame.measurements.ids, frame.measurements.azimuth,
                                  strict=True):
        row = rows.get(int(beacon_id))
        if row is None:
            colours.append(UNIDENTIFIED)
        elif estimate is None:
            colours.append(IDENTIFIED)
        else:
            ex, ey, eh = estimate
            dx, dy = beacons.xyz[row, 0] - ex, beacons.xyz[row, 1] - ey
            predicted = math.atan2(dy, dx) - eh
            tolerance = float(scenario.error_model.tolerance(math.hypot(dx, dy),
                                                             beacons.width[row]))
            error = abs(wrap_angle(float(azimuth) - predicted))
            colours.append(ACCEPTED if error <= tolerance else REJECTED)
    return colours


def _arrow(canvas: _Canvas, x: float, y: float, heading: float,
           colour: tuple[int, int, int]) -> None:
    tip = (x + 1.5 * math.cos(heading), y + 1.5 * math.sin(heading))
    cv2.circle(canvas.image, canvas.px(x, y), 6, colour, 2, cv2.LINE_AA)
    cv2.arrowedLine(canvas.image, canvas.px(x, y), canvas.px(*tip), colour, 2, cv2.LINE_AA,
                    tipLength=0.3)
