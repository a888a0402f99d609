"""The example command lines that end every ``azgym`` command's ``--help``.

One table for every command, group and the ``azgym`` command itself, keyed by the words that
name it (``"leaderboard submit"``; ``""`` for ``azgym``): each a real command line, 1-3 of them.
:func:`add_examples` puts them under the parsers once they are built; tests/test_cli_help.py
checks that every command has them and that each parses.
"""

from __future__ import annotations

import argparse

__all__ = ["EXAMPLES", "add_examples"]

_SUBMIT = ("azgym leaderboard submit results/mine --localizer "
           "my_localizer.py:MedianOfTriplets:max_triplets=100 --name median-of-triplets "
           "--version 0.1 --authors \"Your Name\"")

EXAMPLES: dict[str, tuple[str, ...]] = {
    "": ("azgym suites", "azgym bench",
         "azgym bench --suite warehouse-static --localizer my_localizer.py:MedianOfTriplets"),
    "bench": ("azgym bench --suite warehouse-static --localizer ransac --localizer lsq",
              "azgym bench --data roh --localizer ransac --localizer lsq",
              "azgym bench --suite navigation --quick --navigator pure-pursuit"),
    "bench mapping": ("azgym bench mapping --quick",
                      "azgym bench mapping --mapper survey --mapper survey:loss=huber --quick "
                      "--out results/mapping-loss"),
    "leaderboard": (_SUBMIT, "azgym leaderboard build"),
    "leaderboard submit": (_SUBMIT,),
    "leaderboard build": ("azgym leaderboard build",
                          "azgym leaderboard build --entries my-board/entries --out my-board"),
    "leaderboard verify": ("azgym leaderboard verify leaderboard/entries/ransac-stress.json",
                           "azgym leaderboard verify leaderboard/mapping/mapping-dev.json"),
    "reproduce": ("azgym reproduce paper --quick", "azgym reproduce plotter --runs 20"),
    "reproduce paper": ("azgym reproduce paper --quick --out results/paper-quick",
                        "azgym reproduce paper --workers 2"),
    "reproduce plotter": ("azgym reproduce plotter --runs 20 --seed 1",),
    "study": ("azgym study error-model", "azgym study ids --noise 4"),
    "study error-model": ("azgym study error-model --scenario warehouse-small --frames 200",),
    "study ids": ("azgym study ids --scenario warehouse-small --noise 4",),
    "train": ("azgym train localizer --model ng-ransac --out runs/ng-ransac",
              "azgym train navigator --env azgym/Navigate-WarehouseSmall-v2 --algo ppo "
              "--out runs/navigator"),
    "train localizer": ("azgym train localizer --model ng-ransac --out runs/ng-ransac "
                        "--layouts 400 --frames-per-layout 100 --epochs 20",),
    "train navigator": ("azgym train navigator --env azgym/Navigate-WarehouseSmall-v2 --algo ppo "
                        "--out runs/navigator",),
    "evaluate": ("azgym evaluate navigator ppo --localizer ransac --episodes 20",),
    "evaluate navigator": ("azgym evaluate navigator ppo --localizer truth --localizer ransac "
                           "--episodes 200 --seed 2000000",
                           "azgym evaluate navigator runs/navigator/policy.zip --localizer "
                           "ransac"),
    "import": ("azgym import roh", "azgym import path/to/log",
               "azgym import bag wander-bag --out wander-log"),
    "export bag": ("azgym export bag --data warehouse-small-simulated --out simulated-bag",
                   "azgym export bag --scenario robot-arena --route wander-1 --seed 3 "
                   "--out wander-bag --storage mcap"),
    "export": ("azgym export route --scenario robot-arena --route long --seed 99 --out long",
               "azgym export bag --data warehouse-small-simulated --out simulated-bag"),
    "export route": ("azgym export route --scenario robot-arena --route long --seed 99 "
                     "--out long",),
    "survey": ("azgym survey drive --anchor 1 2 --out surveyed --figure survey.png",),
    "calibrate": ("azgym calibrate long --out robot.toml",
                  "azgym calibrate roh --out roh.toml --figure roh.png"),
    "layout": ("azgym layout analyze warehouse-small",
               "azgym layout optimize warehouse-small --add 4"),
    "layout analyze": ("azgym layout analyze warehouse-small --localizer ransac",),
    "layout optimize": ("azgym layout optimize warehouse-small --add 4",),
    "sweep": ("azgym sweep baselines/sweeps/ransac-iterations.toml",
              "azgym sweep baselines/sweeps/ransac-iterations.toml --workers 2 --out results/s"),
    "suites": ("azgym suites",),
    "scenarios": ("azgym scenarios",),
    "show": ("azgym show warehouse-small", "azgym show my-site.toml --out my-site.png"),
    "generate": ("azgym generate --seed 7", "azgym generate --seed 7 --size 40 25 --out site.toml"),
    "localizers": ("azgym localizers",),
    "check": ("azgym check my_localizer.py:MedianOfTriplets", "azgym check ransac:max_iter=20"),
}
"""Example command lines by command (``""``: ``azgym`` itself)."""


def add_examples(parser: argparse.ArgumentParser, words: str = "") -> None:
    """End the ``--help`` of ``parser`` and of every command under it with its examples.

    A command's one-line help becomes its ``--help``'s description too, when it has none.
    """
    parser.epilog = "examples:\n" + "\n".join(f"  {line}" for line in EXAMPLES[words])
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            helps = {choice.dest: choice.help for choice in action._choices_actions}
            for name, command in action.choices.items():
                command.description = command.description or helps.get(name)
                add_examples(command, f"{words} {name}".strip())
