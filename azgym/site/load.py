"""Scenario files: the shipped ones found by name (``envs/*.toml``), a user's by path.

Nothing is read at import: a file is read and validated when it is loaded.
"""

from __future__ import annotations

import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

from azgym.errors import ScenarioError, unknown_name
from azgym.site.parse import parse_scenario
from azgym.site.scenario import Scenario

SCENARIO_PACKAGE = "azgym.site.scenarios"
"""The package the shipped scenario files are installed as (the repository's ``envs/``)."""


def _shipped() -> dict[str, Any]:
    """Name → resource of every scenario file shipped with azgym."""
    folder = resources.files(SCENARIO_PACKAGE)
    return {entry.name[:-5]: entry for entry in folder.iterdir() if entry.name.endswith(".toml")}


def list_scenarios() -> list[str]:
    """Names of the shipped scenarios."""
    return sorted(_shipped())


def load_scenario(scenario: str | Path | Scenario) -> Scenario:
    """Load a shipped scenario by name, or a user's TOML file by path.

    Raises:
        UnknownNameError: No shipped scenario of that name ("Did you mean ...?").
        ScenarioError: The file is malformed.
    """
    if isinstance(scenario, Scenario):
        return scenario
    path = Path(scenario)
    if path.suffix == ".toml" or path.exists():
        if not path.is_file():
            raise ScenarioError(f"{path}: no such scenario file")
        text, origin = path.read_text(encoding="utf-8"), str(path)
    else:
        shipped = _shipped()
        if str(scenario) not in shipped:
            raise unknown_name("scenario", str(scenario), shipped)
        entry = shipped[str(scenario)]
        text, origin = entry.read_text(encoding="utf-8"), f"{scenario}.toml"
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{origin}: not valid TOML: {exc}") from None
    parsed = parse_scenario(data, origin)
    return Scenario(**{**parsed.__dict__, "source": path if path.is_file() else None})
