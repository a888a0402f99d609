"""``azgym show SCENARIO``: draw a site, shipped or the user's, to a PNG file.

The picture (:func:`azgym.site.drawing.scenario_figure`) shows the racks and walls, the beacons
with their ids, lamps and windows, each route by name and where a vehicle starts on it: what
``azgym generate`` wrote, or a file being written by hand, can be looked at before it is used.
A command of its own rather than an option of ``azgym scenarios``, which lists the shipped
sites: this one takes a single site, a user's file as readily as a shipped name, and writes a
file. It needs matplotlib (``pip install "azgym[plot]"``) and replaces an existing picture only
with ``--overwrite``.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from azgym.cli.options import add_overwrite, out_file

__all__ = ["add_show"]


def add_show(commands: argparse._SubParsersAction) -> None:
    """Register ``azgym show``."""
    parser = commands.add_parser(
        "show", help="draw a scenario: its beacons (with ids), racks, walls and routes")
    parser.add_argument("scenario", metavar="SCENARIO",
                        help="a shipped scenario's name (azgym scenarios lists them) or a "
                             "scenario file (.toml)")
    parser.add_argument("--out", metavar="FILE.png", type=out_file,
                        help="the picture to write (default: the scenario's name with .png, "
                             "in the current folder)")
    add_overwrite(parser, "the picture")
    parser.set_defaults(handler=_show)


def _show(args: argparse.Namespace) -> int:
    from azgym.errors import require
    from azgym.files import claim_file, prepare_folder
    from azgym.site import load_scenario
    from azgym.site.drawing import write_scenario_figure

    require("matplotlib", "plot")
    scenario = load_scenario(args.scenario)
    out = claim_file(Path(args.out or f"{scenario.name}.png"), args.overwrite, "--out")
    prepare_folder(out.parent)
    write_scenario_figure(scenario, out)
    print(f"wrote {out}: {scenario.name}, {len(scenario.beacons.ids)} beacons, "
          f"{len(scenario.racks)} racks, {len(scenario.routes)} routes")
    return 0
