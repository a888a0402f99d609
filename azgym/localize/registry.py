"""Names → localizer factories: the built-ins, the ``azgym.localizers`` entry points, and specs.

A spec is a registered name (``"ransac"``), an importable ``"package.module:Class"``, or a file
``"path/to/file.py:Class"``. Third-party packages register a name by declaring, in their
pyproject.toml::

    [project.entry-points."azgym.localizers"]
    mylocalizer = "mypackage.module:MyLocalizer"
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import sys
from collections.abc import Callable
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

from azgym.core import BeaconMap, Estimate, Measurements
from azgym.errors import InvalidInputError, unknown_name

ENTRY_POINT_GROUP = "azgym.localizers"


@runtime_checkable
class SupportsLocalize(Protocol):
    """What azgym needs of a localizer: one method. :class:`Localizer` adds validation on top."""

    def localize(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        """Estimate the camera pose from one frame."""
        ...


Factory = Callable[..., SupportsLocalize]

_BUILTIN: dict[str, str] = {
    "triplet": "azgym.localize.triplet:Triplet",
    "ransac": "azgym.localize.ransac:Ransac",
    "mex": "azgym.localize.mex:Mex",
    "lsq": "azgym.localize.lsq:LeastSquares",
    "loo": "azgym.localize.loo:LeaveOneOut",
}
_REGISTERED: dict[str, Factory] = {}


def register_localizer(name: str, factory: Factory) -> None:
    """Register ``factory`` (a class or callable returning a localizer) under ``name``.

    Raises:
        InvalidInputError: The name is empty or already taken.
    """
    if not isinstance(name, str) or not name:
        raise InvalidInputError(f"localizer name must be a non-empty string, got {name!r}")
    if name in _BUILTIN or name in _REGISTERED:
        raise InvalidInputError(f"a localizer named {name!r} is already registered")
    _REGISTERED[name] = factory


def _entry_points() -> dict[str, Any]:
    return {ep.name: ep for ep in entry_points(group=ENTRY_POINT_GROUP)}


def list_localizers() -> list[str]:
    """Every name ``make_localizer`` accepts: built-ins, registered and entry-point localizers."""
    return sorted(set(_BUILTIN) | set(_REGISTERED) | set(_entry_points()))


def _load_attribute(spec: str) -> Factory:
    """Resolve ``"module:Class"`` or ``"path/file.py:Class"``."""
    target, _, attribute = spec.rpartition(":")
    if target.endswith(".py"):
        path = Path(target).expanduser().resolve()
        if not path.is_file():
            raise InvalidInputError(f"localizer spec {spec!r}: no file {path}")
        digest = hashlib.sha1(str(path).encode()).hexdigest()[:10]  # stable across processes
        module_name = f"azgym_plugin_{path.stem}_{digest}"
        module = sys.modules.get(module_name)
        if module is None:
            module_spec = importlib.util.spec_from_file_location(module_name, path)
            if module_spec is None or module_spec.loader is None:
                raise InvalidInputError(f"localizer spec {spec!r}: cannot import {path}")
            module = importlib.util.module_from_spec(module_spec)
            sys.modules[module_name] = module  # so pickling (worker processes) can find it
            module_spec.loader.exec_module(module)
    else:
        try:
            module = importlib.import_module(target)
        except ImportError as exc:
            raise InvalidInputError(
                f"localizer spec {spec!r}: cannot import {target!r}: {exc}"
            ) from None
    try:
        factory = getattr(module, attribute)
    except AttributeError:
        raise InvalidInputError(
            f"localizer spec {spec!r}: {target!r} has no attribute {attribute!r}"
        ) from None
    return _localizer_class(spec, factory)


def _localizer_class(spec: str, factory: Any) -> Factory:
    """The factory a spec names, if it is a localizer class: a class with a ``localize`` method.

    A spec comes from a command line or a leaderboard entry, which anyone can write: refusing
    anything else before calling it means that ``"os:system"`` or ``"subprocess:Popen"`` with
    hyperparameters can never run a command.
    """
    if not (isinstance(factory, type) and callable(getattr(factory, "localize", None))):
        raise InvalidInputError(
            f"localizer spec {spec!r} names a {type(factory).__name__}, not a localizer class "
            "(a class with a localize(measurements, beacons) method)")
    return factory


def resolve(name: str) -> Factory:
    """The factory behind a name or spec (see module docstring)."""
    if not isinstance(name, str):
        raise InvalidInputError(f"localizer name must be a string, got {type(name).__name__}")
    if name in _REGISTERED:
        return _REGISTERED[name]
    if name in _BUILTIN:
        return _load_attribute(_BUILTIN[name])
    if ":" in name:
        return _load_attribute(name)
    plugins = _entry_points()
    if name in plugins:
        return _localizer_class(name, plugins[name].load())
    raise unknown_name("localizer", name, list_localizers())


def make_localizer(name: str, **params: Any) -> SupportsLocalize:
    """Build a localizer from a name or spec, with hyperparameters as keywords.

    Example:
        >>> import azgym
        >>> localizer = azgym.make_localizer("ransac", weighted=True)
        >>> localizer.get_params()["weighted"]
        True

    Raises:
        UnknownNameError: No such localizer ("Did you mean ...?").
        InvalidInputError: A spec that cannot be imported, or a hyperparameter it does not take.
    """
    factory = resolve(name)
    try:
        localizer = factory(**params)
    except TypeError as exc:
        raise InvalidInputError(f"localizer {name!r}: {exc}") from None
    if not isinstance(localizer, SupportsLocalize):
        raise InvalidInputError(
            f"localizer {name!r} built a {type(localizer).__name__}, which has no "
            "localize(measurements, beacons) method"
        )
    return localizer
