"""Specs read by any registry of factories: the grammar, plug-in loading, names checked."""

from __future__ import annotations

import re

import pytest

from azgym.errors import InvalidInputError, UnknownNameError
from azgym.registry import (
    Registry,
    check_param_names,
    construct,
    hyperparameter_names,
    load_attribute,
    split_spec,
)


def make(*, size: int = 1, colour: str = "red") -> tuple[int, str]:
    return size, colour


def checked(spec: str, thing: object) -> object:
    if not callable(thing):
        raise InvalidInputError(f"widget spec {spec!r} names no factory")
    return thing


def test_the_grammar_names_the_kind_in_its_errors():
    assert split_spec("w:size=2,colour=blue", "widget") == ("w", {"size": 2, "colour": "blue"})
    assert split_spec("m.py:M:bounds=0,1.5", "widget") == ("m.py:M", {"bounds": [0, 1.5]})
    with pytest.raises(InvalidInputError, match=re.escape("widget spec 'w:size=2,': a comma")):
        split_spec("w:size=2,", "widget")
    with pytest.raises(InvalidInputError, match=re.escape("widget name must be a string")):
        split_spec(3, "widget")  # type: ignore[arg-type]


def test_a_registry_resolves_names_plugin_files_and_refuses_what_its_check_refuses(tmp_path):
    widgets = Registry("widget", {"plain": make}, check=checked)
    assert widgets.resolve("plain") is make
    path = tmp_path / "widget_plugin.py"
    path.write_text("def factory(*, size=3):\n    return size\n\nNUMBER = 4\n")
    assert widgets.resolve(f"{path}:factory")() == 3
    assert load_attribute(f"{path}:NUMBER", "widget") == 4
    with pytest.raises(InvalidInputError, match=re.escape("names no factory")):
        widgets.resolve(f"{path}:NUMBER")
    with pytest.raises(InvalidInputError, match=re.escape(
            "widget spec 'plain:x': 'plain' is a registered name; its hyperparameters are "
            "written plain:NAME=VALUE")):
        widgets.resolve("plain:x")
    with pytest.raises(UnknownNameError, match=re.escape("Did you mean 'plain'?")):
        widgets.resolve("plan")


def test_hyperparameters_are_a_factorys_keyword_only_arguments_checked_by_name():
    assert hyperparameter_names(make) == ("size", "colour")
    assert hyperparameter_names(max) == ()  # no readable signature: none a profile could set
    assert construct("widget", "plain", make, {"size": 2}) == (2, "red")
    with pytest.raises(InvalidInputError, match=re.escape(
            "widget 'plain': unknown hyperparameter 'colur'. Did you mean 'colour'?")):
        check_param_names("widget", "plain", make, {"colur": "blue"})
