"""The command that trains learned localizers: ``azgym train localizer``.

Every argument is checked, torch is looked for and the output folder is made writable before
any frame is drawn, so a typo or a missing extra costs nothing; :mod:`azgym.cli` adds the
parser to the ``azgym`` command.
"""

from __future__ import annotations

import argparse
import importlib.util
import time
from pathlib import Path

from azgym.arguments import whole_number
from azgym.errors import AzgymError, DependencyNotInstalled, InvalidInputError

MODELS = ("ng-ransac", "learned")
"""The models ``--model`` names; ``learned`` is announced, not yet trainable."""
TRAINABLE = ("ng-ransac",)


def _whole(minimum: int):
    """An argparse type: a whole number >= ``minimum``, refused by argparse (exit 2)."""
    def parse(text: str) -> int:
        try:
            return whole_number("value", int(text), minimum)
        except (ValueError, AzgymError):
            raise argparse.ArgumentTypeError(f"must be an integer >= {minimum}, got {text!r}"
                                             ) from None
    return parse


def _require_training_extra() -> None:
    """Raise :class:`DependencyNotInstalled` unless torch and matplotlib can be imported."""
    if importlib.util.find_spec("torch") is None:
        raise DependencyNotInstalled('torch is not installed: pip install torch==2.13.0 first '
                                     '(the CPU wheel), then pip install "azgym[train]"')
    if importlib.util.find_spec("matplotlib") is None:
        raise DependencyNotInstalled('matplotlib is not installed (it draws the learning '
                                     'curve): pip install "azgym[train]"')


def _train_localizer(args: argparse.Namespace) -> int:
    if args.model not in TRAINABLE:
        raise InvalidInputError(f"--model {args.model}: not available yet; trainable models: "
                                f"{', '.join(TRAINABLE)}")
    _require_training_extra()
    from azgym.learn.train import train_ng_ransac

    started = time.perf_counter()
    result = train_ng_ransac(Path(args.out), layouts=args.layouts,
                             frames=args.frames_per_layout, epochs=args.epochs, seed=args.seed,
                             hidden=args.hidden, threads=args.threads)
    print(f"{args.model}: {len(result.history)} epochs, {time.perf_counter() - started:.0f} s"
          "; wrote " + ", ".join(map(str, (result.weights, result.card, result.figure))))
    return 0


def add_train(commands: argparse._SubParsersAction) -> None:
    """``azgym train localizer``: train a learned localizer on generated warehouses."""
    train = commands.add_parser("train", help="train a learned localizer (extra: train)")
    targets = train.add_subparsers(dest="target", required=True)
    localizer = targets.add_parser(
        "localizer", help="train on frames of generated warehouses; write the weight file, "
                          "learning curve and model card")
    localizer.add_argument("--model", required=True, choices=MODELS,
                           help="ng-ransac: a network orders the measurements for the "
                                "triplet search")
    localizer.add_argument("--out", required=True, metavar="DIR",
                           help="output folder (a checkpoint there is resumed)")
    localizer.add_argument("--layouts", type=_whole(1), default=64, metavar="N",
                           help="generated warehouses trained on")
    localizer.add_argument("--frames-per-layout", type=_whole(1), default=100, metavar="N",
                           help="frames drawn in each warehouse (held-out ones too)")
    localizer.add_argument("--epochs", type=_whole(1), default=20, metavar="N",
                           help="passes over the frames")
    localizer.add_argument("--seed", type=_whole(0), default=0, metavar="S",
                           help="seed of the frames, the initial weights and the batch order "
                                "(default: 0)")
    localizer.add_argument("--hidden", type=_whole(1), default=16, metavar="H",
                           help="width of the network's hidden layers")
    localizer.add_argument("--threads", type=_whole(1), default=1, metavar="N",
                           help="torch's CPU threads")
    localizer.set_defaults(handler=_train_localizer)
