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

A registry of factories (localizers, trackers, mappers) also reads **specs**: a registered name
or a plug-in (``package.module:Class``, ``path/to/file.py:Class``), optionally followed by
hyperparameters, ``TARGET[:NAME=VALUE[,NAME=VALUE...]]`` (:func:`split_spec`; the grammar is
told in :mod:`azgym.localize.registry`). :meth:`Registry.resolve` finds a target's factory,
loading a plug-in's file or module (:func:`load_attribute`) and checking what it loads before
anything calls it; :func:`construct` calls it with hyperparameters whose names it takes
(:func:`hyperparameter_names`), a misspelt one refused with the closest.

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

import hashlib
import importlib
import importlib.util
import inspect
import json
import re
import sys
from collections.abc import Callable, Collection, Iterator, Mapping
from importlib.metadata import EntryPoint, entry_points
from pathlib import Path
from typing import Any, TypeVar, cast

from azgym.errors import InvalidInputError, UnknownNameError, unknown_name

__all__ = ["Registry", "check_param_names", "construct", "hyperparameter_names",
           "load_attribute", "load_reference", "split_spec"]

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

    def resolve(self, target: str) -> T:
        """The thing a spec's target names: registered, a plug-in file or module, an entry point.

        A registered name comes before a plug-in's of the same name.

        Raises:
            UnknownNameError: No such name ("Did you mean ...?").
            InvalidInputError: A plug-in that cannot be loaded, or is not a thing of this kind.
        """
        if not isinstance(target, str) or target in self.names(plugins=False) \
                or ":" not in target:
            return self[target]
        return self.load(target, self.names())

    def load(self, spec: str, taken: Collection[str]) -> T:
        """The plug-in a ``module:Class`` or ``path/to/file.py:Class`` target names, checked.

        Args:
            spec: The target.
            taken: The registered names: one of them before a colon is a name whose
                hyperparameters were miswritten, refused as such.

        Raises:
            InvalidInputError: A registered name with a colon, a plug-in that cannot be loaded,
                or (the registry's ``check``) is not a thing of this kind.
        """
        registered = spec.partition(":")[0]
        if registered in taken:
            raise InvalidInputError(
                f"{self.kind} spec {spec!r}: {registered!r} is a registered name; its "
                f"hyperparameters are written {registered}:NAME=VALUE[,NAME=VALUE...]")
        loaded = load_attribute(spec, self.kind)
        return self._check(spec, loaded) if self._check is not None else cast(T, loaded)

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


def load_attribute(spec: str, kind: str) -> Any:
    """What ``"module:attribute"`` or ``"path/to/file.py:attribute"`` names, unchecked.

    A file is imported once per process under a name made of its resolved path (stable across
    processes, so that a worker process finds the same module).

    Args:
        spec: The target.
        kind: What it should be, as errors name it (``"localizer"``).

    Raises:
        InvalidInputError: No such file, a module that cannot be imported, no such attribute.
    """
    target, _, attribute = spec.rpartition(":")
    if target.endswith(".py"):
        path = Path(target).expanduser().resolve()
        if not path.is_file():
            raise InvalidInputError(f"{kind} spec {spec!r}: no file {path}")
        digest = hashlib.sha1(str(path).encode()).hexdigest()[:10]  # stable across processes
        module_name = f"azgym_plugin_{path.stem}_{digest}"
        module = sys.modules.get(module_name)
        if module is None:
            module_spec = importlib.util.spec_from_file_location(module_name, path)
            if module_spec is None or module_spec.loader is None:
                raise InvalidInputError(f"{kind} spec {spec!r}: cannot import {path}")
            module = importlib.util.module_from_spec(module_spec)
            sys.modules[module_name] = module  # so pickling (worker processes) can find it
            module_spec.loader.exec_module(module)
    else:
        try:
            module = importlib.import_module(target)
        except ImportError as exc:
            raise InvalidInputError(
                f"{kind} spec {spec!r}: cannot import {target!r}: {exc}") from None
    try:
        return getattr(module, attribute)
    except AttributeError:
        raise InvalidInputError(
            f"{kind} spec {spec!r}: {target!r} has no attribute {attribute!r}") from None


_PARAMS_START = re.compile(r":(?=\s*[A-Za-z_]\w*\s*=)")
_PARAM = re.compile(r'\s*([A-Za-z_]\w*)\s*=\s*("(?:[^"\\]|\\.)*"'
                    r'|[^,]*?(?:,(?!\s*[A-Za-z_]\w*\s*=)[^,]*?)*)\s*(?:,|$)')
"""A NAME=VALUE pair; the value runs over commas up to the next NAME= (a list of numbers)."""
_PYTHON_WORDS = {"True": True, "False": False, "None": None}


def split_spec(spec: str, kind: str) -> tuple[str, dict[str, Any]]:
    """Split a spec into its target and hyperparameters (:mod:`azgym.localize.registry`).

    Args:
        spec: The spec.
        kind: What it names, as errors say (``"localizer"``).

    Raises:
        InvalidInputError: Hyperparameters that are not ``NAME=VALUE`` pairs, a name given twice,
            a value that is not a scalar.
    """
    if not isinstance(spec, str):
        raise InvalidInputError(f"{kind} name must be a string, got {type(spec).__name__}")
    start = _PARAMS_START.search(spec)
    target, text = (spec, "") if start is None else (spec[:start.start()], spec[start.end():])
    if text.rstrip().endswith(","):
        raise InvalidInputError(f"{kind} spec {spec!r}: a comma with nothing after it")
    params: dict[str, Any] = {}
    position = 0
    while position < len(text):
        pair = _PARAM.match(text, position)
        if pair is None or not pair.group(2) or pair.end() == position:
            raise InvalidInputError(
                f"{kind} spec {spec!r}: cannot read hyperparameters from {text[position:]!r}; "
                "write NAME=VALUE[,NAME=VALUE...]")
        name = pair.group(1)
        if name in params:
            raise InvalidInputError(f"{kind} spec {spec!r}: hyperparameter {name!r} twice")
        params[name] = _scalar(f"{kind} spec {spec!r}", name, pair.group(2))
        position = pair.end()
    return target, params


def _scalar(where: str, name: str, text: str) -> Any:
    """A hyperparameter's value: a JSON scalar, Python's True/False/None, or else a bare string."""
    if text in _PYTHON_WORDS:
        return _PYTHON_WORDS[text]
    if text.startswith(("[", "{")):
        raise InvalidInputError(f"{where}: {name} must be a scalar (true, false, null, a number "
                                f"or a string) or numbers separated by commas ({name}=1,2,3), "
                                f"got {text}")
    if "," in text and not text.startswith('"'):
        return _numbers(where, name, text)
    try:
        return json.loads(text)
    except ValueError:
        if text.startswith('"'):
            raise InvalidInputError(
                f"{where}: {name}={text} is not a valid quoted string") from None
        return text


def _numbers(where: str, name: str, text: str) -> list[float | int]:
    """A list value, ``1,2.5,-3``: JSON numbers separated by commas."""
    values = []
    for piece in text.split(","):
        try:
            value = json.loads(piece)
        except ValueError:
            value = None
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise InvalidInputError(
                f"{where}: {name}={text} is not a list of numbers separated by commas "
                f"({piece.strip()!r} is not a number; quote a string that has commas)")
        values.append(value)
    return values


def hyperparameter_names(factory: Callable[..., Any]) -> tuple[str, ...]:
    """The hyperparameters a factory takes: its keyword-only arguments (a class's ``__init__``'s).

    A factory whose signature cannot be read takes none that a profile could set.
    """
    try:
        signature = inspect.signature(factory)
    except (TypeError, ValueError):
        return ()
    return tuple(name for name, parameter in signature.parameters.items()
                 if parameter.kind is parameter.KEYWORD_ONLY)


def check_param_names(kind: str, target: str, factory: Callable[..., Any],
                      params: Mapping[str, Any]) -> None:
    """Refuse a hyperparameter the factory does not take, naming the closest one it does.

    A factory that takes ``**kwargs`` (or whose signature cannot be read) is left to raise
    its own TypeError when called.

    Raises:
        InvalidInputError: A name the factory does not take ("Did you mean ...?").
    """
    try:
        signature = inspect.signature(factory)
    except (TypeError, ValueError):
        return
    kinds = {p.kind for p in signature.parameters.values()}
    if inspect.Parameter.VAR_KEYWORD in kinds:
        return
    valid = [p.name for p in signature.parameters.values()
             if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)]
    for key in params:
        if key not in valid:
            raise InvalidInputError(
                f"{kind} {target!r}: {unknown_name('hyperparameter', key, valid)}")


def construct(kind: str, target: str, factory: Callable[..., R], params: Mapping[str, Any]
              ) -> R:
    """Call a spec's factory with its hyperparameters, their names checked first.

    Raises:
        InvalidInputError: A hyperparameter it does not take, or its TypeError, named.
    """
    check_param_names(kind, target, factory, params)
    try:
        return factory(**params)
    except TypeError as exc:
        raise InvalidInputError(f"{kind} {target!r}: {exc}") from None
