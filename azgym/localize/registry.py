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

import json
from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

from azgym.core import BeaconMap, Estimate, Measurements
from azgym.errors import AzgymError, InvalidInputError, unknown_name
from azgym.profile import Profile, profile_defaults
from azgym.registry import Registry, construct, hyperparameter_names, split_spec

__all__ = ["ENTRY_POINT_GROUP", "LOCALIZERS", "PRESETS", "TRACKERS", "TRACKER_ENTRY_POINT_GROUP",
           "TRACKER_METHODS", "Factory", "SupportsLocalize", "build", "has_tracker_methods",
           "is_builtin", "list_localizers",
           "list_trackers", "make_localizer", "parse_spec", "profile_params",
           "register_localizer", "resolve", "spec_label"]

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
        return LOCALIZERS.load(name, list_localizers() + list_trackers())
    for registry in (TRACKERS, LOCALIZERS):  # a name in both groups: the tracker's, as ever
        if name in registry:
            return registry[name]
    raise unknown_name("localizer", name, list_localizers() + list_trackers())


def parse_spec(spec: str) -> tuple[str, dict[str, Any]]:
    """Split a spec into its target and hyperparameters, a preset expanded (module docstring).

    Raises:
        InvalidInputError: Hyperparameters that are not ``NAME=VALUE`` pairs, a name given twice,
            a value that is not a scalar.
    """
    target, params = split_spec(spec, "localizer")
    if target in PRESETS:
        target, params = PRESETS[target][0], {**PRESETS[target][1], **params}
    return target, params


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
    return construct("localizer", target, resolve(target), {**inline, **params})


def profile_params(factory: Callable[..., Any], given: dict[str, Any],
                   profile: Profile | None) -> dict[str, Any]:
    """The hyperparameters a profile gives a factory: the fields it takes that ``given`` lacks.

    A hyperparameter the spec writes wins over the profile's. The one rule of a profile's
    fields as hyperparameters, for a contender (localizer or tracker) as for a mapper
    (:mod:`azgym.profile`).

    Args:
        factory: The class the spec resolves to (a preset's, not a tracker wrapping it).
        given: The hyperparameters the spec writes, inline or beside it.
        profile: The profile (None: none).
    """
    if profile is None or profile.empty:
        return {}
    return profile_defaults(hyperparameter_names(factory), profile, given)
