"""Drawings of a site with matplotlib, and the rules every figure of azgym shares.

:func:`scenario_figure` draws a scenario as ``azgym show`` writes it: racks and walls
(:func:`draw_floor`, which every floor plan of azgym draws the same way), the beacons with their
ids, lamps and windows, each route by name and where a vehicle starts on it. :func:`line_styles`
gives curves that stay apart however many there are to tell apart (the benchmark's and the
board's error CDFs, the routes here), and :func:`figures_skipped` the one line a command prints
when it skips its figures because matplotlib is not installed.
"""

from __future__ import annotations

import importlib.util
import io
import math
import textwrap
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from azgym.errors import require
from azgym.files import write_file
from azgym.site.scenario import Scenario

__all__ = ["DASHES", "draw_floor", "figures_skipped", "line_styles", "scenario_figure",
           "write_scenario_figure"]

DASHES = ("-", "--", ":", "-.")
"""Line styles, each taken with each of the ten colours before the next."""


def line_styles(count: int) -> list[dict[str, Any]]:
    """``count`` curve styles (matplotlib's ``color`` and ``linestyle``) that stay apart.

    The ten colours of matplotlib's ``tab10`` drawn solid, then dashed, dotted and dash-dotted:
    40 curves before a style repeats (ten colours alone repeat at the eleventh). The k-th curve
    always gets the k-th style, so a figure drawn twice is drawn the same.
    """
    from matplotlib.colors import TABLEAU_COLORS

    colours = list(TABLEAU_COLORS.values())  # tab10's, in the order of matplotlib's own cycle
    return [{"color": colours[k % len(colours)],
             "linestyle": DASHES[(k // len(colours)) % len(DASHES)]} for k in range(count)]


def figures_skipped(names: Sequence[str]) -> str | None:
    """The line to print when ``names`` (figures) are skipped; None with matplotlib installed."""
    if importlib.util.find_spec("matplotlib") is not None:
        return None
    return (f"figures skipped ({', '.join(names)}): matplotlib is not installed; "
            'pip install "azgym[plot]" draws them')


def draw_floor(axes: Any, scenario: Scenario) -> None:
    """A scenario's racks (grey footprints) and walls (dark lines) on matplotlib axes, to scale."""
    for k, rack in enumerate(scenario.racks):
        axes.fill(*rack.corners().T, color="0.75", label="racks" if k == 0 else None)
    for k, wall in enumerate(scenario.walls):
        axes.plot(*zip(wall.start, wall.end, strict=True), color="0.3",
                  label="walls" if k == 0 else None)
    axes.set_aspect("equal")


def scenario_figure(scenario: Scenario) -> Any:
    """A matplotlib figure of ``scenario``: floor, beacons with ids, lights, routes and starts.

    Raises:
        DependencyNotInstalled: matplotlib is not installed (named with the extra to install).
    """
    require("matplotlib", "plot")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x_min, y_min, x_max, y_max = scenario.bounds
    width = 9.0
    height = max(3.0, min(12.0, width * (y_max - y_min) / max(x_max - x_min, 1e-9))) + 1.0
    figure, axes = plt.subplots(figsize=(width + 2.5, height), constrained_layout=True)
    draw_floor(axes, scenario)
    xy = scenario.beacons.xy
    axes.scatter(xy[:, 0], xy[:, 1], marker="^", s=40, color="tab:red", zorder=5,
                 label="beacons")
    for beacon_id, (bx, by) in zip(scenario.beacons.ids, xy, strict=True):
        axes.annotate(str(int(beacon_id)), (bx, by), xytext=(3, 3), textcoords="offset points",
                      fontsize=7, color="tab:red", zorder=6)
    if scenario.lights:
        axes.scatter([light.xyz[0] for light in scenario.lights],
                     [light.xyz[1] for light in scenario.lights], marker="D", s=30,
                     color="gold", edgecolor="0.3", zorder=5, label="lamps and windows")
    arrow = 0.04 * max(x_max - x_min, y_max - y_min)
    for route, style in zip(scenario.routes, line_styles(len(scenario.routes)), strict=True):
        points = route.waypoints
        axes.plot(points[:, 0], points[:, 1], linewidth=1.5, label=f"route {route.name}",
                  **style)
        x, y, heading = route.start_pose()
        axes.annotate("", xy=(x + arrow * math.cos(heading), y + arrow * math.sin(heading)),
                      xytext=(x, y), zorder=7,
                      arrowprops={"arrowstyle": "-|>", "color": style["color"], "lw": 2})
    if scenario.routes:
        starts = [route.start_pose()[:2] for route in scenario.routes]
        axes.scatter([s[0] for s in starts], [s[1] for s in starts], s=60, facecolor="none",
                     edgecolor="black", zorder=7, label="starts")
    pad = 0.05 * max(x_max - x_min, y_max - y_min)
    axes.set(xlim=(x_min - pad, x_max + pad), ylim=(y_min - pad, y_max + pad),
             xlabel="x [m]", ylabel="y [m]")
    title = f"{scenario.name}: {scenario.description}" if scenario.description else scenario.name
    axes.set_title("\n".join(textwrap.wrap(title, 90)), fontsize=10)
    axes.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8)
    return figure


def write_scenario_figure(scenario: Scenario, path: Path) -> Path:
    """Draw ``scenario`` (:func:`scenario_figure`) to the PNG file ``path``.

    Raises:
        DependencyNotInstalled: matplotlib is not installed.
    """
    figure = scenario_figure(scenario)
    import matplotlib.pyplot as plt

    image = io.BytesIO()
    figure.savefig(image, format="png", dpi=110)
    plt.close(figure)
    return write_file(path, image.getvalue())
