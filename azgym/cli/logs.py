"""``azgym import`` and ``azgym export``: logged data, and ROS bags in and out.

``import DIR`` checks a log folder (docs/logs.md) and prints what it holds and what the reader
changed (its notes: repeated time stamps merged, motion samples trimmed), or every problem found
with its file, line and column; ``import bag BAG --out LOG`` reads a ROS bag into a log
(docs/ros2.md), then prints the same summary. ``export route`` writes a simulated route as a
log; ``export bag`` writes a log, or a simulated route, as a ROS 2 bag. ``azgym bench --data``
scores localizers and trackers on a log (:mod:`azgym.cli.bench`).
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from azgym.cli.options import add_overwrite, out_folder, profile_option
from azgym.errors import InvalidInputError

if TYPE_CHECKING:
    from azgym.logs.read import Log
    from azgym.logs.ros import BagImport

__all__ = ["add_logs", "describe"]

BAG = "bag"
"""The word after ``azgym import`` that makes the next argument a bag to import."""
_BAG_OPTIONS = ("out", "overwrite", "topic", "detections_type", "msg_file", "ids_field",
                "azimuths_field", "quality_field", "frame_field", "truth_frame", "truth_parent",
                "max_gap", "steer_joint", "no_imu_heading", "map", "name", "description",
                "simulated", "profile")
"""The options of ``azgym import bag`` (refused, by name, without it)."""


def add_logs(commands: argparse._SubParsersAction) -> None:
    """Register ``azgym import`` and ``azgym export route|bag``."""
    check = commands.add_parser(
        "import", help="check a log of bearing data (docs/logs.md) and summarize it, or import "
                       "a ROS bag as a log: azgym import bag BAG --out LOG (docs/ros2.md)")
    check.add_argument("folder", metavar="DIR", help="the log's folder (with log.toml), or the "
                                                     f"word {BAG} followed by BAG")
    check.add_argument("bag", metavar="BAG", nargs="?",
                       help=f"after the word {BAG}: the ROS bag to import (a ROS 2 bag's folder, "
                            ".db3 or .mcap file, or a ROS 1 .bag file)")
    _bag_import_options(check.add_argument_group(
        f"importing a bag (azgym import {BAG} BAG --out LOG; rosbags: pip install "
        "\"azgym[ros]\")"))
    check.set_defaults(handler=_import)
    export = commands.add_parser("export", help="write a simulated route as a log, or a log as "
                                                "a ROS bag")
    kinds = export.add_subparsers(dest="kind", required=True)
    route = kinds.add_parser("route", help="drive a scenario's route and write it as a log")
    route.add_argument("--scenario", required=True, help="a shipped scenario or a .toml file")
    _route_options(route, seed=0)
    route.add_argument("--out", required=True, metavar="DIR", type=out_folder,
                       help="the log folder to write")
    add_overwrite(route, "a log in --out")
    route.set_defaults(handler=_export)
    _add_export_bag(kinds)


def _add_export_bag(kinds: argparse._SubParsersAction) -> None:
    """Register ``azgym export bag``."""
    bag = kinds.add_parser("bag", help="write a log, or a simulated route, as a ROS 2 bag "
                                       "(docs/ros2.md)")
    source = bag.add_mutually_exclusive_group(required=True)
    source.add_argument("--data", metavar="LOG", help="a log's folder or a shipped log's name")
    source.add_argument("--scenario", help="drive a route of this scenario (a shipped one or a "
                                           ".toml file), as export route does")
    _route_options(bag, seed=None)
    bag.add_argument("--out", required=True, metavar="BAG", type=out_folder,
                     help="the bag's folder to write (its files are named after it)")
    bag.add_argument("--storage", default="sqlite3", help="the bag's storage: sqlite3 or mcap")
    add_overwrite(bag, "a bag in --out")
    bag.set_defaults(handler=_export_bag)


def _route_options(parser: argparse.ArgumentParser, seed: int | None) -> None:
    """The options of a simulated route: its name, seed, dataset name and motion rate."""
    parser.add_argument("--route", help="the route's name (default: the scenario's first)")
    parser.add_argument("--seed", type=int, default=seed,
                        help="the seed of every draw" + ("" if seed is not None else
                                                         " (default: 0)"))
    parser.add_argument("--name", help="the dataset's name (default: "
                                       "SCENARIO-ROUTE-sSEED-simulated)")
    parser.add_argument("--motion-rate", type=float, metavar="HZ",
                        help="the odometry's and IMU's rate (default: 50)")


def _bag_import_options(group: argparse._ArgumentGroup) -> None:
    """The options of ``azgym import bag`` (docs/ros2.md)."""
    group.add_argument("--out", metavar="LOG", type=out_folder, help="the log folder to write")
    add_overwrite(group, "a log in --out")
    group.add_argument("--topic", action="append", metavar="KIND=TOPIC",
                       help="read KIND (detections, odometry, imu, truth, steering) from TOPIC "
                            "instead of its default (/azgym/detections, /odom, /imu, "
                            "/azgym/truth, /joint_states); a topic named must be in the bag")
    group.add_argument("--detections-type", metavar="PKG/msg/T",
                       help="your own detection type (default: azgym's, docs/ros2.md), with "
                            "--ids-field and --azimuths-field")
    group.add_argument("--msg-file", metavar="T.msg", help="the .msg definition of "
                       "--detections-type, for a bag that carries no definitions")
    for name, what in (("ids", "the beacon ids"), ("azimuths", "the azimuths [rad]")):
        group.add_argument(f"--{name}-field", metavar="PATH",
                           help=f"the field of --detections-type holding {what}, one per "
                                "detection (dotted: detections.id)")
    group.add_argument("--quality-field", action="append", metavar="NAME=PATH",
                       help="a quality value of --detections-type (repeatable)")
    group.add_argument("--frame-field", metavar="PATH", help="the frame number's field of "
                       "--detections-type (default: the message's index)")
    group.add_argument("--truth-frame", metavar="CHILD", help="read the truth from tf: this "
                       "child frame's pose (topic /tf unless --topic truth=... names another)")
    group.add_argument("--truth-parent", metavar="FRAME", help="the parent of --truth-frame "
                       "(default: map)")
    group.add_argument("--max-gap", type=float, metavar="SECONDS", help="the longest gap "
                       "between truth samples a frame's truth is interpolated across "
                       "(default: 0.5)")
    group.add_argument("--steer-joint", metavar="NAME", help="the joint (a sensor_msgs/"
                       "JointState's) whose position is the steering angle (default: steer)")
    group.add_argument("--no-imu-heading", action="store_true", help="ignore the IMU's "
                       "orientation (default: its yaw is the heading, in the map frame)")
    group.add_argument("--map", metavar="MAP", help="a bag without an azgym manifest: the "
                       "beacon map (a shipped scenario, a scenario .toml or a beacons .csv)")
    group.add_argument("--name", help="a bag without a manifest: the dataset's name (default: "
                                      "the bag's)")
    group.add_argument("--description", help="a bag without a manifest: one line about it")
    group.add_argument("--simulated", action="store_true", help="a bag without a manifest: its "
                       "frames are simulated")
    group.add_argument("--profile", type=profile_option, metavar="PROFILE.toml",
                       help="a bag without a manifest: the vehicle's, camera's and motion "
                            "sensors' profile")


def _import(args: argparse.Namespace) -> int:
    from azgym.logs import read_log

    given = [f"--{name.replace('_', '-')}" for name in _BAG_OPTIONS
             if getattr(args, name) not in (None, False)]
    if args.bag is None:
        if given:
            raise InvalidInputError(f"{', '.join(given)}: for azgym import {BAG} BAG only "
                                    "(azgym import DIR checks a log)")
        print(describe(read_log(args.folder)))
        return 0
    if args.folder != BAG:
        raise InvalidInputError(f"import {args.folder} {args.bag}: give a log's folder (azgym "
                                f"import DIR), or the word {BAG} and a bag (azgym import {BAG} "
                                "BAG --out LOG)")
    if args.out is None:
        raise InvalidInputError(f"--out: name the log folder to write (azgym import {BAG} BAG "
                                "--out LOG)")
    from azgym.logs.ros import import_bag

    log = import_bag(args.bag, args.out, _bag_import(args), overwrite=args.overwrite)
    print(f"wrote the log {args.out} from the bag {args.bag}; score it with: azgym bench "
          f"--data {args.out}")
    print(describe(log))
    return 0


def _bag_import(args: argparse.Namespace) -> BagImport:
    """``azgym import bag``'s options as the library's."""
    from azgym.arguments import positive_number
    from azgym.logs.ros import BagImport
    from azgym.logs.ros.decode import parse_path
    from azgym.logs.ros.detections import Mapping
    from azgym.logs.ros.log_files import Options

    fields = [args.ids_field, args.azimuths_field, args.quality_field, args.frame_field]
    mapping = None
    if any(fields):
        if not (args.ids_field and args.azimuths_field and args.detections_type):
            raise InvalidInputError("--ids-field, --azimuths-field: a user's detection type "
                                    "needs both, and --detections-type")
        mapping = Mapping(
            parse_path(args.ids_field, "--ids-field"),
            parse_path(args.azimuths_field, "--azimuths-field"),
            tuple((name, parse_path(path, "--quality-field")) for name, path in
                  (_pair(text, "--quality-field") for text in args.quality_field or ())),
            parse_path(args.frame_field, "--frame-field") if args.frame_field else None)
    given: dict[str, Any] = {key: value for key, value in (
        ("truth_parent", args.truth_parent), ("steer_joint", args.steer_joint),
        ("max_gap", None if args.max_gap is None else
         positive_number("--max-gap", args.max_gap, "s"))) if value is not None}
    return BagImport(
        topics=dict(_pair(text, "--topic") for text in args.topic or ()),
        detections_type=args.detections_type,
        msg_file=Path(args.msg_file) if args.msg_file else None, mapping=mapping,
        truth_frame=args.truth_frame, imu_heading=not args.no_imu_heading,
        log=Options(args.map, args.name, args.description, True if args.simulated else None,
                    Path(args.profile) if args.profile else None), **given)


def _pair(text: str, option: str) -> tuple[str, str]:
    """``NAME=VALUE`` of a repeatable option."""
    name, equals, value = text.partition("=")
    if not (name and equals and value):
        raise InvalidInputError(f"{option}: {text!r} is not NAME=VALUE")
    return name, value


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


def _export_bag(args: argparse.Namespace) -> int:
    from azgym.logs import export_route, read_log
    from azgym.logs.ros import export_bag
    from azgym.logs.ros.write_bag import claim_bag

    if args.data is not None:
        route = [f"--{name.replace('_', '-')}" for name in ("route", "seed", "name", "motion_rate")
                 if getattr(args, name) is not None]
        if route:
            raise InvalidInputError(f"{', '.join(route)}: options of a simulated route "
                                    "(--scenario), not of --data")
        folder = export_bag(read_log(args.data), args.out, storage=args.storage,
                            overwrite=args.overwrite)
    else:
        claim_bag(Path(args.out), args.storage, args.overwrite)  # before the route is driven
        with tempfile.TemporaryDirectory(prefix="azgym-route-") as scratch:
            log = export_route(args.scenario, args.route, args.seed or 0, Path(scratch) / "log",
                               name=args.name, motion_rate_hz=args.motion_rate)
            folder = export_bag(read_log(log), args.out, storage=args.storage,
                                overwrite=args.overwrite)
    print(f"wrote the bag {folder} ({args.storage}); read it back with: azgym import {BAG} "
          f"{folder} --out LOG")
    return 0
