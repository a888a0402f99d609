"""The commands that train: ``azgym train localizer`` and ``azgym train navigator``.

Every argument is checked, torch is looked for and the output folder is made writable before
any frame is drawn or any step is trained, so a typo or a missing extra costs nothing;
:mod:`azgym.cli` adds the parser to the ``azgym`` command.
"""

from __future__ import annotations

import argparse
import importlib.util
import time
from collections.abc import Callable
from pathlib import Path

from azgym.arguments import whole_number
from azgym.cli.options import add_overwrite, on_ctrl_c, out_folder
from azgym.errors import AzgymError, DependencyNotInstalled, InvalidInputError
from azgym.learn.defaults import FRAMES_PER_LAYOUT, MODEL_DEFAULTS

__all__ = ["MODELS", "add_train"]

MODELS = tuple(MODEL_DEFAULTS)
"""The models ``--model`` names."""


def _per_model(setting: str) -> str:
    """Each model's default of a setting, for the help: ``ng-ransac 64, learned 1000``."""
    return ", ".join(f"{model} {getattr(given, setting)}"
                     for model, given in MODEL_DEFAULTS.items())


def _whole(minimum: int) -> Callable[[str], int]:
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
    settings: dict[str, int] = {
        key: value if value is not None else getattr(MODEL_DEFAULTS[args.model], key)
        for key, value in (("layouts", args.layouts), ("epochs", args.epochs),
                           ("hidden", args.hidden))}
    _require_training_extra()
    from azgym.learn.train import CHECKPOINT_NAME

    if args.model == "learned":
        from azgym.learn.train_regression import WEIGHTS_NAME
        from azgym.learn.train_regression import train_learned as train
    else:
        from azgym.learn.train import WEIGHTS_NAME
        from azgym.learn.train import train_ng_ransac as train

    from azgym.learn.dataset import layout_seeds

    layout_seeds(settings["layouts"])  # a bad count is refused before --out is touched
    out = Path(args.out)
    checkpoint = _claim_run(out, out / WEIGHTS_NAME, out / CHECKPOINT_NAME, args)
    started = time.perf_counter()
    result = on_ctrl_c(
        lambda: train(out, layouts=settings["layouts"], frames=args.frames_per_layout,
                      epochs=settings["epochs"], seed=args.seed, hidden=settings["hidden"],
                      threads=args.threads),
        lambda: f"the last finished epoch is kept in {checkpoint} (the same command resumes "
                "from it)" if checkpoint.is_file() else "no epoch was finished, nothing was kept")
    print(f"{args.model}: {len(result.history)} epochs, {time.perf_counter() - started:.0f} s"
          "; wrote " + ", ".join(map(str, (result.weights, result.card, result.figure))))
    return 0


def _checkpoints_kept(folder: Path) -> str:
    """What an interrupted navigator training kept: its checkpoints folder, if it has any."""
    return f"the checkpoints so far are kept in {folder}" if folder.is_dir() and any(
        folder.iterdir()) else "no checkpoint was written yet, nothing was kept"


def _claim_run(out: Path, weights: Path, checkpoint: Path, args: argparse.Namespace) -> Path:
    """The checkpoint of ``train localizer`` in ``--out``, once the run there is claimed.

    A finished run there (its weight file) is refused unless ``--resume`` (train on from its
    checkpoint) or ``--overwrite`` (start over: its checkpoint is removed); an interrupted one
    (a checkpoint only) is resumed.

    Raises:
        InvalidInputError: A finished run in ``out`` and neither option.
    """
    if args.overwrite:
        checkpoint.unlink(missing_ok=True)
    elif weights.is_file() and not args.resume:
        raise InvalidInputError(
            f"--out: {out} holds a finished run ({weights.name}"
            f"{', ' + checkpoint.name if checkpoint.is_file() else ''}); nothing was written "
            "(--resume trains on from its checkpoint, e.g. with more --epochs; --overwrite "
            "starts over)")
    return checkpoint


def _train_navigator(args: argparse.Namespace) -> int:
    from azgym.files import claim_folder
    from azgym.learn.navigator.request import CHECKPOINTS
    from azgym.learn.navigator.train import NAVIGATOR_FILES, prepare, run

    claim_folder(Path(args.out), NAVIGATOR_FILES, args.overwrite, "--out")
    request = prepare(args.env, args.algo, args.steps, Path(args.out), seed=args.seed,
                      localizer=args.localizer, n_envs=args.envs, threads=args.threads)
    result = on_ctrl_c(lambda: run(request), lambda: _checkpoints_kept(request.out / CHECKPOINTS))
    print("wrote " + ", ".join(map(str, (result.policy, result.card, result.curve,
                                          result.evaluations))))
    return 0


def add_train(commands: argparse._SubParsersAction) -> None:
    """``azgym train localizer`` and ``azgym train navigator``."""
    train = commands.add_parser("train", help="train a learned localizer (extra: train) or a "
                                              "navigator (extra: rl)")
    targets = train.add_subparsers(dest="target", required=True)
    _add_localizer(targets)
    _add_navigator(targets)


def _add_navigator(targets: argparse._SubParsersAction) -> None:
    """``azgym train navigator``: a stable-baselines3 policy on a Navigate environment."""
    navigator = targets.add_parser(
        "navigator", help="train a stable-baselines3 policy on a Navigate environment; write "
                          "the policy, evaluations, learning curve and model card")
    navigator.add_argument("--env", required=True, metavar="ID",
                           help="a Navigate id, e.g. azgym/Navigate-WarehouseSmall-v2")
    navigator.add_argument("--algo", required=True, choices=("ppo", "sac"),
                           help="ppo, or sac (continuous actions: not the NavigateDiscrete ids)")
    navigator.add_argument("--out", required=True, metavar="DIR", type=out_folder,
                           help="output folder")
    add_overwrite(navigator, "a trained policy in --out")
    navigator.add_argument("--steps", type=_whole(1), metavar="N",
                           help="environment steps (default: n_timesteps of the id's entry in "
                                "azgym/learn/navigator/hyperparams.yml)")
    navigator.add_argument("--seed", type=_whole(0), default=0, metavar="S",
                           help="seed of the training environments and the algorithm "
                                "(default: 0)")
    navigator.add_argument("--localizer", metavar="L",
                           help="the environment's localizer: a name, a spec or truth "
                                "(default: the entry's, ransac)")
    navigator.add_argument("--envs", type=_whole(1), metavar="N",
                           help="environments stepped together (default: the entry's)")
    navigator.add_argument("--threads", type=_whole(1), default=1, metavar="N",
                           help="torch's CPU threads")
    navigator.set_defaults(handler=_train_navigator)


def _add_localizer(targets: argparse._SubParsersAction) -> None:
    """``azgym train localizer``: train a learned localizer on generated warehouses."""
    localizer = targets.add_parser(
        "localizer", help="train on frames of generated warehouses; write the weight file, "
                          "learning curve and model card")
    localizer.add_argument("--model", required=True, choices=MODELS,
                           help="ng-ransac: a network orders the measurements for the "
                                "triplet search; learned: a network regresses the pose")
    localizer.add_argument("--out", required=True, metavar="DIR", type=out_folder,
                           help="output folder (an interrupted run there, a checkpoint, is "
                                "resumed; a finished one is refused without --resume or "
                                "--overwrite)")
    claims = localizer.add_mutually_exclusive_group()
    claims.add_argument("--resume", action="store_true",
                        help="train on from a finished run's checkpoint in --out (e.g. with "
                             "more --epochs)")
    add_overwrite(claims, "a run in --out (it starts over: its checkpoint is removed)")
    localizer.add_argument("--layouts", type=_whole(1), metavar="N",
                           help="generated warehouses trained on (default: "
                                f"{_per_model('layouts')})")
    localizer.add_argument("--frames-per-layout", type=_whole(1), default=FRAMES_PER_LAYOUT,
                           metavar="N",
                           help="frames drawn in each warehouse (held-out ones too)")
    localizer.add_argument("--epochs", type=_whole(1), metavar="N",
                           help=f"passes over the frames (default: {_per_model('epochs')})")
    localizer.add_argument("--seed", type=_whole(0), default=0, metavar="S",
                           help="seed of the frames, the initial weights and the batch order "
                                "(default: 0)")
    localizer.add_argument("--hidden", type=_whole(1), metavar="H",
                           help="width of the network's hidden layers (default: "
                                f"{_per_model('hidden')})")
    localizer.add_argument("--threads", type=_whole(1), default=1, metavar="N",
                           help="torch's CPU threads")
    localizer.set_defaults(handler=_train_localizer)
