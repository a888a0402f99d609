"""azgym: a Gymnasium benchmark for robust azimuth-based indoor positioning.

The public API in one place::

    import azgym
    scenario = azgym.load_scenario("paper-room")
    localizer = azgym.make_localizer("ransac")
    estimate = localizer.localize(measurements, scenario.beacons)

Importing azgym does no work and loads no heavy library: each name below is imported when it is
first used (PEP 562). The Gymnasium environment ids are registered by ``import azgym.envs`` (or
by reading ``azgym.ENV_IDS``), and by ``import azgym`` itself when Gymnasium is already imported
(see :mod:`azgym.envs.registration`).
"""

from __future__ import annotations

import importlib
import sys
from typing import TYPE_CHECKING, Any

from azgym._version import __version__
from azgym.core import BeaconMap, Estimate, Measurements, pose_error, wrap_angle
from azgym.errors import (
    AzgymError,
    DependencyNotInstalled,
    InvalidInputError,
    ScenarioError,
    UnknownNameError,
)

_LAZY = {
    "Contender": "azgym.bench.run.contenders",
    "ENV_IDS": "azgym.envs",
    "ErrorModel": "azgym.site.error_model",
    "FrameByFrame": "azgym.track.base",
    "Localizer": "azgym.localize.base",
    "LocalizerCheckError": "azgym.localize.checks",
    "MapAnswer": "azgym.mapping.base",
    "Mapper": "azgym.mapping.base",
    "MapperCheckError": "azgym.mapping.checks",
    "Motion": "azgym.sensing.motion",
    "Scenario": "azgym.site.scenario",
    "Tracker": "azgym.track.base",
    "check_localizer": "azgym.localize.checks",
    "check_mapper": "azgym.mapping.checks",
    "check_tracker": "azgym.track.checks",
    "evaluate": "azgym.envs.evaluate",
    "get_suite": "azgym.bench.suites",
    "list_localizers": "azgym.localize.registry",
    "list_mappers": "azgym.mapping.registry",
    "list_trackers": "azgym.localize.registry",
    "list_scenarios": "azgym.site.load",
    "load_scenario": "azgym.site.load",
    "make_localizer": "azgym.localize.registry",
    "make_mapper": "azgym.mapping.registry",
    "make_tracker": "azgym.track.base",
    "register_localizer": "azgym.localize.registry",
    "run_benchmark": "azgym.bench.run.runner",
}

if TYPE_CHECKING:
    from azgym.bench.run.contenders import Contender
    from azgym.bench.run.runner import run_benchmark
    from azgym.bench.suites import get_suite
    from azgym.envs import ENV_IDS
    from azgym.envs.evaluate import evaluate
    from azgym.localize.base import Localizer
    from azgym.localize.checks import LocalizerCheckError, check_localizer
    from azgym.localize.registry import (
        list_localizers,
        list_trackers,
        make_localizer,
        register_localizer,
    )
    from azgym.mapping.base import MapAnswer, Mapper
    from azgym.mapping.checks import MapperCheckError, check_mapper
    from azgym.mapping.registry import list_mappers, make_mapper
    from azgym.sensing.motion import Motion
    from azgym.site.error_model import ErrorModel
    from azgym.site.load import list_scenarios, load_scenario
    from azgym.site.scenario import Scenario
    from azgym.track.base import FrameByFrame, Tracker, make_tracker
    from azgym.track.checks import check_tracker


def __getattr__(name: str) -> Any:
    """Import a public name's module when the name is first used."""
    if name not in _LAZY:
        raise AttributeError(f"module 'azgym' has no attribute {name!r}")
    value = getattr(importlib.import_module(_LAZY[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


if "gymnasium" in sys.modules:  # `import gymnasium as gym, azgym`: the ids are wanted now
    importlib.import_module("azgym.envs")

__all__ = [
    "ENV_IDS",
    "AzgymError",
    "BeaconMap",
    "Contender",
    "DependencyNotInstalled",
    "ErrorModel",
    "Estimate",
    "FrameByFrame",
    "InvalidInputError",
    "Localizer",
    "LocalizerCheckError",
    "MapAnswer",
    "Mapper",
    "MapperCheckError",
    "Measurements",
    "Motion",
    "Scenario",
    "ScenarioError",
    "Tracker",
    "UnknownNameError",
    "__version__",
    "check_localizer",
    "check_mapper",
    "check_tracker",
    "evaluate",
    "get_suite",
    "list_localizers",
    "list_mappers",
    "list_trackers",
    "list_scenarios",
    "load_scenario",
    "make_localizer",
    "make_mapper",
    "make_tracker",
    "pose_error",
    "register_localizer",
    "run_benchmark",
    "wrap_angle",
]
