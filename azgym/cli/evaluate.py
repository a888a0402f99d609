"""The command that scores a navigator: ``azgym evaluate navigator POLICY``.

A policy (the scripted ``pure-pursuit`` or a stable-baselines3 zip) drives the same episodes of a
Navigate environment once per localizer, and each localizer gets a row of the navigation scores of
:mod:`azgym.bench.navigation.scoring`. Every argument is checked, every environment built and the
policy loaded and matched against them before the first episode, so a typo, a missing extra or a
policy trained for another observation costs nothing; :mod:`azgym.cli` adds the parser to the
``azgym`` command.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from azgym.arguments import whole_number
from azgym.cli.options import add_overwrite, out_folder, progress_printer

__all__ = ["DEFAULT_ENV", "DEFAULT_LOCALIZER", "TEST_SEED", "add_evaluate"]

DEFAULT_ENV = "azgym/Navigate-WarehouseSmall-v2"
"""The environment driven unless ``--env`` names another."""
DEFAULT_LOCALIZER = "ransac"
"""The localizer used unless ``--localizer`` names others."""
TEST_SEED = 1_000_000
"""The default seed of the first episode (then + 1, ...): far above the small seeds that
training scripts, examples and tests use, so a policy is scored on episodes it has not been
tuned on, and the same ones on every run."""


def _evaluate_navigator(args: argparse.Namespace) -> int:
    from azgym.bench.navigation.benchmark import evaluate_navigator
    from azgym.bench.run.contenders import resolve_contenders
    from azgym.envs.registration import navigation_spec
    from azgym.files import claim_folder, prepare_folder

    episodes = whole_number("--episodes", args.episodes, 1)
    seed = whole_number("--seed", args.seed, 0)
    env_id = navigation_spec(args.env).id
    out = None if args.out is None else prepare_folder(
        claim_folder(Path(args.out), ["navigation.json"], args.overwrite, "--out"))
    localizers = [c.label for c in resolve_contenders(  # who runs: the bench's one rule
        args.localizer, builtins=(DEFAULT_LOCALIZER,), check=None)]
    result = evaluate_navigator(args.policy, env_id, localizers, episodes=episodes, seed=seed,
                                sensor=args.sensor, ids=args.ids,
                                progress=progress_printer())
    print(result.table())
    if out is not None:
        print(f"wrote {result.write(out)}")
    return 0


def add_evaluate(commands: argparse._SubParsersAction) -> None:
    """``azgym evaluate navigator``: score a driving policy with one localizer or several."""
    evaluate = commands.add_parser("evaluate", help="score a navigation policy")
    targets = evaluate.add_subparsers(dest="target", required=True)
    navigator = targets.add_parser(
        "navigator", help="drive a Navigate environment with a policy, once per localizer; "
                          "print success, SPL, collisions, time and localization error")
    navigator.add_argument("policy", metavar="POLICY",
                           help="'pure-pursuit' (the scripted baseline) or a stable-baselines3 "
                                ".zip (PPO, A2C, SAC, TD3, DDPG, DQN; extra: rl). A zip is "
                                "unpickled, which runs code: load only files you trust")
    navigator.add_argument("--env", default=DEFAULT_ENV, metavar="ID",
                           help="a Navigate or NavigateDiscrete environment id")
    navigator.add_argument("--localizer", action="append", default=[], metavar="L",
                           help="a localizer name or spec, or 'truth'; repeatable, one row each "
                                f"(default: {DEFAULT_LOCALIZER})")
    navigator.add_argument("--episodes", type=int, default=100, metavar="N",
                           help="episodes per localizer")
    navigator.add_argument("--seed", type=int, default=TEST_SEED, metavar="S",
                           help="seed of the first episode (then S + 1, ...); the default is "
                                f"a fixed test seed, {TEST_SEED}, away from training seeds")
    navigator.add_argument("--sensor", choices=("geometry", "image"), default="geometry",
                           help="the camera: exact geometry or the fisheye image path")
    navigator.add_argument("--ids", choices=("oracle", "blink"), default="oracle",
                           help="how the image sensor identifies beacons")
    navigator.add_argument("--out", metavar="DIR", type=out_folder,
                           help="folder to write navigation.json in")
    add_overwrite(navigator, "navigation.json in --out")
    navigator.set_defaults(handler=_evaluate_navigator)
