"""Names → localizer factories: built-ins, presets, ``azgym.localizers`` entry points, specs.

A spec is a target, optionally followed by hyperparameters::

    TARGET[:NAME=VALUE[,NAME=VALUE...]]

The target is a registered name (``ransac``), a preset (``ransac-weighted``: a built-in with
hyperparameters, listed in ``PRESETS``), an importable ``package.module:Class`` or a file
``path/to/file.py:Class``. The hyperparameters start at the first colon that is followed by
``NAME=``, which a target's own colon (``file.py:Class``, ``C:/dir``) never is:
``ransac:weighted=true``, ``path/mine.py:Mine:max_iter=50,tag=fast``. A value is read as a JSON
scalar (``true``, ``false``, ``null``, a number, a ``"quoted string"``; Python's ``True``,
``False`` and ``None`` too); any other word is a string (``tag=fast``). A list of numbers is
written with commas, the pieces up to the next ``NAME=``: ``mex:bounds=0,-2.5,12,8,step=0.05``
gives ``bounds=[0, -2.5, 12, 8]``. :func:`spec_label` writes the one canonical spec of a target
and its hyperparameters, which :func:`parse_spec` reads back.

Third-party packages register a name by declaring, in their pyproject.toml::

    [project.entry-points."azgym.localizers"]
    mylocalizer = "mypackage.module:MyLocalizer"
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import inspect
import json
import re
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

from azgym.core import BeaconMap, Estimate, Measurements
from azgym.errors import AzgymError, InvalidInputError, unknown_name
from azgym.registry import Registry

__all__ = ["ENTRY_POINT_GROUP", "LOCALIZERS", "PRESETS", "TRACKERS", "TRACKER_ENTRY_POINT_GROUP",
           "TRACKER_METHODS", "Factory", "SupportsLocalize", "build", "has_tracker_methods",
           "is_builtin", "list_localizers",
           "list_trackers", "make_localizer", "parse_spec", "register_localizer", "resolve",
           "spec_label"]

ENTRY_POINT_GROUP = "azgym.localizers"
TRACKER_ENTRY_POINT_GROUP = "azgym.trackers"


@runtime_checkable
class SupportsLocalize(Protocol):
    """What azgym needs of a localizer: one method. :class:`Localizer` adds validation on top."""

    def localize(self, measurements: Measurements, beacons: BeaconMap) -> Estimate:
        """Estimate the camera pose from one frame."""
        ...


TRACKER_METHODS = ("reset", "predict", "update")
"""What a tracker must offer (:class:`azgym.track.base.SupportsTrack`), each a callable."""


def has_tracker_methods(candidate: object) -> bool:
    """Whether an object (or a class) has a tracker's methods: the one test of "a tracker"."""
    return all(callable(getattr(candidate, method, None)) for method in TRACKER_METHODS)


Factory = Callable[..., SupportsLocalize]


def _localizer_class(spec: str, factory: Any) -> Factory:
    """The factory a spec names, if it is a localizer or tracker class.

    A localizer class has a ``localize`` method; a tracker class has ``reset``, ``predict`` and
    ``update``. A spec comes from a command line or a leaderboard entry, which anyone can write:
    refusing anything else before calling it means that ``"os:system"`` or
    ``"subprocess:Popen"`` with hyperparameters can never run a command.
    """
    is_class = isinstance(factory, type)
    localizer = is_class and callable(getattr(factory, "localize", None))
    tracker = is_class and has_tracker_methods(factory)
    if not (localizer or tracker):
        raise InvalidInputError(
            f"localizer spec {spec!r} names a {type(factory).__name__}, not a localizer class "
            "(a class with a localize(measurements, beacons) method) or a tracker class (with "
            "reset, predict and update)")
    return factory


LOCALIZERS: Registry[Factory] = Registry("localizer", {
    "triplet": "azgym.localize.triplet:Triplet",
    "ransac": "azgym.localize.ransac:Ransac",
    "mex": "azgym.localize.mex:Mex",
    "lsq": "azgym.localize.lsq:LeastSquares",
    "loo": "azgym.localize.loo:LeaveOneOut",
    "ng-ransac": "azgym.localize.learned:NgRansac",
    "learned": "azgym.localize.learned:Learned",
}, group=ENTRY_POINT_GROUP, check=_localizer_class)
"""Localizers by name: the built-ins, those of :func:`register_localizer` and the plug-ins."""
TRACKERS: Registry[Factory] = Registry("tracker", {
    "dead-reckoning": "azgym.track.dead_reckoning:DeadReckoning",
    "tkf": "azgym.track.inertial_kalman:Tkf",
    "lpkf": "azgym.track.inertial_kalman:Lpkf",
    "gated-ekf": "azgym.track.gated_ekf:GatedEkf",
    "robust": "azgym.track.robust:Robust",
}, group=TRACKER_ENTRY_POINT_GROUP, check=_localizer_class)
"""Trackers (:mod:`azgym.track`) by name; they share the specs, presets and plug-in rules."""
PRESETS: dict[str, tuple[str, dict[str, Any]]] = {
    "ransac-weighted": ("ransac", {"weighted": True}),
    "mex-coarse": ("mex", {"coarse_step": 0.1}),
}
"""Named built-ins with hyperparameters: ``name -> (target, params)``; the bench's defaults use
them. A preset is only a short spec: it expands to its target and hyperparameters wherever it is
read, so results and leaderboard entries record ``ransac`` with ``weighted=true``."""
_SHIPPED = frozenset(LOCALIZERS.names(plugins=False) + TRACKERS.names(plugins=False)) | \
    set(PRESETS)
"""The names that ship with azgym (registered above, before any user's)."""


def register_localizer(name: str, factory: Factory) -> None:
    """Register ``factory`` (a class or callable returning a localizer) under ``name``.

    Raises:
        InvalidInputError: The name is empty or already taken.
    """
    if isinstance(name, str) and (name in TRACKERS.names(plugins=False) or name in PRESETS):
        raise InvalidInputError(f"a localizer named {name!r} is already registered")
    LOCALIZERS.register(name, factory)


def list_localizers() -> list[str]:
    """Every localizer name: built-ins, presets, registered and entry-point localizers."""
    return sorted(set(LOCALIZERS) | set(PRESETS))


def is_builtin(spec: str) -> bool:
    """Whether a spec names a localizer or tracker that ships with azgym (hyperparameters aside).

    The benchmark's workers trust a built-in's first call to compile its kernels for as long as
    that takes; a plug-in's first call has the time limit of any other.
    """
    try:
        target, _ = parse_spec(spec)
    except AzgymError:
        return False
    return target in _SHIPPED


def list_trackers() -> list[str]:
    """Every tracker name: built-ins and ``azgym.trackers`` entry points.

    Any localizer runs as a tracker too (:func:`azgym.track.base.make_tracker`).
    """
    return sorted(TRACKERS)


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


def resolve(name: str) -> Factory:
    """The factory behind a name or spec (see module docstring).

    A registered name (a built-in's, or one of :func:`register_localizer`) comes before a
    plug-in's of the same name, whichever registry each is in.
    """
    if not isinstance(name, str):
        raise InvalidInputError(f"localizer name must be a string, got {type(name).__name__}")
    for registry in (LOCALIZERS, TRACKERS):
        if name in registry.names(plugins=False):
            return registry[name]
    if name in PRESETS:
        return resolve(PRESETS[name][0])
    if ":" in name:
        registered = name.partition(":")[0]
        if registered in list_localizers() or registered in list_trackers():
            raise InvalidInputError(
                f"localizer spec {name!r}: {registered!r} is a registered name; its "
                f"hyperparameters are written {registered}:NAME=VALUE[,NAME=VALUE...]")
        return _load_attribute(name)
    for registry in (TRACKERS, LOCALIZERS):  # a name in both groups: the tracker's, as ever
        if name in registry:
            return registry[name]
    raise unknown_name("localizer", name, list_localizers() + list_trackers())


_PARAMS_START = re.compile(r":(?=\s*[A-Za-z_]\w*\s*=)")
_PARAM = re.compile(r'\s*([A-Za-z_]\w*)\s*=\s*("(?:[^"\\]|\\.)*"'
                    r'|[^,]*?(?:,(?!\s*[A-Za-z_]\w*\s*=)[^,]*?)*)\s*(?:,|$)')
"""A NAME=VALUE pair; the value runs over commas up to the next NAME= (a list of numbers)."""
_PYTHON_WORDS = {"True": True, "False": False, "None": None}


def parse_spec(spec: str) -> tuple[str, dict[str, Any]]:
    """Split a spec into its target and hyperparameters, a preset expanded (module docstring).

    Raises:
        InvalidInputError: Hyperparameters that are not ``NAME=VALUE`` pairs, a name given twice,
            a value that is not a scalar.
    """
    if not isinstance(spec, str):
        raise InvalidInputError(f"localizer name must be a string, got {type(spec).__name__}")
    start = _PARAMS_START.search(spec)
    target, text = (spec, "") if start is None else (spec[:start.start()], spec[start.end():])
    if text.rstrip().endswith(","):
        raise InvalidInputError(f"localizer spec {spec!r}: a comma with nothing after it")
    params: dict[str, Any] = {}
    position = 0
    while position < len(text):
        pair = _PARAM.match(text, position)
        if pair is None or not pair.group(2) or pair.end() == position:
            raise InvalidInputError(
                f"localizer spec {spec!r}: cannot read hyperparameters from {text[position:]!r}; "
                "write NAME=VALUE[,NAME=VALUE...]")
        name = pair.group(1)
        if name in params:
            raise InvalidInputError(f"localizer spec {spec!r}: hyperparameter {name!r} twice")
        params[name] = _scalar(spec, name, pair.group(2))
        position = pair.end()
    if target in PRESETS:
        target, params = PRESETS[target][0], {**PRESETS[target][1], **params}
    return target, params


def _scalar(spec: str, name: str, text: str) -> Any:
    """A hyperparameter's value: a JSON scalar, Python's True/False/None, or else a bare string."""
    if text in _PYTHON_WORDS:
        return _PYTHON_WORDS[text]
    if text.startswith(("[", "{")):
        raise InvalidInputError(f"localizer spec {spec!r}: {name} must be a scalar (true, false, "
                                f"null, a number or a string) or numbers separated by commas "
                                f"({name}=1,2,3), got {text}")
    if "," in text and not text.startswith('"'):
        return _numbers(spec, name, text)
    try:
        return json.loads(text)
    except ValueError:
        if text.startswith('"'):
            raise InvalidInputError(
                f"localizer spec {spec!r}: {name}={text} is not a valid quoted string") from None
        return text


def _numbers(spec: str, name: str, text: str) -> list[float | int]:
    """A list value, ``1,2.5,-3``: JSON numbers separated by commas."""
    values = []
    for piece in text.split(","):
        try:
            value = json.loads(piece)
        except ValueError:
            value = None
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise InvalidInputError(
                f"localizer spec {spec!r}: {name}={text} is not a list of numbers separated by "
                f"commas ({piece.strip()!r} is not a number; quote a string that has commas)")
        values.append(value)
    return values


def spec_label(target: str, params: dict[str, Any]) -> str:
    """The canonical spec of a target and hyperparameters, which :func:`parse_spec` reads back.

    A preset's name where one matches, else the target and the hyperparameters sorted by name.
    """
    text = _canonical(target, params)
    for preset, (preset_target, preset_params) in PRESETS.items():
        if preset_target == target and _canonical(target, preset_params) == text:
            return preset
    return text


def _canonical(target: str, params: dict[str, Any]) -> str:
    pairs = ",".join(f"{name}={_written(params[name])}" for name in sorted(params))
    return f"{target}:{pairs}" if pairs else target


def _written(value: Any) -> str:
    """A value as a spec writes it: a word bare if it reads back as itself, numbers with commas.

    Anything else as JSON.
    """
    if isinstance(value, list | tuple) and value and all(
            isinstance(v, int | float) and not isinstance(v, bool) for v in value):
        return ",".join(json.dumps(v) for v in value)
    if isinstance(value, str):
        try:
            if parse_spec(f"x:v={value}") == ("x", {"v": value}):
                return value
        except InvalidInputError:
            pass
    return json.dumps(value)


def make_localizer(name: str, **params: Any) -> SupportsLocalize:
    """Build a localizer from a name or spec, with hyperparameters as keywords.

    Example:
        >>> import azgym
        >>> localizer = azgym.make_localizer("ransac", weighted=True)
        >>> localizer.get_params()["weighted"]
        True
        >>> azgym.make_localizer("ransac:weighted=true").get_params()["weighted"]
        True

    Raises:
        UnknownNameError: No such localizer ("Did you mean ...?").
        InvalidInputError: A spec that cannot be imported, or a hyperparameter it does not take
            (naming the closest one it does).
    """
    localizer = build(name, **params)
    if not isinstance(localizer, SupportsLocalize):
        kind = "tracker" if callable(getattr(localizer, "update", None)) else \
            type(localizer).__name__
        raise InvalidInputError(
            f"{name!r} built a {kind}, which has no localize(measurements, beacons) method "
            "(a tracker runs with azgym.make_tracker, and in any benchmark)")
    return localizer


def build(name: str, **params: Any) -> Any:
    """Build whatever a name or spec names (a localizer or a tracker), hyperparameters checked.

    Raises:
        UnknownNameError: No such name ("Did you mean ...?").
        InvalidInputError: A spec that cannot be imported, or a hyperparameter it does not take.
    """
    target, inline = parse_spec(name)
    both = sorted(set(inline) & set(params))
    if both:
        raise InvalidInputError(f"localizer {name!r}: hyperparameter {both[0]!r} given both in "
                                "the spec and as a keyword")
    params = {**inline, **params}
    factory = resolve(target)
    _check_param_names(target, factory, params)
    try:
        return factory(**params)
    except TypeError as exc:
        raise InvalidInputError(f"localizer {target!r}: {exc}") from None


def _check_param_names(target: str, factory: Factory, params: dict[str, Any]) -> None:
    """Refuse a hyperparameter the factory does not take, naming the closest one it does.

    A factory that takes ``**kwargs`` (or whose signature cannot be read) is left to raise
    its own TypeError when called.
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
                f"localizer {target!r}: {unknown_name('hyperparameter', key, valid)}")
