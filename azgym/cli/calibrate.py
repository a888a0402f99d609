"""``azgym calibrate LOG --out PROFILE.toml``: fit a profile to a log with truth, and draw why.

Prints each fit with its 95 % interval, the samples it used and its method
(:mod:`azgym.logs.calibrate`), writes the profile (the table as its header comment) and, when
matplotlib is installed, a figure of the residuals beside it (``--figure``). An existing profile
or figure is replaced only with ``--overwrite``.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
from io import BytesIO
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from azgym.cli.options import add_overwrite, out_file
from azgym.errors import InvalidInputError

if TYPE_CHECKING:
    from azgym.logs.calibrate import Calibration

__all__ = ["add_calibrate", "draw_residuals"]


def add_calibrate(commands: argparse._SubParsersAction) -> None:
    """Register ``azgym calibrate``."""
    from azgym.logs.calibrate import TURN_RATE_SOURCES

    parser = commands.add_parser(
        "calibrate", help="fit a sensor, vehicle and motion profile to a log with truth")
    parser.add_argument("log", metavar="LOG", help="the log's folder (or a shipped log's name)")
    parser.add_argument("--out", required=True, metavar="PROFILE.toml", type=out_file,
                        help="the profile to write")
    parser.add_argument("--figure", metavar="PATH",
                        help="the residuals' figure (default: PROFILE-residuals.png beside "
                             "--out when matplotlib is installed; \"\" for none)")
    add_overwrite(parser, "the profile or the figure")
    parser.add_argument("--turn-rate", choices=TURN_RATE_SOURCES, default="auto",
                        help="fit the turn rate from the odometry's yaw_rate or the IMU's "
                             "(auto: the odometry's when it reports one)")
    parser.add_argument("--seed", type=int, default=0, help="the bootstrap's seed")
    parser.set_defaults(handler=_calibrate)


def _calibrate(args: argparse.Namespace) -> int:
    from azgym.files import claim_file, prepare_folder, write_file
    from azgym.logs import read_log
    from azgym.logs.calibrate import calibrate
    from azgym.profile import parse_profile, profile_toml
    from azgym.site.toml_writer import to_toml

    out = claim_file(Path(args.out), args.overwrite, "--out")
    figure = _figure(args.figure, out, args.overwrite)
    if figure is not None and figure.resolve() == out.resolve():
        raise InvalidInputError("--figure: the same file as --out; give another name")
    for path in (out, figure):  # before the work: a bad path must not waste it
        if path is not None:
            prepare_folder(path.parent)
    log = read_log(args.log)
    calibration = calibrate(log, turn_rate=args.turn_rate, seed=args.seed)
    table = calibration.table()
    print(table)
    header = (f"A profile fitted by azgym calibrate (seed {args.seed}) to the log "
              f"{log.manifest.name!r}, sha256 {log.sha256}.\n\n{table}")
    data = profile_toml(calibration.profile())
    problems: list[str] = []
    parse_profile(data, problems.append)
    if problems:  # a fit no profile can hold (a camera 20 m ahead): the data is not the model's
        raise InvalidInputError("the fits do not make a profile, nothing written:\n" + "\n".join(
            f"  {problem}" for problem in problems))
    write_file(out, to_toml(data, header))
    print(f"wrote the profile {out}")
    if figure is not None:
        draw_residuals(calibration, figure)
        print(f"wrote the residuals' figure {figure}")
    return 0


def _figure(value: str | None, out: Path, overwrite: bool) -> Path | None:
    """The figure's path: given, or beside the profile when matplotlib is installed."""
    from azgym.files import claim_file

    if value is None:
        if importlib.util.find_spec("matplotlib") is None:
            from azgym.site.drawing import figures_skipped

            print(figures_skipped([f"{out.stem}-residuals.png"]))
            return None
        value = str(out.with_name(f"{out.stem}-residuals.png"))
    elif not value:
        return None
    else:
        from azgym.errors import require

        require("matplotlib", "plot")
    return claim_file(Path(value), overwrite, "--figure")


def draw_residuals(calibration: Calibration, path: Path) -> None:
    """Draw the residuals of a calibration as a PNG at ``path``.

    Four panels: azimuth residuals by distance, speed and turn residuals over time, and the
    camera's sideways slide against the turn; a panel without its fit says so.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from azgym.files import write_file

    fits = {fit.name: fit for fit in calibration.fits}
    residuals = calibration.residuals
    figure, axes = plt.subplots(2, 2, figsize=(12, 8))
    _azimuth_panel(axes[0, 0], residuals.get("azimuth"), fits)
    for axis, key, title, unit in ((axes[0, 1], "speed", "Odometry speed", "m/s"),
                                   (axes[1, 0], "turn", "Turn rate", "rad/s")):
        if key not in residuals:
            _empty(axis, title)
            continue
        time, scaled = residuals[key]
        axis.plot(time, scaled, ".", markersize=2)
        axis.set(xlabel="time [s]", ylabel=f"(true − fitted) / √Σ hold² [{unit}]",
                 title=f"{title}: residual per frame interval")
    if "camera" in residuals:
        chord, side = residuals["camera"]
        ahead = fits["vehicle.camera_ahead"].value
        axes[1, 1].plot(chord, side, ".", markersize=2, label="frame intervals")
        grid = np.linspace(float(chord.min()), float(chord.max()), 2)
        axes[1, 1].plot(grid, ahead * grid, "k", label=f"camera_ahead = {ahead:.3f} m")
        axes[1, 1].set(xlabel="2 sin(Δφ / 2) [1]", ylabel="sideways slide [m]",
                       title="Camera ahead of the turning axis")
        axes[1, 1].legend(fontsize=8)
    else:
        _empty(axes[1, 1], "Camera ahead of the turning axis")
    figure.suptitle(f"azgym calibrate: {calibration.log_name}")
    figure.tight_layout()
    buffer = BytesIO()
    figure.savefig(buffer, format="png", dpi=100)
    plt.close(figure)
    write_file(path, buffer.getvalue())


def _azimuth_panel(axis: Any, azimuth: tuple[np.ndarray, ...] | None, fits: dict[str, Any]
                   ) -> None:
    """Residuals against distance, inliers and trimmed, with eq. 3's bound ±(Δα_d + Δα_c,i)."""
    if azimuth is None:
        _empty(axis, "Azimuth residuals")
        return
    distance, residual, kept = azimuth
    delta = fits["sensor.delta_alpha_d"].value
    axis.plot(distance[kept], np.degrees(residual[kept]), ".", markersize=2, label="inliers")
    axis.plot(distance[~kept], np.degrees(residual[~kept]), "x", markersize=3, color="tab:red",
              label="trimmed (eq. 25)")
    axis.axhline(math.degrees(delta), color="k", linewidth=0.8,
                 label=f"±Δα_d = {math.degrees(delta):.3f}° "
                       f"(coverage {'on' if fits['sensor.coverage'].value else 'off'})")
    axis.axhline(-math.degrees(delta), color="k", linewidth=0.8)
    limit = 4.0 * max(math.degrees(delta), float(np.percentile(np.abs(np.degrees(
        residual[kept])), 99)) if kept.any() else 1.0)
    axis.set(xlabel="distance to the beacon [m]", ylabel="measured − predicted azimuth [deg]",
             ylim=(-limit, limit), title="Azimuth residuals")
    axis.legend(fontsize=8)


def _empty(axis: Any, title: str) -> None:
    """A panel whose fit was not made."""
    axis.text(0.5, 0.5, "not fitted (see the table)", ha="center", va="center",
              transform=axis.transAxes)
    axis.set(title=title, xticks=[], yticks=[])
