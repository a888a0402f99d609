"""``azgym scenarios``, ``localizers``, ``generate`` and ``check``: what ships, and checks.

``scenarios`` and ``localizers`` list the shipped scenarios and the registered localizers,
presets and trackers; ``generate`` writes a procedurally generated warehouse; ``check`` runs the
conformance checks on a localizer or tracker.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from azgym.cli.options import add_overwrite, out_file

__all__ = ["add_info"]


def add_info(commands: argparse._SubParsersAction) -> None:
    """``azgym scenarios``, ``azgym localizers``: what ships; ``azgym generate``, ``check``."""
    commands.add_parser("scenarios", help="list the shipped scenarios").set_defaults(
        handler=_scenarios)
    generate = commands.add_parser("generate", help="write a procedurally generated warehouse")
    generate.add_argument("--seed", type=int, required=True, help="the same seed, the same site")
    generate.add_argument("--out", metavar="FILE.toml", type=out_file,
                          help="the scenario file to write (default: generated-SEED.toml)")
    add_overwrite(generate, "the scenario file")
    generate.add_argument("--size", type=float, nargs=2, metavar=("X", "Y"),
                          help="the room's east-west and north-south sides [m] (default: drawn)")
    generate.set_defaults(handler=_generate)
    commands.add_parser("localizers", help="list the registered localizers and presets"
                        ).set_defaults(handler=_localizers)
    check = commands.add_parser("check", help="run the conformance checks on a localizer")
    check.add_argument("localizer", metavar="SPEC",
                       help="as for bench --localizer, e.g. path/mine.py:Mine:max_iter=20")
    check.set_defaults(handler=_check)


def _scenarios(_args: argparse.Namespace) -> int:
    from azgym.site import list_scenarios, load_scenario

    for name in list_scenarios():
        print(f"{name:<20} {load_scenario(name).description}")
    return 0


def _generate(args: argparse.Namespace) -> int:
    from azgym.site.generator import write_generated

    path = Path(args.out or f"generated-{args.seed}.toml")
    scenario = write_generated(path, args.seed, size=args.size, overwrite=args.overwrite,
                               option="--out")
    print(f"wrote {path}: {scenario.description} (loads back to the same scenario)")
    return 0


def _localizers(_args: argparse.Namespace) -> int:
    from azgym.localize.registry import PRESETS, build, list_localizers, list_trackers

    for name in list_localizers():
        if name in PRESETS:
            target, params = PRESETS[name]
            pairs = ",".join(f"{key}={json.dumps(value)}" for key, value in params.items())
            print(f"{name:<16} {target} with {pairs}")
            continue
        doc = (type(build(name)).__doc__ or "").strip().splitlines()
        print(f"{name:<16} {doc[0] if doc else ''}")
    print("\ntrackers (any localizer above runs as one too):")
    for name in list_trackers():
        doc = (type(build(name)).__doc__ or "").strip().splitlines()
        print(f"{name:<16} {doc[0] if doc else ''}")
    return 0


def _check(args: argparse.Namespace) -> int:
    from azgym.localize.checks import check_localizer
    from azgym.localize.registry import SupportsLocalize, build
    from azgym.track.checks import check_tracker

    built = build(args.localizer)  # raises (exit code 2) on a failed check, as the checks do
    if isinstance(built, SupportsLocalize):
        check_localizer(built)
    else:
        check_tracker(built)
    return 0
