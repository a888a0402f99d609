"""Figures of a benchmark run: error CDFs, fault causes, error maps and trajectories.

Error CDFs and the headline by fault cause; error maps on the floor plan; and, for driven routes,
each contender's estimates over the true routes, coloured by their error. :func:`draw_error_cdfs`
is the one drawing of error CDFs, which the board's page draws too.
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from azgym.bench.suites import CAUSES, Case
from azgym.core import BeaconMap
from azgym.files import write_file
from azgym.metrics import HEADLINE
from azgym.site import Scenario, load_scenario
from azgym.site.drawing import draw_floor, line_styles

if TYPE_CHECKING:
    from azgym.bench.report.summary import Summary
    from azgym.bench.run.outcome import RunOutcome

__all__ = ["draw_error_cdfs", "write_figures"]


def write_figures(summary: Summary, frames: list[Case],
                  outcomes: dict[str, RunOutcome], out: Path,
                  maps: dict[str, BeaconMap] | None = None) -> list[Path]:
    """cdf.png, causes.png and one error_map_<scenario>.png per scenario (needs matplotlib).

    Args:
        summary: The run's summary (results.json).
        frames: Its cases.
        outcomes: Each contender's outcome on them.
        out: The folder.
        maps: Beacon maps by the cases' scenario name, for maps that are no shipped scenario
            (a log's ``beacons.csv``): their floor plans show the beacons only, without racks
            or walls. Any other scenario is loaded by name.
    """
    maps = maps or {}
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    written = [_error_cdfs(plt, summary, outcomes, out / "cdf.png"),
               _p75_by_cause(plt, summary, out / "causes.png")]
    for scenario_name in dict.fromkeys(f.scenario for f in frames):
        given = maps.get(scenario_name)
        plan = given if given is not None else load_scenario(scenario_name)  # parsed once
        written.append(_error_map(plt, summary, frames, outcomes, (scenario_name, plan),
                                  out / f"error_map_{scenario_name}.png"))
        routed = any(f.sequence for f in frames if f.scenario == scenario_name)
        if routed:
            written.append(_trajectories(plt, summary, frames, outcomes, (scenario_name, plan),
                                         out / f"trajectories_{scenario_name}.png"))
    return written


def _error_cdfs(plt: Any, summary: Summary, outcomes: dict[str, RunOutcome],
                path: Path) -> Path:
    """One curve per localizer: the share of frames within each position error."""
    figure, axes = plt.subplots(figsize=(7, 4.5), constrained_layout=True)
    # A missing estimate is a failure: it sits at +inf, never at zero error.
    draw_error_cdfs(axes, [(label, np.where(outcomes[label].ok, outcomes[label].position * 100,
                                            np.inf)) for label in summary["localizers"]])
    axes.set_title(f"{summary['suite']} ({summary['split']}): error CDF")
    return _save(figure, path, plt)


def draw_error_cdfs(axes: Any, curves: list[tuple[str, np.ndarray]],
                    legend_size: float = 8) -> None:
    """One step curve per (label, position errors [cm]): the share of frames within each error.

    A frame without an answer is an infinite error. The curves take :func:`line_styles` in
    order, so they stay apart however many there are; the error axis is logarithmic.
    """
    for (label, errors), style in zip(curves, line_styles(len(curves)), strict=True):
        ordered = np.sort(errors)
        axes.step(ordered, np.arange(1, ordered.size + 1) / ordered.size, where="post",
                  label=label, **style)
    axes.set_xscale("log")
    axes.set_xlim(left=0.1)
    axes.set_xlabel("position error [cm]")
    axes.set_ylabel("share of frames")
    axes.grid(True, which="both", alpha=0.3)
    axes.legend(fontsize=legend_size, loc="lower right")


def _p75_by_cause(plt: Any, summary: Summary, path: Path) -> Path:
    """Bars of each localizer's headline per fault cause that occurs.

    The headline (:data:`~azgym.metrics.HEADLINE`) counts a refusal as infinitely wrong;
    an infinite one is drawn as a hatched bar up to the top of the axis, marked ∞.
    """
    labels = list(summary["localizers"])
    causes = [c for c in CAUSES if any(c in summary["localizers"][lab]["by_cause"]
                                       for lab in labels)]
    by_cause = [summary["localizers"][label]["by_cause"] for label in labels]
    values = np.array([[stats[c][HEADLINE] if c in stats else np.nan for c in causes]
                       for stats in by_cause], dtype=float)
    finite = values[np.isfinite(values) & (values > 0)]
    top = 10.0 ** np.ceil(np.log10(finite.max() * 2)) if finite.size else 100.0
    figure, axes = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
    width = 0.8 / max(len(labels), 1)
    for k, label in enumerate(labels):
        x = np.arange(len(causes)) + k * width
        bars = axes.bar(x, np.where(np.isinf(values[k]), top, values[k]), width, label=label)
        for bar, value in zip(bars, values[k], strict=True):
            if np.isinf(value):
                bar.set_hatch("//")
                axes.annotate("∞", (bar.get_x() + width / 2, top), ha="center", va="bottom",
                              fontsize=7)
    axes.set_xticks(np.arange(len(causes)) + 0.4 - width / 2, causes)
    axes.set_yscale("log")
    axes.set_ylim(top=top * 1.5)
    axes.set_ylabel("p75 position error, every frame [cm]")
    axes.set_title("by the worst fault in the frame (a refusal infinitely wrong: ∞)")
    axes.legend(fontsize=8)
    return _save(figure, path, plt)


def _error_map(plt: Any, summary: Summary, frames: list[Case],
               outcomes: dict[str, RunOutcome], scenario: tuple[str, Scenario | BeaconMap],
               path: Path) -> Path:
    """One floor plan per localizer: its position error at each of the scenario's frames.

    ``scenario`` is the cases' scenario name and its plan (:func:`_floor_plan`).
    """
    from matplotlib.colors import LogNorm

    scenario_name, plan = scenario
    labels = list(summary["localizers"])
    rows = [k for k, f in enumerate(frames) if f.scenario == scenario_name]
    xy = np.array([frames[k].pose[:2] for k in rows])
    figure, grid, colour_bar = _panels(plt, len(labels), plan)
    norm = LogNorm(vmin=0.5, vmax=1000.0)
    for axes, label in zip(grid.ravel(), labels, strict=False):
        outcome = outcomes[label]
        # A missing estimate is drawn at the top of the scale, 1000 cm.
        error = np.where(outcome.ok[rows], outcome.position[rows] * 100, 1000.0)
        _floor_plan(axes, plan)
        shown = axes.scatter(xy[:, 0], xy[:, 1], c=np.clip(error, 0.5, 1000.0), s=8,
                             norm=norm, cmap="viridis")
        axes.set_title(label, fontsize=9)
    for axes in grid.ravel()[len(labels):]:
        axes.set_axis_off()
    figure.colorbar(shown, cax=colour_bar, label="position error [cm] (none: top)")
    return _save(figure, path, plt)


PANEL_WIDTH = 4.2
"""Width of a floor-plan panel [inch]; its height follows the floor's aspect."""
PANEL_MARGINS = (0.55, 0.15, 0.35, 0.35)
"""Room around each panel for its tick labels: left, right, bottom, top (its title) [inch]."""
COLOURBAR_ROOM = 1.1
"""Width kept right of the panels for the colour bar and its label [inch]."""


def _panels(plt: Any, count: int, plan: Scenario | BeaconMap,
            title: bool = False) -> tuple[Any, Any, Any]:
    """A figure with one floor-plan panel per contender, three to a row, and a colour-bar axes.

    The panels are laid out at fixed sizes (no layout engine, which costs seconds per figure):
    each as wide as :data:`PANEL_WIDTH` and as tall as the floor's aspect makes it, with room for
    its tick labels and title; ``title`` keeps room above for a figure title.
    """
    x_min, y_min, x_max, y_max = _extent(plan)
    aspect = min(2.0, max(0.25, (y_max - y_min) / max(x_max - x_min, 1e-9)))
    columns = min(3, count)
    lines = -(-count // columns)
    left, right, bottom, top = PANEL_MARGINS
    cell_width = left + PANEL_WIDTH + right
    cell_height = bottom + PANEL_WIDTH * aspect + top
    head = 0.35 if title else 0.0
    width, height = columns * cell_width + COLOURBAR_ROOM, lines * cell_height + head
    figure = plt.figure(figsize=(width, height))
    grid = np.empty((lines, columns), dtype=object)
    for line in range(lines):
        for column in range(columns):
            x0 = column * cell_width + left
            y0 = height - head - (line + 1) * cell_height + bottom
            grid[line, column] = figure.add_axes(
                (x0 / width, y0 / height, PANEL_WIDTH / width, PANEL_WIDTH * aspect / height))
    colour_bar = figure.add_axes(((columns * cell_width + 0.1) / width, 0.1,
                                  0.15 / width, (height - head) / height - 0.2))
    return figure, grid, colour_bar


def _extent(plan: Scenario | BeaconMap) -> tuple[float, float, float, float]:
    """(x_min, y_min, x_max, y_max) of a floor plan [m]: the room, or the beacons with 1 m."""
    if isinstance(plan, BeaconMap):
        x_min, y_min = plan.xyz[:, :2].min(axis=0) - 1.0
        x_max, y_max = plan.xyz[:, :2].max(axis=0) + 1.0
        return float(x_min), float(y_min), float(x_max), float(y_max)
    return plan.bounds


def _floor_plan(axes: Any, plan: Scenario | BeaconMap) -> None:
    """A scenario's racks (grey) and walls (dark lines), or a beacon map's beacons only.

    ``plan`` is the scenario, or the beacon map of a map that is no shipped scenario (a log's
    ``beacons.csv``): its beacons are drawn as red triangles, without racks or walls.
    """
    if isinstance(plan, BeaconMap):
        axes.scatter(plan.xyz[:, 0], plan.xyz[:, 1], marker="^", s=14, color="tab:red",
                     label="beacons")
        axes.set_aspect("equal")
        return
    draw_floor(axes, plan)


def _trajectories(plt: Any, summary: Summary, frames: list[Case],
                  outcomes: dict[str, RunOutcome], scenario: tuple[str, Scenario | BeaconMap],
                  path: Path) -> Path:
    """One floor plan per contender: the true routes (lines) and its estimates, by error.

    ``scenario`` is the cases' scenario name and its plan (:func:`_floor_plan`).
    """
    from matplotlib.colors import LogNorm

    scenario_name, plan = scenario
    labels = list(summary["localizers"])
    rows = [k for k, f in enumerate(frames) if f.scenario == scenario_name]
    figure, grid, colour_bar = _panels(plt, len(labels), plan, title=True)
    norm = LogNorm(vmin=0.5, vmax=1000.0)
    for axes, label in zip(grid.ravel(), labels, strict=False):
        _floor_plan(axes, plan)
        for sequence in dict.fromkeys(frames[k].sequence for k in rows):
            truth = np.array([frames[k].pose[:2] for k in rows if frames[k].sequence == sequence])
            axes.plot(truth[:, 0], truth[:, 1], color="black", linewidth=0.6)
        outcome = outcomes[label]
        answered = [k for k in rows if outcome.ok[k]]
        shown = axes.scatter(outcome.estimate[answered, 0], outcome.estimate[answered, 1],
                             c=np.clip(outcome.position[answered] * 100, 0.5, 1000.0), s=5,
                             norm=norm, cmap="viridis")
        axes.set_title(f"{label}: {len(answered)} of {len(rows)} frames answered", fontsize=9)
    for axes in grid.ravel()[len(labels):]:
        axes.set_axis_off()
    figure.colorbar(shown, cax=colour_bar, label="position error [cm]")
    figure.suptitle(f"{scenario_name}: true routes (lines) and estimates", fontsize=10)
    return _save(figure, path, plt)


def _save(figure: Any, path: Path, plt: Any) -> Path:
    """Write the figure to ``path`` and close it (pyplot keeps open figures alive)."""
    image = io.BytesIO()
    figure.savefig(image, format="png", dpi=100)
    plt.close(figure)
    return write_file(path, image.getvalue())
