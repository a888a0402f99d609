"""azgym: benchmark azimuth-based indoor localizers, and reproduce the papers they come from.

azgym bench [--suite S | --data DIR] [--localizer SPEC ...] [--with-builtins] [--split dev|test]
            [--workers N] [--time-limit SECONDS] [--quick] [--out DIR] [--overwrite]
            [--navigator NAME ...] [--backend local|ray] [--address ADDR] [--profile PROFILE.toml]
azgym bench mapping [--mapper SPEC ...] [--quick] [--time-limit SECONDS] [--workers N] [--out DIR]
                    [--overwrite]
azgym sweep CONFIG [--backend local|ray] [--address ADDR] [--workers N] [--out DIR] [--overwrite]
azgym import DIR | azgym import bag BAG --out LOG [--topic KIND=TOPIC ...] [--map MAP] [--overwrite]
azgym calibrate LOG --out PROFILE.toml [--figure FILE] [--turn-rate auto|odometry|imu] [--seed N]
                [--overwrite]
azgym survey LOG [--prior MAP] [--anchor ID ...] --out DIR [--figure FILE] [--overwrite]
azgym export route --scenario S [--route R] [--seed N] --out DIR [--name NAME] [--motion-rate HZ]
                   [--overwrite]
azgym export bag (--data LOG | --scenario S [--route R] [--seed N]) --out BAG
                 [--storage sqlite3|mcap] [--overwrite]
azgym layout analyze SCENARIO [--step M] [--localizer L] [--frames N] [--seed S] [--workers N]
                      [--survey DIR] [--time-limit SECONDS] [--out DIR] [--overwrite]
azgym layout optimize SCENARIO --add N [--step M] [--spacing M] [--out DIR] [--overwrite]
azgym leaderboard submit RESULTS --localizer SPEC --name NAME --version V --authors NAME ...
                         [--link URL] [--entries DIR] [--overwrite] [--datasets DIR]
azgym leaderboard build [--entries DIR] [--out DIR] [--navigation DIR] [--mapping DIR]
                        [--datasets DIR] [--overwrite] [--skip-unavailable]
azgym leaderboard verify ENTRY [--workers N] [--datasets DIR]
azgym reproduce paper [--quick] [--out DIR] [--workers N] [--seed S] [--no-figures] [--overwrite]
azgym reproduce plotter [--runs N] [--seed S] [--out DIR] [--overwrite]
azgym study error-model [--scenario S] [--frames N] [--noise SIGMA] [--calibration-px PX]
                        [--out DIR] [--overwrite]
azgym study ids [--scenario S] [--rate HZ] [--noise SIGMA]
azgym suites
azgym scenarios
azgym show SCENARIO [--out FILE.png] [--overwrite]
azgym generate --seed N [--out FILE.toml] [--size X Y] [--overwrite]
azgym localizers
azgym check SPEC
azgym train localizer --model ng-ransac|learned --out DIR [--layouts N] [--frames-per-layout N]
                      [--epochs N] [--seed S] [--hidden H] [--threads N] [--overwrite]
azgym train navigator --env ID --algo ppo|sac --out DIR [--steps N] [--seed S] [--localizer L]
                      [--envs N] [--threads N] [--overwrite]
azgym evaluate navigator POLICY [--env ID] [--localizer L ...] [--episodes N] [--seed S]
                         [--sensor geometry|image] [--ids oracle|blink] [--out DIR] [--overwrite]

Every command's ``--help`` ends with examples (:mod:`~azgym.cli.examples`);
``python -m azgym`` runs the command too.

The command's modules, one per command group: :mod:`~azgym.cli.bench` (a frame suite, a
navigation suite, a log or the mapping suite), :mod:`~azgym.cli.leaderboard`,
:mod:`~azgym.cli.studies` (``reproduce``, ``study``), :mod:`~azgym.cli.train`,
:mod:`~azgym.cli.evaluate`, :mod:`~azgym.cli.logs` (``import``, ``export``),
:mod:`~azgym.cli.calibrate`, :mod:`~azgym.cli.survey`, :mod:`~azgym.cli.layout`,
:mod:`~azgym.cli.sweep` and :mod:`~azgym.cli.info` (``suites``, ``scenarios``, ``localizers``,
``generate``, ``check``); :mod:`~azgym.cli.options` the options every command shares and the
progress printer. Each module registers its parsers (``add_*``);
this one builds the ``azgym`` parser from them and runs the handler (:func:`main`).
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Sequence
from typing import Any

from azgym.cli.bench import add_bench
from azgym.cli.calibrate import add_calibrate
from azgym.cli.evaluate import add_evaluate
from azgym.cli.examples import add_examples
from azgym.cli.info import add_info
from azgym.cli.layout import add_layout
from azgym.cli.leaderboard import add_leaderboard
from azgym.cli.logs import add_logs
from azgym.cli.options import ctrl_c_never_lost, interruption_within, stopped
from azgym.cli.show import add_show
from azgym.cli.studies import add_reproduce, add_study
from azgym.cli.survey import add_survey
from azgym.cli.sweep import add_sweep
from azgym.cli.train import add_train
from azgym.errors import AzgymError

__all__ = ["build_parser", "main"]


class _DefaultsFormatter(argparse.RawDescriptionHelpFormatter):
    """Help that ends each option with its default, unless the text says it or there is none.

    The description and the examples under it are printed as written, one command a line.
    """

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if (not action.option_strings or "default" in text
                or action.default in (None, False, [], argparse.SUPPRESS)):
            return text
        return f"{text} (default: %(default)s)"


class _Parser(argparse.ArgumentParser):
    """An argument parser whose ``--help`` shows every option's default."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        kwargs.setdefault("formatter_class", _DefaultsFormatter)
        super().__init__(*args, **kwargs)


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``azgym`` command."""
    from azgym._version import __version__

    parser = _Parser(prog="azgym", description=__doc__.splitlines()[0])
    parser.add_argument("--version", action="version", version=f"azgym {__version__}")
    commands = parser.add_subparsers(dest="command", required=True)
    add_bench(commands)
    add_leaderboard(commands)
    add_reproduce(commands)
    add_study(commands)
    add_train(commands)
    add_evaluate(commands)
    add_logs(commands)
    add_calibrate(commands)
    add_survey(commands)
    add_layout(commands)
    add_sweep(commands)
    add_info(commands)
    add_show(commands)
    add_examples(parser)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``azgym`` command."""
    args = build_parser().parse_args(argv)
    try:
        with ctrl_c_never_lost():
            return int(args.handler(args))
    except AzgymError as exc:
        print(f"azgym: error: {exc}", file=sys.stderr)
        return 2
    except (KeyboardInterrupt, SystemError) as exc:  # Ctrl-C: one line saying what was kept
        interruption = interruption_within(exc)  # (a kernel's machinery may have wrapped it)
        if interruption is None:
            raise
        return stopped(interruption)
    except BrokenPipeError:  # the reader left (azgym suites | head): stop without a traceback
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 1
