"""``azgym import DIR`` and ``azgym export route``: logged data.

``import`` checks a log folder (docs/logs.md) and prints what it holds and what the reader
changed (its notes: repeated time stamps merged, motion samples trimmed), or every problem found
with its file, line and column; ``export route`` writes a simulated route as a log. ``azgym
bench --data`` scores localizers and trackers on a log (:mod:`azgym.cli.bench`).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from azgym.cli.options import add_overwrite, out_folder

if TYPE_CHECKING:
    from azgym.logs.read import Log

__all__ = ["add_logs", "describe"]


def add_logs(commands: argparse._SubParsersAction) -> None:
    """Register ``azgym import`` and ``azgym export route``."""
    check = commands.add_parser("import", help="check a log of bearing data (docs/logs.md) "
                                               "and summarize it")
    check.add_argument("folder", metavar="DIR", help="the log's folder (with log.toml)")
    check.set_defaults(handler=_import)
    export = commands.add_parser("export", help="write a simulated route as a log")
    kinds = export.add_subparsers(dest="kind", required=True)
    route = kinds.add_parser("route", help="drive a scenario's route and write it as a log")
    route.add_argument("--scenario", required=True, help="a shipped scenario or a .toml file")
    route.add_argument("--route", help="the route's name (default: the scenario's first)")
    route.add_argument("--seed", type=int, default=0, help="the seed of every draw")
    route.add_argument("--out", required=True, metavar="DIR", type=out_folder,
                       help="the log folder to write")
    add_overwrite(route, "a log in --out")
    route.add_argument("--name", help="the dataset's name (default: "
                                      "SCENARIO-ROUTE-sSEED-simulated)")
    route.add_argument("--motion-rate", type=float, metavar="HZ",
                       help="the odometry's and IMU's rate (default: 50)")
    route.set_defaults(handler=_export)


def _import(args: argparse.Namespace) -> int:
    from azgym.logs import read_log

    print(describe(read_log(args.folder)))
    return 0


def describe(log: Log) -> str:
    """What a log holds, in a few lines, and the reader's notes: ``azgym import``'s summary."""
    from azgym.logs.problems import seconds

    manifest, frames, detections = log.manifest, log.frames, log.detections
    times, ids = frames["time"], detections["id"]
    per_frame = np.bincount(detections["frame"], minlength=len(times))
    known = log.beacons.index_of(ids) >= 0
    sequences = list(dict.fromkeys(frames["sequence"]))
    truth = "none (cannot score)" if not log.has_truth else \
        "x, y, heading on every frame" if log.has_heading else \
        "x, y on every frame (position only: heading not scored)"
    lines = [
        f"{manifest.name}: {'SIMULATED' if manifest.simulated else 'real'} data, log format "
        f"{manifest.format}; {manifest.description}",
        f"  map: {log.map_name}, {len(log.beacons)} beacons",
        f"  frames: {len(times)} over {times[-1] - times[0]:.3f} s (from {seconds(times[0])}), in "
        f"{len(sequences)} sequence(s); {len(ids)} detections ({per_frame.mean():.2f} a frame; "
        f"{int((per_frame == 0).sum())} frames without any)",
        f"  ids not in the map: {int((~known & (ids >= 0)).sum())} detections; undecoded "
        f"(negative ids): {int((ids < 0).sum())}",
        f"  truth: {truth}{f' ({manifest.truth})' if manifest.truth and log.has_truth else ''}; "
        f"labels: {'yes' if detections['labelled'] else 'no'}; quality: "
        f"{', '.join(log.quality_names) or 'none'}",
    ]
    for name, columns in (("odometry", log.odometry), ("IMU", log.imu)):
        if columns is None:
            lines.append(f"  {name}: none")
            continue
        given = [key for key in ("speed", "steer", "yaw_rate", "ax", "ay", "heading")
                 if key in columns.values]
        lines.append(f"  {name}: {columns['time'].size} samples ({', '.join(given)}"
                     f"{'; no accelerations' if name == 'IMU' and 'ax' not in given else ''})")
    profile = manifest.profile.hyperparameters()
    if profile:
        lines.append("  profile: " + ", ".join(f"{key} = {value!r}"
                                               for key, value in profile.items()))
    lines.append(f"  sha256 of its files: {log.sha256}")
    if log.notes:
        lines.append(f"  the reader changed ({len(log.notes)}):")
        lines += [f"    {note}" for note in log.notes]
    return "\n".join(lines)


def _export(args: argparse.Namespace) -> int:
    from azgym.logs import export_route

    folder = export_route(args.scenario, args.route, args.seed, Path(args.out), name=args.name,
                          motion_rate_hz=args.motion_rate, overwrite=args.overwrite)
    print(f"wrote the log {folder} (simulated); check it with: azgym import {folder}")
    return 0
