"""Heat maps over the floor plan: predicted σ, beacons seen, the Monte Carlo check, before/after.

Every panel draws the site on top of its map: the room, the racks (grey footprints), the walls,
the beacons (black triangles) and, after ``optimize``, the new ones (red stars). σ maps share a
logarithmic colour scale in centimetres; a cell with no fix or a σ at or over the penalty
(:data:`azgym.placement.objective.PENALTY_SIGMA`) is black.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from azgym.core import FloatArray
from azgym.errors import require
from azgym.placement.floor import Floor
from azgym.placement.objective import PENALTY_SIGMA
from azgym.site import Scenario

__all__ = ["analysis_figure", "placement_figure"]

FIGURE_DPI = 110
"""Resolution of the PNG files."""


def _pyplot() -> Any:
    require("matplotlib", "plot")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _site(axes: Any, scenario: Scenario, new_xyz: FloatArray | None = None) -> None:
    """The room, racks, walls and beacons over a map."""
    from matplotlib.patches import Polygon, Rectangle

    x_min, y_min, x_max, y_max = scenario.bounds
    axes.add_patch(Rectangle((x_min, y_min), x_max - x_min, y_max - y_min, fill=False,
                             edgecolor="k", linewidth=1.0))
    for rack in scenario.racks:
        axes.add_patch(Polygon(rack.corners(), closed=True, facecolor="0.6", edgecolor="0.3"))
    for wall in scenario.walls:
        axes.plot(*zip(wall.start, wall.end, strict=True), color="k", linewidth=1.5)
    xy = scenario.beacons.xy
    axes.scatter(xy[:, 0], xy[:, 1], marker="^", s=36, color="k", zorder=5, label="beacons")
    if new_xyz is not None and len(new_xyz):
        axes.scatter(new_xyz[:, 0], new_xyz[:, 1], marker="*", s=140, color="red", zorder=6,
                     edgecolor="k", label="new beacons")
    pad = 0.05 * max(x_max - x_min, y_max - y_min)
    axes.set(xlim=(x_min - pad, x_max + pad), ylim=(y_min - pad, y_max + pad), aspect="equal",
             xlabel="x [m]", ylabel="y [m]")


def _sigma_norm(*maps: FloatArray) -> Any:
    """A logarithmic scale [cm] over the positive finite values under the penalty of ``maps``."""
    from matplotlib.colors import LogNorm

    values = np.concatenate([m[np.isfinite(m) & (m > 0) & (m < PENALTY_SIGMA)] for m in maps])
    low, high = (values.min(), values.max()) if values.size else (0.01, PENALTY_SIGMA)
    return LogNorm(vmin=100 * low, vmax=100 * max(high, 1.01 * low))


def _panel(figure: Any, axes: Any, floor: Floor, grid: FloatArray, title: str, label: str,
           **style: Any) -> None:
    """One map: ``grid`` (ny, nx) over the floor's cells, NaN off the floor, inf as 'over'."""
    half = 0.5 * floor.step
    edges_x = np.r_[floor.xs - half, floor.xs[-1] + half]
    edges_y = np.r_[floor.ys - half, floor.ys[-1] + half]
    shown = np.where(np.isinf(grid), np.finfo(float).max, grid)
    mesh = axes.pcolormesh(edges_x, edges_y, np.ma.masked_invalid(shown), shading="flat",
                           **style)
    figure.colorbar(mesh, ax=axes, label=label, shrink=0.85,
                    extend="max" if "norm" in style else "neither")
    axes.set_title(title, fontsize=10)


def _sigma_cmap() -> Any:
    import matplotlib

    return matplotlib.colormaps["viridis"].with_extremes(over="black")


def analysis_figure(scenario: Scenario, floor: Floor, sigma: FloatArray, visible: FloatArray,
                    rms: FloatArray | None, path: Path, localizer: str = "",
                    map_sigma: FloatArray | None = None) -> Path:
    """σ, beacons seen, (with ``rms``) the Monte Carlo RMS and its ratio to σ, per cell.

    With ``map_sigma`` (a surveyed map's bias floor) a last row shows it and
    σ_total = sqrt(σ² + σ_map²), on the σ maps' colour scale.
    """
    plt = _pyplot()
    extra = () if map_sigma is None else (map_sigma, np.hypot(sigma, map_sigma))
    rows = 1 + (rms is not None) + (map_sigma is not None)
    figure, grid = plt.subplots(rows, 2, figsize=(10.4, 4.6 * rows), squeeze=False)
    axes = grid.ravel()
    norm = _sigma_norm(sigma, *(() if rms is None else (rms,)), *extra)
    _panel(figure, axes[0], floor, floor.to_grid(100 * sigma), "predicted σ_pos (black: no fix "
           f"or ≥ {PENALTY_SIGMA:g} m)", "σ_pos [cm]", norm=norm, cmap=_sigma_cmap())
    _panel(figure, axes[1], floor, floor.to_grid(visible.astype(float)), "beacons seen",
           "beacons", cmap="magma", vmin=0, vmax=max(3, float(visible.max())))
    if rms is not None:
        _panel(figure, axes[2], floor, floor.to_grid(100 * rms), f"Monte Carlo RMS, {localizer}",
               "RMS error [cm]", norm=norm, cmap=_sigma_cmap())
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.where(np.isfinite(sigma), rms / sigma, np.nan)
        _panel(figure, axes[3], floor, floor.to_grid(ratio), "Monte Carlo RMS / predicted σ",
               "ratio", cmap="coolwarm", vmin=0.8, vmax=1.2)
    for a, values, title in zip(axes[-2:], extra, ("the surveyed map's bias floor σ_map",
                                                   "σ_total = sqrt(σ_pos² + σ_map²)"),
                                strict=False):
        _panel(figure, a, floor, floor.to_grid(100 * values), title, "σ [cm]", norm=norm,
               cmap=_sigma_cmap())
    for a in axes:
        _site(a, scenario)
    figure.suptitle(f"{scenario.name}: {len(scenario.beacons)} beacons, {floor.step:g} m grid")
    figure.tight_layout()
    figure.savefig(path, dpi=FIGURE_DPI)
    plt.close(figure)
    return path


def placement_figure(scenario: Scenario, floor: Floor, before: FloatArray, after: FloatArray,
                     new_xyz: FloatArray, figures: tuple[float, float], path: Path) -> Path:
    """σ before and after the new beacons, on one scale; ``figures`` the p95 before and after."""
    plt = _pyplot()
    figure, axes = plt.subplots(1, 2, figsize=(10.4, 4.6))
    norm = _sigma_norm(before, after)
    for a, sigma, title, new in ((axes[0], before, "before", None),
                                 (axes[1], after, f"after: {len(new_xyz)} new", new_xyz)):
        p95 = figures[0] if new is None else figures[1]
        _panel(figure, a, floor, floor.to_grid(100 * sigma), f"predicted σ_pos {title} "
               f"(p95 {100 * p95:.1f} cm)", "σ_pos [cm]", norm=norm, cmap=_sigma_cmap())
        _site(a, scenario, new)
    figure.suptitle(f"{scenario.name}: black = no fix or σ ≥ {PENALTY_SIGMA:g} m")
    figure.tight_layout()
    figure.savefig(path, dpi=FIGURE_DPI)
    plt.close(figure)
    return path
