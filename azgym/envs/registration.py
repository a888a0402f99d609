"""Register an environment id for every shipped scenario (``azgym.ENV_IDS``).

Each scenario file in ``envs/`` gives ``azgym/Localize-<Scenario>-v0`` and, when it has routes
(whose waypoints are the pick and drop spots), ``azgym/Navigate-<Scenario>-v0`` and
``azgym/NavigateDiscrete-<Scenario>-v0``. ``gym.make(id, scenario="path/to/my.toml")`` runs an
id's environment on a user's file instead.
"""

from __future__ import annotations

import gymnasium as gym

from azgym.scenario import list_scenarios, load_scenario

NAMESPACE = "azgym"


def camel_case(name: str) -> str:
    """'warehouse-small' → 'WarehouseSmall'."""
    return "".join(part.capitalize() for part in name.replace("_", "-").split("-"))


def register_environments() -> list[str]:
    """Register every environment id (once) and return the ids."""
    ids = []
    for name in list_scenarios():
        scenario = load_scenario(name)
        entries = [("Localize", "azgym.envs.localize:LocalizeEnv", {})]
        if scenario.routes:
            entries += [("Navigate", "azgym.envs.navigate:NavigateEnv", {}),
                        ("NavigateDiscrete", "azgym.envs.navigate:NavigateEnv",
                         {"discrete": True})]
        for task, entry_point, extra in entries:
            env_id = f"{NAMESPACE}/{task}-{camel_case(name)}-v0"
            if env_id not in gym.registry:
                gym.register(id=env_id, entry_point=entry_point,
                             kwargs={"scenario": name, **extra},
                             max_episode_steps=None)
            ids.append(env_id)
    return ids


ENV_IDS = register_environments()
