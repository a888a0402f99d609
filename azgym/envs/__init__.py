"""Gymnasium environments: localization and navigation, an id for every shipped scenario.

Importing this package registers the ids with Gymnasium (:mod:`azgym.envs.registration`)::

    import gymnasium as gym
    import azgym.envs

    env = gym.make("azgym/Localize-WarehouseSmall-v1")
"""

from azgym.envs.registration import register_environments

__all__ = ["ENV_IDS"]

ENV_IDS: list[str] = list(register_environments())
"""Every environment id, registered with Gymnasium when this package was imported."""
