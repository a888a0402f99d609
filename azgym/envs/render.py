"""Top-down drawings of the environments (OpenCV): racks, walls, beacons, the forklift, rays."""

from __future__ import annotations

import math
import os
import sys
from typing import Any

import cv2
import numpy as np

from azgym.errors import AzgymError, require
from azgym.sensing import geometry as G

SIZE = 640
BACKGROUND = (245, 245, 245)
RACK = (150, 150, 150)
WALL = (60, 60, 60)
MIRROR = (200, 160, 40)
BEACON = (40, 40, 200)
TRUE_POSE = (30, 140, 30)
ESTIMATE = (200, 60, 200)
RAY = {G.DIRECT: (80, 180, 80), G.PARTIAL: (40, 170, 230), G.GHOST: (40, 40, 220),
       G.MISIDENTIFIED: (160, 40, 160), G.MOVED: (20, 120, 240), G.DISTRACTOR: (120, 120, 120)}


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


def render_frame(env: Any, mode: str | None) -> np.ndarray | None:
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


def draw(env: Any) -> np.ndarray:
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
    buffers = env._buffers
    for k in np.flatnonzero(buffers.ids >= 0):
        azimuth = heading + float(buffers.true_azimuth[k])
        end = (x + 60.0 * math.cos(azimuth), y + 60.0 * math.sin(azimuth))
        colour = RAY.get(int(buffers.label[k]), (0, 0, 0))
        cv2.line(image, canvas.px(x, y), canvas.px(*end), colour, 1, cv2.LINE_AA)
    for bx, by, _ in scenario.beacon_positions:
        cv2.circle(image, canvas.px(bx, by), 4, BEACON, -1, cv2.LINE_AA)
    _arrow(canvas, x, y, heading, TRUE_POSE)
    estimate = env.last_estimate()
    if estimate is not None:
        _arrow(canvas, *estimate, ESTIMATE)
    return image[:, :, ::-1].copy()  # BGR drawing colours to RGB


def _arrow(canvas: _Canvas, x: float, y: float, heading: float, colour: tuple[int, int, int]):
    tip = (x + 1.5 * math.cos(heading), y + 1.5 * math.sin(heading))
    cv2.circle(canvas.image, canvas.px(x, y), 6, colour, 2, cv2.LINE_AA)
    cv2.arrowedLine(canvas.image, canvas.px(x, y), canvas.px(*tip), colour, 2, cv2.LINE_AA,
                    tipLength=0.3)
