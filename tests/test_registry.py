"""The one registry shape: names to things or lazy references, plug-ins, refusals."""

from __future__ import annotations

import re
import subprocess
import sys
import uuid
from importlib.metadata import EntryPoint

import pytest

import azgym.registry
from azgym.errors import InvalidInputError, UnknownNameError
from azgym.registry import Registry, load_reference


@pytest.fixture
def module_on_path(tmp_path, monkeypatch):
    """A module of a fresh name, importable but not imported: ``make(x=1)`` returns x + 1."""
    name = f"registry_probe_{uuid.uuid4().hex[:8]}"
    (tmp_path / f"{name}.py").write_text("def make(*, x=0, y=0):\n    return (x + 1, y)\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    yield name
    sys.modules.pop(name, None)


def test_a_reference_is_imported_only_when_its_thing_is_made(module_on_path):
    things = Registry("thing", {"probe": f"{module_on_path}:make"})
    assert "probe" in things and things.names() == ["probe"] and len(things) == 1
    things.check_name("probe")
    assert module_on_path not in sys.modules  # listing and looking a name up load nothing
    assert things.make("probe", x=1) == (2, 0)
    assert module_on_path in sys.modules


def test_an_unknown_name_suggests_the_closest_and_lists_the_valid_ones():
    colours = Registry("colour", {"red": "x:y", "green": "x:y"})
    message = "unknown colour 'gren'. Did you mean 'green'? Valid colours: green, red."
    with pytest.raises(UnknownNameError, match=re.escape(message)):
        colours["gren"]
    with pytest.raises(UnknownNameError, match=re.escape(message)):
        colours.make("gren")
    with pytest.raises(UnknownNameError, match=re.escape(message)):
        colours.check_name("gren")
    with pytest.raises(UnknownNameError, match=re.escape("unknown colour '3'")):
        colours[3]
    assert colours.get("gren") is None and 3 not in colours  # a mapping's answers
    with pytest.raises(KeyError):  # UnknownNameError is one
        colours["blue"]


def test_a_name_is_registered_once_and_is_a_non_empty_string():
    things = Registry("thing", {"one": 1})
    with pytest.raises(InvalidInputError, match=re.escape("a thing named 'one' is already "
                                                          "registered")):
        things.register("one", 2)
    assert things["one"] == 1  # the first stays
    for name in ("", None, 5):
        with pytest.raises(InvalidInputError, match=re.escape(
                f"thing name must be a non-empty string, got {name!r}")):
            things.register(name, 3)


def test_names_keep_the_order_of_registration():
    things = Registry("thing", {"b": 1, "a": 2})
    things.register("c", 3)
    assert list(things) == things.names() == ["b", "a", "c"]
    assert dict(things.items()) == {"b": 1, "a": 2, "c": 3}


def test_a_bad_reference_is_refused():
    with pytest.raises(InvalidInputError, match="is written 'module:attribute'"):
        load_reference("fractions.Fraction")
    assert load_reference("os.path:join.__name__") == "join"


def test_plugins_are_listed_after_the_registered_and_never_shadow_them(monkeypatch):
    plugins = [EntryPoint(name, "fractions:Fraction", "test.things") for name in ("one", "frac")]
    monkeypatch.setattr(azgym.registry, "entry_points",
                        lambda *, group: plugins if group == "test.things" else [])
    checked = []

    def check(name, loaded):
        checked.append(name)
        return loaded

    things = Registry("thing", {"one": 1}, group="test.things", check=check)
    assert things.names() == ["one", "frac"] and things.names(plugins=False) == ["one"]
    assert "frac" in things and things["one"] == 1
    assert things.make("frac", numerator=1, denominator=2) == 0.5
    assert checked == ["frac"]  # a plug-in's loaded object passes the check, an entry does not
    with pytest.raises(UnknownNameError, match=re.escape("Did you mean 'frac'?")):
        things["fracc"]
    assert Registry("thing", {"one": 1}).names() == ["one"]  # no group: no plug-ins


def test_every_registry_of_azgym_has_the_one_shape():
    from azgym.bench.navigation.suites import NAVIGATION_SUITES
    from azgym.bench.run.backends import BACKENDS
    from azgym.bench.suites import SUITES
    from azgym.localize.registry import LOCALIZERS, TRACKERS
    from azgym.sensing.catalog import SENSORS

    for registry in (LOCALIZERS, TRACKERS, SENSORS, SUITES, NAVIGATION_SUITES, BACKENDS):
        assert isinstance(registry, Registry)
    assert list(BACKENDS) == ["local", "ray"] and list(SENSORS) == ["geometry", "image"]


def test_no_registry_imports_what_it_registers():
    code = ("import sys\n"
            "import azgym.localize.registry, azgym.sensing.catalog, azgym.bench.run.backends\n"
            "print(sorted(m for m in ('azgym.localize.ransac', 'azgym.localize.learned', "
            "'azgym.track.inertial_kalman', 'azgym.track.gated_ekf', "
            "'azgym.sensing.geometry.sensor', 'azgym.sensing.image.sensor', "
            "'azgym.bench.run.isolation', 'ray') "
            "if m in sys.modules))")
    loaded = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                            check=True).stdout.strip()
    assert loaded == "[]"
