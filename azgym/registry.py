"""Things by name: the one shape of azgym's registries (localizers, sensors, suites, backends).

A :class:`Registry` maps names to things: an object, or a ``"module:attribute"`` reference that
is imported only when the thing is first asked for, so that a registry costs nothing to import
and its entries' modules (and their libraries) load only when used. A registry with an
entry-point group also lists, under their own names, the things that installed packages declare
in that group::

    [project.entry-points."azgym.localizers"]
    mylocalizer = "mypackage.module:MyLocalizer"

A registered entry always wins over a plug-in of the same name. An unknown name is refused
with the valid ones and the closest (:func:`azgym.errors.unknown_name`).

Example:
    >>> from azgym.registry import Registry
    >>> numbers = Registry("number")
    >>> numbers.register("fraction", "fractions:Fraction")
    >>> "fraction" in numbers, numbers.names()  # fractions is not imported yet
    (True, ['fraction'])
    >>> numbers.make("fraction", numerator=1, denominator=3)
    Fraction(1, 3)
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Iterator, Mapping
from importlib.metadata import EntryPoint, entry_points
from typing import Any, TypeVar, cast

from azgym.errors import InvalidInputError, UnknownNameError, unknown_name

__all__ = ["Registry", "load_reference"]

T = TypeVar("T")
R = TypeVar("R")


def load_reference(reference: str) -> Any:
    """The object a ``"module:attribute"`` reference names (the attribute may be dotted).

    Raises:
        InvalidInputError: The reference has no ``module:attribute`` form.
        ImportError: The module cannot be imported.
        AttributeError: The module has no such attribute.
    """
    module, colon, attribute = reference.partition(":")
    if not (module and colon and attribute):
        raise InvalidInputError(f"a reference is written 'module:attribute', got {reference!r}")
    value: Any = importlib.import_module(module)
    for part in attribute.split("."):
        value = getattr(value, part)
    return value


class Registry(Mapping[str, T]):
    """Names to things of one kind, registered here or declared by installed packages.

    It reads as a mapping (``name in registry``, ``registry[name]``, iteration in the order of
    registration, then the plug-ins'), and ``registry.get(name)`` is None for an unknown name,
    as a dict's. Looking a name up imports a referenced entry; listing names never does.

    Args:
        kind: What is registered, as errors name it (``"localizer"``, ``"suite"``).
        entries: The first entries, name to thing or reference (as :meth:`register` takes).
        group: The entry-point group whose plug-ins the registry lists too (None: none).
        check: Called with a plug-in's name and the object its entry point loads; returns it
            as a thing of this registry or raises (a plug-in is anyone's code). None: taken as
            it is.
    """

    def __init__(self, kind: str, entries: Mapping[str, T | str] | None = None, *,
                 group: str | None = None, check: Callable[[str, Any], T] | None = None) -> None:
        self.kind = kind
        self.group = group
        self._check = check
        self._entries: dict[str, T | str] = {}
        for name, target in (entries or {}).items():
            self.register(name, target)

    def register(self, name: str, target: T | str) -> None:
        """Register ``target`` under ``name``: the thing itself, or a ``"module:attribute"``.

        A string is always a reference, imported when the entry is first looked up.

        Args:
            name: The entry's name.
            target: The thing, or where to import it from.

        Raises:
            InvalidInputError: The name is not a non-empty string, or it is already taken.
        """
        if not isinstance(name, str) or not name:
            raise InvalidInputError(f"{self.kind} name must be a non-empty string, got {name!r}")
        if name in self._entries:
            raise InvalidInputError(f"a {self.kind} named {name!r} is already registered")
        self._entries[name] = target

    def names(self, plugins: bool = True) -> list[str]:
        """Every name, registered ones first (in order), then the plug-ins' (without loading)."""
        names = list(self._entries)
        if plugins:
            names += [name for name in self._plugins() if name not in self._entries]
        return names

    def make(self: Registry[Callable[..., R]], name: str, /, **params: Any) -> R:
        """Call the thing of that name with ``params`` (a factory's keyword arguments).

        Raises:
            UnknownNameError: No such name ("Did you mean ...?").
        """
        return self[name](**params)

    def check_name(self, name: object) -> None:
        """Refuse a name the registry does not have, without loading anything.

        Raises:
            UnknownNameError: No such name ("Did you mean ...?").
        """
        if name not in self:
            raise self._unknown(name)

    def __getitem__(self, name: str) -> T:
        if isinstance(name, str) and name in self._entries:
            target = self._entries[name]
            return cast(T, load_reference(target) if isinstance(target, str) else target)
        plugin = self._plugins().get(name) if isinstance(name, str) else None
        if plugin is None:
            raise self._unknown(name)
        loaded = plugin.load()
        return self._check(name, loaded) if self._check is not None else cast(T, loaded)

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and (name in self._entries or name in self._plugins())

    def __iter__(self) -> Iterator[str]:
        return iter(self.names())

    def __len__(self) -> int:
        return len(self.names())

    def __repr__(self) -> str:
        return f"Registry({self.kind!r}, names={self.names()!r})"

    def _unknown(self, name: object) -> UnknownNameError:
        return unknown_name(self.kind, str(name), self.names())

    def _plugins(self) -> dict[str, EntryPoint]:
        """The group's entry points by name, read afresh (a package installed since counts)."""
        if self.group is None:
            return {}
        return {plugin.name: plugin for plugin in entry_points(group=self.group)}
