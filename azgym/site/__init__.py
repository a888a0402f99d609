"""The site: the scenario model, its validated TOML files, generated sites, poses on its floor."""

from azgym.site.generator import generate
from azgym.site.load import list_scenarios, load_scenario
from azgym.site.parse import parse_scenario
from azgym.site.scenario import Scenario

__all__ = ["Scenario", "generate", "list_scenarios", "load_scenario", "parse_scenario"]
