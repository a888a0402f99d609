"""A survey written out: the map as ``beacons.csv``, each beacon's covariance beside it, a figure.

``beacons.csv`` is docs/logs.md's table (id, x, y, z, width) of the observable beacons only, so
a log's ``[map] beacons`` reads it as it is; ``survey.csv`` lists every id detected with its
position and covariance (``sxx``, ``sxy``, ``syy`` [m²]), whether it was surveyed, moved, and
why not. The figure draws the estimate (with 95 % ellipses) over the truth when one is given.
"""

from __future__ import annotations

import io
import math
from pathlib import Path

import numpy as np

from azgym.core import BeaconMap
from azgym.errors import require
from azgym.files import write_file
from azgym.mapping.survey import Survey

__all__ = ["MAP_FILE", "SURVEY_FILE", "draw_survey", "map_csv", "survey_csv"]

MAP_FILE = "beacons.csv"
"""The map's file name in the output folder."""
SURVEY_FILE = "survey.csv"
"""The per-id table's file name."""
ELLIPSE_CHI2 = 5.991
"""χ² of 2 degrees of freedom at 0.95: the drawn ellipses hold the beacon with that chance."""


def map_csv(result: Survey, prior: BeaconMap | None = None) -> str:
    """``beacons.csv`` of the observable beacons (z and width from ``prior`` where known)."""
    beacons = result.beacon_map(prior)
    lines = ["id,x,y,z,width"]
    for i, (x, y, z), w in zip(beacons.ids.tolist(), beacons.xyz.tolist(),
                               beacons.width.tolist(), strict=True):
        lines.append(f"{i},{x:.4f},{y:.4f},{z:.4f},{w:.4f}")
    return "\n".join(lines) + "\n"


def survey_csv(result: Survey) -> str:
    """``survey.csv``: every id with its position, covariance and status."""
    lines = ["id,x,y,sxx,sxy,syy,observable,anchor,moved,rays,outliers,reason"]
    for b, beacon in enumerate(result.ids.tolist()):
        x, y = result.xy[b]
        cov = result.covariances[b]
        numbers = ",".join("" if math.isnan(v) else f"{v:.6g}"
                           for v in (x, y, cov[0, 0], cov[0, 1], cov[1, 1]))
        reason = result.reasons[b].replace('"', "'")
        lines.append(f"{beacon},{numbers},{int(result.observable[b])},"
                     f"{int(beacon in result.anchors)},{int(beacon in result.moved)},"
                     f"{result.rays[b]},{result.outlier_rays[b]},\"{reason}\"")
    return "\n".join(lines) + "\n"


def draw_survey(result: Survey, path: Path, truth: BeaconMap | None = None) -> Path:
    """Draw the survey (poses, beacons, 95 % ellipses) over ``truth`` as a PNG at ``path``."""
    require("matplotlib", "plot")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Ellipse

    figure, axes = plt.subplots(figsize=(9, 7))
    for n, poses in enumerate(result.poses):
        axes.plot(poses[:, 0], poses[:, 1], "-", color="0.6", linewidth=0.8,
                  label="camera path (solved)" if n == 0 else None)
    if truth is not None:
        axes.plot(truth.xyz[:, 0], truth.xyz[:, 1], "k+", markersize=10, label="true beacons")
    keep = np.flatnonzero(result.observable)
    axes.plot(result.xy[keep, 0], result.xy[keep, 1], "o", color="tab:blue", markersize=4,
              label="surveyed beacons")
    for b in keep.tolist():
        values, vectors = np.linalg.eigh(result.covariances[b])
        width, height = 2.0 * np.sqrt(ELLIPSE_CHI2 * np.maximum(values, 0.0))
        angle = math.degrees(math.atan2(vectors[1, 1], vectors[0, 1]))
        axes.add_patch(Ellipse(result.xy[b], height, width, angle=angle, fill=False,
                               color="tab:blue"))
        colour = "tab:red" if result.ids[b] in result.moved else "black"
        axes.annotate(str(result.ids[b]), result.xy[b], textcoords="offset points",
                      xytext=(4, 4), fontsize=8, color=colour)
    axes.set(aspect="equal", xlabel="x [m]", ylabel="y [m]",
             title=f"Survey: {keep.size} of {len(result.ids)} ids surveyed, "
                   f"{len(result.moved)} moved (red), ellipses 95 %")
    axes.legend(fontsize=8, loc="best")
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=120, bbox_inches="tight")
    plt.close(figure)
    return write_file(path, buffer.getvalue())
