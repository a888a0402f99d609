"""``azgym suites``, ``scenarios``, ``localizers``, ``generate``, ``check``: what ships, checks.

``suites`` lists what ``azgym bench`` scores on (the frame suites, the navigation suites and the
shipped logs); ``scenarios`` and ``localizers`` list the shipped scenarios and the registered
localizers, presets and trackers; ``generate`` writes a procedurally generated warehouse;
``check`` runs the conformance checks on a localizer, tracker or mapper.
"""

from __future__ import annotations

import argparse
import json
import re
from pathlib import Path

from azgym.cli.options import add_overwrite, out_file

__all__ = ["add_info"]


def add_info(commands: argparse._SubParsersAction) -> None:
    """``azgym suites``, ``scenarios``, ``localizers``: what ships; ``generate``, ``check``."""
    commands.add_parser("suites", help="list what azgym bench scores on: the suites (--suite) "
                        "and the shipped logs (--data)").set_defaults(handler=_suites)
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
    check = commands.add_parser("check", help="run the conformance checks on a localizer, "
                                "tracker or mapper")
    check.add_argument("localizer", metavar="SPEC",
                       help="as for bench --localizer, e.g. path/mine.py:Mine:max_iter=20; a "
                       "mapper's: survey, path/mine.py:MyMapper (docs/mappers.md)")
    check.set_defaults(handler=_check)


def _suites(_args: argparse.Namespace) -> int:
    from azgym.bench.navigation.suites import NAVIGATION_SUITES
    from azgym.bench.suites import SUITES
    from azgym.bench.suites.sizes import frames
    from azgym.logs.manifest import read_manifest
    from azgym.logs.problems import Problems
    from azgym.logs.read import shipped_logs

    print("frame suites (--suite NAME; frames, --quick / full; the dev split's seed; dev+test: "
          "--split test draws a fresh one):")
    for name in SUITES.names(plugins=False):
        suite = SUITES[name]
        quick, full = frames(name) or ("?", "?")
        split = "dev only" if suite.routes else "dev+test"
        _listed(name, f"{quick} / {full}", f"seed {suite.dev_seed}, {split}", suite.description)
    print("\nnavigation suites (--suite NAME; episodes per contender, --quick / full):")
    for name, navigation in NAVIGATION_SUITES.items():
        _listed(name, f"{navigation.quick_episodes} / {navigation.episodes}",
                f"seed {navigation.dev_seed}, dev+test", navigation.description)
    from azgym.bench.mapping.suites import MAPPING_SUITES, case_names

    print("\nmapping suites (azgym bench NAME; cases per mapper, --quick / full):")
    for name, mapping in MAPPING_SUITES.items():
        _listed(name, f"{len(case_names(True))} / {len(case_names(False))}",
                f"seed {mapping.dev_seed}, dev only", mapping.description)
    print("\nshipped logs (--data NAME; every recorded frame, one size, no seed):")
    for name, folder in shipped_logs().items():
        manifest = read_manifest(folder, Problems(str(folder)))
        _listed(name, "log", "-", "(log.toml unreadable)" if manifest is None
                else manifest.description)
    return 0


def _listed(name: str, size: str, seed: str, description: str) -> None:
    """One line of ``azgym suites``: the name, size, dev seed and split, and what it is."""
    print(f"{name:<26}{size:<13}{seed:<22}{description}")


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
    from azgym.localize.registry import list_localizers, list_trackers

    for name in list_localizers():
        print(f"{name:<16} {_describe(name)}")
    print("\ntrackers (any localizer above runs as one too):")
    for name in list_trackers():
        print(f"{name:<16} {_describe(name)}")
    from azgym.mapping.registry import MAPPERS, list_mappers

    print("\nmappers (the mapping suite's contenders: docs/mappers.md):")
    for name in list_mappers():
        print(f"{name:<16} {_first_line(MAPPERS[name].__doc__)}")
    return 0


def _check(args: argparse.Namespace) -> int:
    from azgym.errors import UnknownNameError, unknown_name
    from azgym.localize.checks import check_localizer
    from azgym.localize.registry import (
        SupportsLocalize,
        build,
        list_localizers,
        list_trackers,
        parse_spec,
    )
    from azgym.mapping.checks import check_mapper
    from azgym.mapping.registry import is_mapper_spec, list_mappers, make_mapper
    from azgym.track.checks import check_tracker

    # each raises (exit code 2) on a failed check, as the checks do
    if is_mapper_spec(args.localizer):
        check_mapper(make_mapper(args.localizer))
        return 0
    try:
        built = build(args.localizer)
    except UnknownNameError:
        raise unknown_name("localizer, tracker or mapper name", parse_spec(args.localizer)[0],
                           list_localizers() + list_trackers() + list_mappers()) from None
    if isinstance(built, SupportsLocalize):
        check_localizer(built)
    else:
        check_tracker(built)
    return 0


_ROLE = re.compile(r":[a-z]+:`~?(?:[\w.]+\.)?([^`<]+?)`")
"""A Sphinx cross-reference (``:class:`~azgym.track.Tkf```): its last name is what is shown."""


def _describe(name: str) -> str:
    """What a localizer, preset or tracker is, in one line of plain text (for listings).

    A preset is its target with its hyperparameters; any other name, the first line of its
    class's docstring, without Sphinx markup or pointers to the module's docstring.
    """
    from azgym.localize.registry import PRESETS, build

    if name in PRESETS:
        target, params = PRESETS[name]
        pairs = ",".join(f"{key}={json.dumps(value)}" for key, value in params.items())
        return f"{target} with {pairs}"
    return _first_line(type(build(name)).__doc__)


def _first_line(doc: str | None) -> str:
    """A docstring's first line in plain text: no Sphinx markup, no pointer to the module's."""
    lines = (doc or "").strip().splitlines()
    first = _ROLE.sub(r"\1", lines[0] if lines else "").replace("``", "")
    return re.sub(r"\s*\((?:see )?(?:the )?module docstring\)", "", first)
