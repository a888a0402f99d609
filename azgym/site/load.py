"""Scenario files: the shipped ones found by name (``envs/*.toml``), a user's by path.

Nothing is read at import: a file is read and validated when it is loaded. A user's file may be
hostile, so before its fields are checked (:mod:`azgym.site.parse`) it must be at most
:data:`MAX_FILE_BYTES` long (only that much is read), UTF-8 text, and TOML nested shallowly
enough to parse.
"""

from __future__ import annotations

import tomllib
from importlib import resources
from pathlib import Path
from typing import Any

from azgym.errors import ScenarioError, unknown_name
from azgym.site.parse import parse_scenario
from azgym.site.scenario import Scenario

__all__ = ["MAX_FILE_BYTES", "SCENARIO_PACKAGE", "list_scenarios", "load_scenario"]

SCENARIO_PACKAGE = "azgym.site.scenarios"
"""The package the shipped scenario files are installed as (the repository's ``envs/``)."""
MAX_FILE_BYTES = 4 * 1024 * 1024
"""The largest scenario file read [bytes]: a site of tens of thousands of beacons fits."""


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
        with path.open("rb") as file:
            raw, origin = file.read(MAX_FILE_BYTES + 1), str(path)
    else:
        shipped = _shipped()
        if str(scenario) not in shipped:
            raise unknown_name("scenario", str(scenario), shipped)
        raw, origin = shipped[str(scenario)].read_bytes(), f"{scenario}.toml"
    parsed = parse_scenario(_toml(raw, origin), origin)
    return Scenario(**{**parsed.__dict__, "source": path if path.is_file() else None})


def _toml(raw: bytes, origin: str) -> dict[str, Any]:
    """A file's bytes as TOML data: at most ``MAX_FILE_BYTES``, UTF-8, not nested too deeply."""
    if len(raw) > MAX_FILE_BYTES:
        raise ScenarioError(f"{origin}: too large: a scenario file has at most {MAX_FILE_BYTES} "
                            "bytes")
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ScenarioError(f"{origin}: not UTF-8 text: byte 0x{raw[exc.start]:02x} at offset "
                            f"{exc.start}") from None
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ScenarioError(f"{origin}: not valid TOML: {exc}") from None
    except RecursionError:  # tomllib recurses once per nested array or inline table
        raise ScenarioError(f"{origin}: not valid TOML: arrays or tables nested too deeply") \
            from None
