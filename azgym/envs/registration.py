"""Register an environment id for every shipped scenario (``azgym.ENV_IDS``).

Each scenario file in ``envs/`` gives ``azgym/Localize-<Scenario>-v1`` and, when it has routes
(whose waypoints are the pick and drop spots), ``azgym/Navigate-<Scenario>-v2`` and
``azgym/NavigateDiscrete-<Scenario>-v2`` (each task's version is in :data:`VERSIONS`); Navigate
drives a forklift, so a scenario whose routes a differential-drive robot drives has no Navigate id.
``gym.make(id, scenario="path/to/my.toml")`` runs an id's environment on a user's file instead.

Registering needs Gymnasium and reads the scenario files, so ``import azgym`` alone does not do
it: importing :mod:`azgym.envs` does (as does reading ``azgym.ENV_IDS``, or ``import azgym`` once
Gymnasium is imported). Gymnasium 1.x has no plug-in entry point to do it with; its own
``"module:id"`` form imports the package first:
``gym.make("azgym.envs:azgym/Localize-WarehouseSmall-v1")``.
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING, Any

from azgym.errors import InvalidInputError, unknown_name

if TYPE_CHECKING:
    from gymnasium.envs.registration import EnvSpec

__all__ = ["NAMESPACE", "VERSIONS", "camel_case", "navigation_spec", "register_environments"]

NAMESPACE = "azgym"
VERSIONS = {"Localize": 1, "Navigate": 2, "NavigateDiscrete": 2}
"""The version of each task's ids; bumped whenever its episodes or interface change."""


def camel_case(name: str) -> str:
    """'warehouse-small' → 'WarehouseSmall'."""
    return "".join(part.capitalize() for part in name.replace("_", "-").split("-"))


@functools.cache
def register_environments() -> tuple[str, ...]:
    """Register every environment id (once) and return the ids."""
    import gymnasium as gym

    from azgym.site import list_scenarios, load_scenario

    ids = []
    for name in list_scenarios():
        entries: list[tuple[str, str, dict[str, Any]]] = [
            ("Localize", "azgym.envs.localize:LocalizeEnv", {})]
        scenario = load_scenario(name)
        if scenario.routes and not scenario.differential_drive:  # Navigate drives a forklift
            entries += [("Navigate", "azgym.envs.navigate:NavigateEnv", {}),
                        ("NavigateDiscrete", "azgym.envs.navigate:NavigateEnv",
                         {"discrete": True})]
        for task, entry_point, extra in entries:
            env_id = f"{NAMESPACE}/{task}-{camel_case(name)}-v{VERSIONS[task]}"
            if env_id not in gym.registry:
                gym.register(id=env_id, entry_point=entry_point,
                             kwargs={"scenario": name, **extra}, max_episode_steps=None)
            ids.append(env_id)
    return tuple(ids)


def navigation_spec(env_id: str) -> EnvSpec:
    """The registered spec of a Navigate id; refuses unknown ids and other environments."""
    import gymnasium as gym

    from azgym.envs.navigate import NavigateEnv

    if env_id not in gym.registry:
        navigate = [name for name in gym.registry if _is_navigation(gym.registry[name])]
        raise unknown_name("navigation environment", env_id, navigate)
    spec = gym.registry[env_id]
    if not _is_navigation(spec):
        raise InvalidInputError(
            f"env {env_id!r} has no planner's map: it is not a navigation environment (a "
            f"{NavigateEnv.__name__} id: azgym/Navigate-... or azgym/NavigateDiscrete-...)")
    return spec


def _is_navigation(spec: EnvSpec) -> bool:
    """Whether an id's environment is a :class:`~azgym.envs.navigate.NavigateEnv`.

    An entry point of another package is never loaded to find out: loading it runs its code.
    """
    import gymnasium as gym

    from azgym.envs.navigate import NavigateEnv

    entry = spec.entry_point
    if not isinstance(entry, str):
        return isinstance(entry, type) and issubclass(entry, NavigateEnv)
    if not entry.startswith("azgym."):  # loading another package's entry point runs it
        return False
    creator = gym.envs.registration.load_env_creator(entry)
    return isinstance(creator, type) and issubclass(creator, NavigateEnv)
