"""The optimized layout as a scenario file: the source file's data, the new beacons appended.

The scenario's own TOML data is read again (from its file, or from the shipped ``envs/``), the
new beacons are appended as ``[[beacons]]`` tables with fresh ids (:func:`fresh_ids`), the
name becomes the new file's stem (:func:`file_stem`), and the data is written through the
scenario writer (:mod:`azgym.site.toml_writer`) after the parser has accepted it, then loaded
back and compared: the file written is a valid scenario holding exactly that data. Comments of
the source file are not carried over (TOML readers drop them); the writer's header says where
the file came from.
"""

from __future__ import annotations

import re
import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

from azgym.core import FloatArray, IntArray
from azgym.errors import ScenarioError
from azgym.files import write_file
from azgym.site import Scenario, load_scenario, parse_scenario
from azgym.site.load import SCENARIO_PACKAGE
from azgym.site.reader import MAX_INTEGER, MAX_NAME, NAME_CHARACTERS
from azgym.site.toml_writer import to_toml

__all__ = ["PLACEMENT_FIGURE", "file_stem", "fresh_ids", "placed_name", "placement_files",
           "source_data", "with_new_beacons", "write_scenario"]

PLACEMENT_FIGURE = "layout-optimized.png"
"""The figure ``azgym layout optimize`` draws beside the new scenario file."""


def source_data(scenario: Scenario) -> dict[str, Any]:
    """The TOML data the scenario was loaded from (its file, or the shipped one of its name).

    Raises:
        ScenarioError: The scenario was not loaded from a file (built in memory).
    """
    if scenario.source is not None:
        raw = Path(scenario.source).read_bytes()
    else:
        shipped = resources.files(SCENARIO_PACKAGE) / f"{scenario.name}.toml"
        if not shipped.is_file():
            raise ScenarioError(f"{scenario.name}: not loaded from a scenario file, so there is "
                                "no file to add beacons to")
        raw = shipped.read_bytes()
    return tomllib.loads(raw.decode("utf-8"))


def file_stem(name: str) -> str:
    """``name`` as a file name's stem: only letters, digits, ``-``, ``_`` and ``.``, not first.

    The parser admits no other name (:func:`azgym.site.reader.name_problem`); this keeps a
    scenario built in memory from naming a file outside the output folder too.
    """
    return re.sub(rf"[^{NAME_CHARACTERS}]", "_", name).lstrip("._-")[:MAX_NAME] or "scenario"


def placed_name(name: str, placed: int | str) -> str:
    """The name of scenario ``name`` with ``placed`` beacons added: ``NAME-plus-N``.

    It is also the new file's stem (``NAME-plus-N.toml``).
    """
    return f"{file_stem(name)}-plus-{placed}"


def placement_files(name: str) -> tuple[str, str]:
    """What ``azgym layout optimize`` writes for scenario ``name``, as glob patterns.

    The new scenario file, however many beacons it was given, and :data:`PLACEMENT_FIGURE`:
    what the command claims in ``--out``. A file stem holds no glob character, so the
    pattern's stem matches only itself.
    """
    return f"{placed_name(name, '*')}.toml", PLACEMENT_FIGURE


def fresh_ids(ids: IntArray, count: int) -> list[int]:
    """``count`` beacon ids not in ``ids``.

    Those after the largest in use, or, when they would pass the largest id a file may give
    (2**31 - 1), the smallest free ones from 1 (a map has at most 10 000 beacons, so there are
    always enough).
    """
    top = int(max(ids, default=0))
    if top + count <= MAX_INTEGER:
        return list(range(top + 1, top + 1 + count))
    taken = {int(i) for i in ids}
    return [k for k in range(1, count + len(taken) + 1) if k not in taken][:count]


def with_new_beacons(scenario: Scenario, xyz: FloatArray, width: float,
                     name: str) -> dict[str, Any]:
    """The scenario's data with beacons at ``xyz`` (:func:`fresh_ids`) added, named ``name``.

    Raises:
        ScenarioError: The result is not a valid scenario (the parser's message).
    """
    data = source_data(scenario)
    added = [{"id": beacon, "xyz": [float(v) for v in place], "width": float(width)}
             for beacon, place in zip(fresh_ids(scenario.beacons.ids, len(xyz)), xyz,
                                      strict=True)]
    data["name"] = name
    data["description"] = (f"{data['description']}; {len(added)} beacons added by azgym layout "
                           "optimize")
    data["beacons"] = [*data["beacons"], *added]
    parse_scenario(data, f"{name} (optimized layout)")
    return data


def write_scenario(path: Path, data: dict[str, Any], comment: str) -> Scenario:
    """Write ``data`` to ``path`` (a ``.toml`` file) and load it back.

    Raises:
        ScenarioError: The file does not read back as ``data`` (a bug in the writer).
    """
    write_file(path, to_toml(data, comment))
    loaded = load_scenario(path)
    with path.open("rb") as stream:
        if tomllib.load(stream) != data:
            raise ScenarioError(f"{path}: the file written does not read back as the layout's "
                                "data")
    return loaded
