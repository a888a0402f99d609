"""First use: every command's help, examples and listings read as a newcomer needs them."""

from __future__ import annotations

import argparse
import re
import shlex
import subprocess
import sys
from collections.abc import Iterator

import pytest

from azgym.bench.mapping.suites import MAPPING_SUITES, case_names
from azgym.bench.navigation.suites import NAVIGATION_SUITES
from azgym.bench.suites import SUITES
from azgym.cli import build_parser, main
from azgym.logs.read import shipped_logs


def commands(parser: argparse.ArgumentParser, words: str = ""
             ) -> Iterator[tuple[str, argparse.ArgumentParser]]:
    """Every command and group of the parser, by the words that name it, itself first."""
    yield words, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, command in action.choices.items():
                yield from commands(command, f"{words} {name}".strip())


COMMANDS = dict(commands(build_parser()))


@pytest.mark.parametrize("words", list(COMMANDS))
def test_every_option_of_every_command_has_help(words):
    missing = [action.option_strings[0] for action in COMMANDS[words]._actions
               if action.option_strings and not action.help]
    assert not missing, f"azgym {words}: options without help: {missing}"


@pytest.mark.parametrize("words", list(COMMANDS))
def test_every_help_ends_with_one_to_three_examples_that_parse(words):
    text = COMMANDS[words].format_help()
    tail = text.rstrip().split("examples:\n", 1)
    assert len(tail) == 2, f"azgym {words} --help has no examples"
    examples = [line.strip() for line in tail[1].splitlines()]
    assert 1 <= len(examples) <= 3 and all(line.startswith("azgym ") for line in examples)
    for line in examples:
        argv = shlex.split(line)[1:]
        assert argv[:len(words.split())] == words.split(), line  # an example of this command
        build_parser().parse_args(argv)  # exits on a wrong option or value


def test_python_dash_m_azgym_runs_the_command():
    done = subprocess.run([sys.executable, "-m", "azgym", "--version"], capture_output=True,
                          text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.startswith("azgym "), done.stderr


def test_localizers_prints_plain_text(capsys):
    assert main(["localizers"]) == 0
    printed = capsys.readouterr().out
    for markup in ("(module docstring)", ":class:", ":func:", "``", ":mod:"):
        assert markup not in printed
    assert re.search(r"^lpkf +Plotter's low-pass filtered Kalman filter: Tkf ", printed, re.M)


def test_suites_lists_every_suite_and_shipped_log_with_size_and_seed(capsys):
    assert main(["suites"]) == 0
    lines = {line.split()[0]: line.split(None, 5) for line in capsys.readouterr().out.splitlines()
             if line and not line.endswith(":")}
    for name in SUITES.names(plugins=False):
        suite = SUITES[name]
        _, quick, _, full, seed, split_and_description = lines[name]
        assert int(quick) < int(full) or name == "route-events"
        assert seed == "seed" and split_and_description.startswith(
            f"{suite.dev_seed}, {'dev only' if suite.routes else 'dev+test'} ")
    for name, suite in NAVIGATION_SUITES.items():
        assert lines[name][1:5] == [str(suite.quick_episodes), "/", str(suite.episodes), "seed"]
    for name in shipped_logs():
        assert lines[name][1:3] == ["log", "-"]
    for name, mapping in MAPPING_SUITES.items():
        assert lines[name][1:5] == [str(len(case_names(True))), "/", str(len(case_names(False))),
                                    "seed"]
        assert lines[name][5].startswith(f"{mapping.dev_seed}, dev only ")
    assert lines["stress"][1:5] == ["60", "/", "600", "seed"]
    assert "warehouse-large (64 beacons)" in lines["stress"][5]
