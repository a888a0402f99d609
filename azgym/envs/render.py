"""Drawings of the environments (OpenCV): the top-down view, and the camera's frame beside it.

The top-down view shows racks, walls (reflective ones in gold), beacons, lamps and windows
(yellow diamonds), the true pose, the last estimate and a ray per detection, coloured by its
cause; a navigation environment (:class:`Navigating`) adds its goal (the circle the vehicle must
reach) and the path its planner laid out. A legend strip under the floor names what each colour
is, so it hides nothing of the room. With the image sensor, the fisheye
frame is drawn on the right with every detected blob ringed: green if the last estimate explains
it (its id is a map beacon whose azimuth from the estimated pose is within the error model's
tolerance), red if it does not (an outlier to that estimate), yellow if it has no id, blue if
there is no estimate yet.
"""

from __future__ import annotations

import functools
import math
import os
import sys
from typing import Any, Protocol, runtime_checkable

import cv2
import numpy as np

from azgym.core import Pose, wrap_angle
from azgym.errors import AzgymError, require
from azgym.sensing.labels import DIRECT, DISTRACTOR, GHOST, MISIDENTIFIED, MOVED, PARTIAL
from azgym.sensing.protocol import Observation
from azgym.site import Scenario

__all__ = ["ACCEPTED", "BEACON", "Drawable", "ESTIMATE", "GOAL", "LEGEND_ROW", "Navigating", "PATH",
           "REJECTED", "SIZE", "TRUE_POSE", "UNIDENTIFIED", "WALL", "blob_status", "draw",
           "render_frame", "require_display"]

SIZE = 640
BACKGROUND = (245, 245, 245)
RACK = (150, 150, 150)
WALL = (60, 60, 60)
MIRROR = (40, 160, 200)  # gold (the colours are BGR, as OpenCV draws)
BEACON = (40, 40, 200)
TRUE_POSE = (30, 140, 30)
ESTIMATE = (200, 60, 200)
LIGHT = (0, 190, 240)
GOAL = (0, 130, 250)
GOAL_AREA = (190, 225, 255)
PATH = (210, 120, 20)
TEXT = (40, 40, 40)
LEGEND_ROW = 22
"""The height of a row of the legend strip under the floor [px]."""
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


@runtime_checkable
class Navigating(Drawable, Protocol):
    """A drawable environment with somewhere to go: a goal and the path planned to it."""

    goal_radius: float
    """How close to the goal counts as arriving [m]."""

    def goal(self) -> tuple[float, float]:
        """The goal's position [m]."""
        ...

    def planned_path(self) -> np.ndarray:
        """The path being followed to the goal, as (N, 2) points [m]."""
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
        self.image = _blank(height, width).copy()

    def px(self, x: float, y: float) -> tuple[int, int]:
        return int(round((x - self.x0) * self.scale)), int(round((self.y1 - y) * self.scale))

    def points(self, xy: np.ndarray) -> np.ndarray:
        """:meth:`px` of each row of an (N, 2) array, as int32 pixels (rounded the same way)."""
        return np.rint(np.column_stack(((xy[:, 0] - self.x0) * self.scale,
                                        (self.y1 - xy[:, 1]) * self.scale))).astype(np.int32)


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
        corners = canvas.points(rack.corners())
        cv2.fillPoly(image, [corners], RACK, lineType=cv2.LINE_AA)
        if rack.reflectivity > 0:
            cv2.polylines(image, [corners], True, MIRROR, 2, cv2.LINE_AA)
    for wall in scenario.walls:
        colour = MIRROR if wall.reflectivity > 0 else WALL
        cv2.line(image, canvas.px(*wall.start), canvas.px(*wall.end), colour, 3, cv2.LINE_AA)
    navigating = env if isinstance(env, Navigating) else None
    if navigating is not None:
        _goal_and_path(canvas, navigating)
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
    image = np.vstack([image, _legend(image.shape[1], navigating is not None)])
    if frame is not None and frame.image is not None:
        image = np.hstack([image, _camera_panel(scenario, frame, frame.image, estimate,
                                                image.shape[0])])
    return cv2.cvtColor(image, cv2.COLOR_BGR2RGB)  # the drawing colours are BGR


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


def _goal_and_path(canvas: _Canvas, env: Navigating) -> None:
    """The goal's circle (tinted, ringed and marked) and the planned path as a polyline."""
    centre = canvas.px(*env.goal())
    radius = max(3, int(round(env.goal_radius * canvas.scale)))
    cv2.circle(canvas.image, centre, radius, GOAL_AREA, -1)
    cv2.circle(canvas.image, centre, radius, GOAL, 2)
    cv2.drawMarker(canvas.image, centre, GOAL, cv2.MARKER_CROSS, 12, 2)
    path = canvas.points(np.asarray(env.planned_path(), dtype=np.float64))
    cv2.polylines(canvas.image, [path], False, PATH, 2, cv2.LINE_AA)


@functools.lru_cache(maxsize=16)
def _blank(height: int, width: int) -> np.ndarray:
    """An empty canvas of that size (cached: filling one afresh costs more than copying it)."""
    blank = np.full((height, width, 3), BACKGROUND, dtype=np.uint8)
    blank.flags.writeable = False
    return blank


@functools.lru_cache(maxsize=16)
def _legend(width: int, navigating: bool) -> np.ndarray:
    """The legend strip, ``width`` pixels wide, in as many rows as its entries need (cached)."""
    entries = [("true pose", TRUE_POSE, "pose"), ("estimate", ESTIMATE, "pose"),
               ("beacon", BEACON, "dot")]
    if navigating:
        entries += [("goal", GOAL, "goal"), ("planned path", PATH, "line")]
    font, scale = cv2.FONT_HERSHEY_SIMPLEX, 0.45
    placed: list[list[tuple[int, str, tuple[int, int, int], str]]] = [[]]
    left = 8
    for text, colour, mark in entries:
        extent = 26 + cv2.getTextSize(text, font, scale, 1)[0][0] + 16
        if left + extent > width and placed[-1]:
            placed.append([])
            left = 8
        placed[-1].append((left, text, colour, mark))
        left += extent
    strip = _blank(LEGEND_ROW * len(placed), width).copy()
    for row, items in enumerate(placed):
        middle = row * LEGEND_ROW + LEGEND_ROW // 2
        for left, text, colour, mark in items:
            if mark == "line":
                cv2.line(strip, (left, middle), (left + 18, middle), colour, 2, cv2.LINE_AA)
            elif mark == "dot":
                cv2.circle(strip, (left + 9, middle), 4, colour, -1, cv2.LINE_AA)
            elif mark == "goal":
                cv2.circle(strip, (left + 9, middle), 7, GOAL_AREA, -1)
                cv2.circle(strip, (left + 9, middle), 7, colour, 2)
            else:
                cv2.circle(strip, (left + 9, middle), 6, colour, 2, cv2.LINE_AA)
            cv2.putText(strip, text, (left + 24, middle + 5), font, scale, TEXT, 1, cv2.LINE_AA)
    strip.flags.writeable = False
    return strip


def _arrow(canvas: _Canvas, x: float, y: float, heading: float,
           colour: tuple[int, int, int]) -> None:
    tip = (x + 1.5 * math.cos(heading), y + 1.5 * math.sin(heading))
    cv2.circle(canvas.image, canvas.px(x, y), 6, colour, 2, cv2.LINE_AA)
    cv2.arrowedLine(canvas.image, canvas.px(x, y), canvas.px(*tip), colour, 2, cv2.LINE_AA,
                    tipLength=0.3)
