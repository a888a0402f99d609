"""azgym: a Gymnasium benchmark for robust azimuth-based indoor positioning.

The public API in one place::

    import azgym
    scenario = azgym.load_scenario("paper-room")
    localizer = azgym.make_localizer("ransac")
    estimate = localizer.localize(measurements, scenario.beacons)
"""

from azgym.core import BeaconMap, Estimate, Measurements, wrap_angle
from azgym.envs.evaluate import evaluate
from azgym.envs.registration import ENV_IDS
from azgym.errors import (
    AzgymError,
    DependencyNotInstalled,
    InvalidInputError,
    ScenarioError,
    UnknownNameError,
)
from azgym.localize.base import Localizer
from azgym.localize.checks import LocalizerCheckError, check_localizer
from azgym.localize.registry import (
    list_localizers,
    make_localizer,
    register_localizer,
)
from azgym.scenario import Scenario, list_scenarios, load_scenario
from azgym.sensing.error_model import ErrorModel

__version__ = "0.1.0"

__all__ = [
    "ENV_IDS",
    "AzgymError",
    "BeaconMap",
    "DependencyNotInstalled",
    "ErrorModel",
    "Estimate",
    "InvalidInputError",
    "Localizer",
    "LocalizerCheckError",
    "Measurements",
    "Scenario",
    "ScenarioError",
    "UnknownNameError",
    "__version__",
    "check_localizer",
    "evaluate",
    "list_localizers",
    "list_scenarios",
    "load_scenario",
    "make_localizer",
    "register_localizer",
    "wrap_angle",
]
