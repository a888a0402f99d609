"""``azgym survey LOG --out MAP``: every beacon's position from a driven log (docs/mapping.md).

Reads the log (its odometry or IMU, its azimuths, its profile), fixes the map frame by each
sequence's known start pose (its first frame's true pose, when the log has one) and by the
anchors (``--anchor ID``: beacons whose positions are surveyed, read from ``--prior`` or else
from the log's map), and writes ``beacons.csv`` and ``survey.csv`` into the folder ``--out``
(:mod:`azgym.mapping.output`), and the figure with ``--figure``. A ``--prior`` holding beacons
beyond the anchors is the site's map: each of its beacons the drive observes is held near its
map position (as well as the map was surveyed, ``map_sigma``), judged moved on its position
without that hold, and freed when it moved; an id it lacks is a misread one.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

from azgym.cli.options import add_overwrite, out_file

if TYPE_CHECKING:
    from azgym.core import BeaconMap
    from azgym.mapping import Survey

__all__ = ["add_survey"]


def add_survey(commands: argparse._SubParsersAction) -> None:
    """Register ``azgym survey``."""
    parser = commands.add_parser(
        "survey", help="survey the beacons' positions from a driven log (bearing-only SLAM)")
    parser.add_argument("log", metavar="LOG", help="the log's folder (or a shipped log's name)")
    parser.add_argument("--prior", metavar="MAP",
                        help="a prior map: a scenario (name or .toml) or a beacons.csv; its "
                             "beacons are held near their map positions, and those that moved "
                             "are found and surveyed afresh")
    parser.add_argument("--anchor", metavar="ID", type=int, nargs="+", default=[],
                        help="ids of surveyed beacons held at their positions (from --prior, "
                             "else from the log's map)")
    parser.add_argument("--out", required=True, metavar="MAP", type=out_file,
                        help="the folder to write beacons.csv and survey.csv into")
    parser.add_argument("--figure", metavar="FILE", type=out_file,
                        help="a PNG of the survey over the log's map (needs matplotlib)")
    add_overwrite(parser, "beacons.csv, survey.csv or the figure")
    parser.set_defaults(handler=_survey)


def _survey(args: argparse.Namespace) -> int:
    from azgym.errors import require
    from azgym.files import claim_file, claim_folder, prepare_folder, write_file
    from azgym.logs import read_log
    from azgym.mapping import Prior, log_drives, settings_from_profile, survey
    from azgym.mapping.output import MAP_FILE, SURVEY_FILE, draw_survey, map_csv, survey_csv

    require("gtsam", "mapping")
    out = claim_folder(Path(args.out), [MAP_FILE, SURVEY_FILE], args.overwrite, "--out")
    figure = None
    if args.figure is not None:
        require("matplotlib", "plot")
        figure = claim_file(Path(args.figure), args.overwrite, "--figure")
        prepare_folder(figure.parent)
    prepare_folder(out)
    log = read_log(args.log)
    given = _prior_map(args.prior) if args.prior is not None else None
    prior = Prior(given if given is not None else log.beacons if args.anchor else None,
                  tuple(args.anchor))
    result = survey(log_drives(log), prior, settings_from_profile(log.manifest.profile))
    write_file(out / MAP_FILE, map_csv(result, prior.beacons or log.beacons))
    write_file(out / SURVEY_FILE, survey_csv(result))
    print(_summary(result))
    print(f"wrote {out / MAP_FILE} and {out / SURVEY_FILE}")
    if figure is not None:
        draw_survey(result, figure, log.beacons)
        print(f"wrote the figure {figure}")
    return 0


def _prior_map(text: str) -> BeaconMap:
    """``--prior``: a beacons.csv table, or a scenario's map."""
    from azgym.errors import InvalidInputError
    from azgym.logs.manifest import read_beacons
    from azgym.site import load_scenario

    path = Path(text)
    if path.suffix == ".csv":
        if not path.is_file():
            raise InvalidInputError(f"--prior: {path} is not a file")
        return read_beacons(path)
    return load_scenario(text).beacons


def _summary(result: Survey) -> str:
    """What the survey found, in a few lines."""
    lines = [f"surveyed {int(result.observable.sum())} of {len(result.ids)} ids "
             f"({result.outliers} detections set aside as outliers)"]
    for b, beacon in enumerate(result.ids.tolist()):
        if not result.observable[b]:
            lines.append(f"  id {beacon}: unobservable: {result.reasons[b]}")
    if result.moved:
        lines.append(f"  moved from the prior map: {list(result.moved)}")
    return "\n".join(lines)
