"""Register an environment id for every shipped scenario (``azgym.ENV_IDS``), when it is needed.

Each scenario file in ``envs/`` gives ``azgym/Localize-<Scenario>-v1`` and, when it has routes
(whose waypoints are the pick and drop spots), ``azgym/Navigate-<Scenario>-v2`` and
``azgym/NavigateDiscrete-<Scenario>-v2`` (each task's version is in :data:`VERSIONS`); Navigate
drives a forklift, so a scenario whose routes a differential-drive robot drives has no Navigate id.
``gym.make(id, scenario="path/to/my.toml")`` runs an id's environment on a user's file instead.

Registering needs Gymnasium and reads the scenario files, so it is not done when azgym is
imported: it is done as soon as Gymnasium is imported (whether before or after azgym), or when
``azgym.ENV_IDS`` is first read. Gymnasium 1.x has no plug-in entry point to do it with.
"""

from __future__ import annotations

import functools
import importlib.abc
import importlib.machinery
import sys
from collections.abc import Sequence
from types import ModuleType
from typing import TYPE_CHECKING, Any

from azgym.errors import InvalidInputError, unknown_name

if TYPE_CHECKING:
    from gymnasium.envs.registration import EnvSpec

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
        entries = [("Localize", "azgym.envs.localize:LocalizeEnv", {})]
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


class _AfterGymnasiumImport(importlib.abc.MetaPathFinder):
    """Registers the ids right after Gymnasium's module has run (a post-import hook).

    It hands out Gymnasium's spec with a loader that registers after running the module, every
    time the spec is looked up (a look-up alone, ``importlib.util.find_spec("gymnasium")`` as
    libraries probe optional dependencies, imports nothing), and leaves ``sys.meta_path`` once
    Gymnasium has really been imported.
    """

    def find_spec(self, fullname: str, path: Sequence[str] | None,
                  target: ModuleType | None = None) -> Any:
        if fullname != "gymnasium":
            return None
        spec = importlib.machinery.PathFinder.find_spec(fullname, path)
        if spec is None or spec.loader is None:
            return spec
        run = spec.loader.exec_module

        def exec_then_register(module: ModuleType) -> None:
            run(module)
            if self in sys.meta_path:
                sys.meta_path.remove(self)
            register_environments()

        spec.loader.exec_module = exec_then_register  # type: ignore[method-assign]
        return spec


def register_when_gymnasium_loads() -> None:
    """Register the ids now if Gymnasium is loaded, else as soon as it is imported."""
    if "gymnasium" in sys.modules:
        register_environments()
    elif not any(isinstance(finder, _AfterGymnasiumImport) for finder in sys.meta_path):
        sys.meta_path.insert(0, _AfterGymnasiumImport())


def __getattr__(name: str) -> Any:
    """``ENV_IDS``: every registered id (registering them first)."""
    if name == "ENV_IDS":
        return list(register_environments())
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
    if isinstance(entry, str):
        if not entry.startswith("azgym."):  # loading another package's entry point runs it
            return False
        entry = gym.envs.registration.load_env_creator(entry)
    return isinstance(entry, type) and issubclass(entry, NavigateEnv)
