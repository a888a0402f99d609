"""Names → mapper factories: the built-ins, ``azgym.mappers`` entry points, and specs.

A mapper is named by a spec, as a localizer is (:mod:`azgym.localize.registry`: the same grammar,
the same plug-in loading): a built-in's name (``survey``, ``rays``, ``prior``, ``repair``), an
importable ``package.module:Class`` or a file ``path/to/file.py:Class``, optionally followed by
hyperparameters, ``survey:loss=huber``, ``path/mine.py:Mine:steps=3``. A plug-in must be a class
with a ``survey`` method (:class:`~azgym.mapping.base.SupportsSurvey`): anything else a spec
names is refused before it is called. Third-party packages register a name by declaring, in
their pyproject.toml::

    [project.entry-points."azgym.mappers"]
    mymapper = "mypackage.module:MyMapper"

A profile's fields (:mod:`azgym.profile`) become the hyperparameters of the same names a
mapper's class takes, as a localizer's do, a hyperparameter the spec writes winning
(:func:`~azgym.localize.registry.profile_params`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from azgym.errors import InvalidInputError
from azgym.localize.registry import profile_params
from azgym.mapping.base import SupportsSurvey
from azgym.profile import Profile
from azgym.registry import Registry, construct, load_attribute, split_spec

__all__ = ["DEFAULT_MAPPERS", "ENTRY_POINT_GROUP", "MAPPERS", "is_mapper_class",
           "is_mapper_spec", "list_mappers", "make_mapper"]

ENTRY_POINT_GROUP = "azgym.mappers"
KIND = "mapper"
"""What the registry's errors call the things it holds."""


def is_mapper_class(candidate: object) -> bool:
    """Whether an object is a mapper class (a class with a ``survey`` method): the one test."""
    return isinstance(candidate, type) and callable(getattr(candidate, "survey", None))


def _mapper_class(spec: str, factory: Any) -> Callable[..., SupportsSurvey]:
    """The factory a spec names, if it is a mapper class.

    A spec comes from a command line or a results file, which anyone can write: refusing
    anything but a class with a ``survey`` method before calling it means that ``"os:system"``
    with hyperparameters can never run a command.
    """
    if not is_mapper_class(factory):
        raise InvalidInputError(
            f"mapper spec {spec!r} names a {type(factory).__name__}, not a mapper class (a class "
            "with a survey(drive, prior) method)")
    return factory


MAPPERS: Registry[Callable[..., SupportsSurvey]] = Registry(KIND, {
    "survey": "azgym.mapping.mappers:SurveyMapper",
    "rays": "azgym.mapping.mappers:RaysMapper",
    "prior": "azgym.mapping.mappers:PriorMapper",
    "repair": "azgym.mapping.mappers:RepairMapper",
}, group=ENTRY_POINT_GROUP, check=_mapper_class)
"""Mappers by name: the built-ins and the plug-ins of :data:`ENTRY_POINT_GROUP`."""
DEFAULT_MAPPERS = ("survey", "rays", "repair", "prior")
"""The mappers a mapping benchmark scores unless told which: every built-in."""


def list_mappers() -> list[str]:
    """Every mapper name: the built-ins and the entry points' (none loaded)."""
    return sorted(MAPPERS)


def make_mapper(spec: str, profile: Profile | None = None) -> SupportsSurvey:
    """Build a mapper from a name or spec; a profile's fields as its defaults.

    Example:
        >>> from azgym.mapping import make_mapper
        >>> make_mapper("survey:loss=huber").get_params()["loss"]
        'huber'

    Args:
        spec: The mapper's spec (module docstring).
        profile: A profile whose fields set the hyperparameters of the same names the mapper's
            class takes, where the spec writes none (None: none).

    Raises:
        UnknownNameError: No such mapper ("Did you mean ...?").
        InvalidInputError: A spec that cannot be read or imported, a plug-in that is not a
            mapper class, a hyperparameter it does not take (naming the closest one it does)
            or a value it refuses.
    """
    target, params = split_spec(spec, KIND)
    factory = MAPPERS.resolve(target)
    mapper = construct(KIND, target, factory, {**profile_params(factory, params, profile),
                                               **params})
    if not isinstance(mapper, SupportsSurvey):
        raise InvalidInputError(f"mapper {target!r} built a {type(mapper).__name__}, which has "
                                "no survey(drive, prior) method")
    return mapper


def is_mapper_spec(spec: str) -> bool:
    """Whether a spec names a mapper rather than a localizer or tracker (``azgym check``).

    A name registered here, or a plug-in class with a ``survey`` method (its module is imported
    to see, its class never called).

    Raises:
        InvalidInputError: A spec that cannot be read, or a plug-in that cannot be loaded.
    """
    target, _ = split_spec(spec, KIND)
    if target in MAPPERS or ":" not in target:
        return target in MAPPERS
    return is_mapper_class(load_attribute(target, "plug-in"))
