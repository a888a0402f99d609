"""Who runs in a benchmark: a contender is a localizer spec with its hyperparameters and a label.

A contender's label is its canonical spec (:func:`azgym.localize.registry.spec_label`): the
target and its hyperparameters written as ``--localizer`` takes them (``ransac``,
``mex:coarse_step=0.2``, ``path/mine.py:Mine:tag=fast``), or the name of the preset they match
(``ransac-weighted`` is ``ransac:weighted=true``). So every label in a table is something
``--localizer`` accepts and builds exactly that contender, and one label never means two
localizers.

Which contenders a command runs is one rule, :func:`resolve_contenders`: the frame suites, a
log, a navigation suite and a sweep all choose theirs through it.
"""

from __future__ import annotations

import contextlib
import json
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from azgym.bench.run.isolation import DEFAULT_TIME_LIMIT, build_problem
from azgym.bench.run.profiles import contender_params
from azgym.bench.run.worker import warm_up as warm_up_tracker
from azgym.errors import InvalidInputError
from azgym.localize.registry import is_builtin, parse_spec, spec_label
from azgym.profile import Profile
from azgym.track.base import make_tracker

__all__ = ["DEFAULT_SPECS", "REFERENCE", "REPAIR_TRACKER", "Contender", "builtins_to_warm",
           "contenders_named", "check_buildable", "contender", "default_contenders",
           "resolve_contenders", "warm_up", "with_reference"]

REFERENCE = "ransac"
"""The localizer every runtime is compared with (added to a run that lacks it)."""

DEFAULT_SPECS = ("ransac", "ransac-weighted", "loo", "lsq", "triplet", "mex-coarse")
"""The bench's default contenders; mex runs coarse-to-fine (10 cm, then the 1 cm lattice), as
the exhaustive 1 cm search takes about 0.1 s a frame."""

REPAIR_TRACKER = "robust:repair=true"
"""The ``repair`` mapper's tracker. Its warm-up also reaches the motion model's kernels that every
built-in mapper steps a drive through (its lag keeps each frame's steps), so a mapping run warms
it in the fork server, and its first case does not compile them inside its time limit."""


@dataclass(frozen=True)
class Contender:
    """A localizer as the runner runs it.

    Attributes:
        label: Its name in reports.
        spec: A registered name, ``package.module:Class`` or ``path/file.py:Class``.
        params: Hyperparameters for ``make_localizer``.
    """

    label: str
    spec: str
    params: dict[str, Any] = field(default_factory=dict)

    @property
    def is_reference(self) -> bool:
        """Whether this is the runtime reference: ``ransac`` with its default hyperparameters."""
        return self.spec == REFERENCE and not self.params


def contender(spec: str) -> Contender:
    """The contender a spec names (``ransac:weighted=true``), labelled by its canonical spec.

    Raises:
        InvalidInputError: Hyperparameters that cannot be read.
    """
    target, params = parse_spec(spec)
    return Contender(spec_label(target, params), target, params)


def default_contenders() -> list[Contender]:
    """The built-in localizers the bench runs by default (:data:`DEFAULT_SPECS`)."""
    return [contender(spec) for spec in DEFAULT_SPECS]


def with_reference(contenders: Iterable[Contender]) -> list[Contender]:
    """The contenders, and ``ransac`` last if none of them is the runtime reference."""
    contenders = list(contenders)
    if not any(c.is_reference for c in contenders):
        contenders.append(Contender(REFERENCE, REFERENCE))
    return contenders


def check_buildable(candidate: Contender, time_limit: float = DEFAULT_TIME_LIMIT,
                    profile: Profile | None = None) -> None:
    """Build the contender once, in a worker: a bad name, spec or hyperparameter raises here.

    The build runs where the benchmark runs the localizer (:mod:`azgym.bench.run.isolation`), with
    the same time limit and hyperparameters (the profile's defaults under its own), so a
    plug-in whose module or constructor hangs or crashes is reported instead of stopping the
    caller.

    Raises:
        InvalidInputError: Naming the contender and what went wrong.
    """
    problem = build_problem(candidate.spec, candidate.params, time_limit, profile)
    if problem:
        raise InvalidInputError(f"cannot build {candidate.label}: {problem}")


def resolve_contenders(
    specs: Sequence[str],
    *,
    with_builtins: bool = False,
    builtins: Sequence[str] = DEFAULT_SPECS,
    check: Callable[[Contender], None] | None = check_buildable,
    check_builtins: bool = False,
    refuse_repeat: Callable[[str, int, int], Exception] | None = None,
) -> list[Contender]:
    """Which contenders run: the ones ``specs`` name, else the built-ins; each once, each built.

    The one rule of every command that runs localizers (``azgym bench`` on a frame suite, a log
    or a navigation suite, ``azgym evaluate navigator`` and ``azgym sweep``), in this order:

    1. Each spec is a contender labelled by its canonical spec (:func:`contender`); a spec whose
       hyperparameters cannot be read stops the caller here, before anything is built.
    2. A label named again is the same localizer (``ransac:weighted=true`` is
       ``ransac-weighted``): it runs once; with ``refuse_repeat``, the error it makes of the
       label and the indices in ``specs`` of the first and of the repeat is raised instead.
    3. With no spec, the built-ins run; with ``with_builtins``, the built-ins first, then the
       named ones that are not among them.
    4. Each named contender is built once by ``check``, which raises on a problem
       (:func:`check_buildable`: in a worker, as the run builds it; a bad name is answered with
       the closest ones, "Did you mean ...?"), the built-ins too with ``check_builtins`` (a
       profile's defaults may not suit one); so a bad name, spec or hyperparameter stops the
       caller before the run rather than failing every frame. ``None``: none is built here (a
       navigation suite builds each in its environment). The runtime reference is the
       runner's to add (:func:`with_reference`).

    Args:
        specs: What ``--localizer`` takes: a name, preset or plug-in spec, with hyperparameters.
        with_builtins: Run the built-ins besides the named ones.
        builtins: The built-ins (default: the bench's, :data:`DEFAULT_SPECS`).
        check: Builds a contender, raising :class:`InvalidInputError` on a problem.
        check_builtins: Build the built-ins too.
        refuse_repeat: Makes the error for a label named twice (None: run it once).

    Raises:
        InvalidInputError: A spec that cannot be read, or one ``check`` refuses.
    """
    named: dict[str, Contender] = {}
    first: dict[str, int] = {}
    for k, candidate in enumerate(map(contender, specs)):
        if candidate.label in named:
            if refuse_repeat is not None:
                raise refuse_repeat(candidate.label, first[candidate.label], k)
            continue
        named[candidate.label] = candidate
        first[candidate.label] = k
    chosen = list(named.values())
    if with_builtins or not named:
        defaults = [contender(spec) for spec in builtins]
        labels = {c.label for c in defaults}
        chosen = defaults + [c for c in chosen if c.label not in labels]
    if check is not None:
        for candidate in chosen:
            if check_builtins or candidate.label in named:
                check(candidate)
    return chosen


def builtins_to_warm(contenders: Iterable[Contender]) -> list[Contender]:
    """The built-ins among the contenders, the reference first: what a run's fork server warms.

    ``ransac``, the reference, takes the longest to compile, so on a machine's first run the
    fork server starts with it while the runner warms the others (:func:`warm_up`).
    """
    return sorted((c for c in contenders if is_builtin(c.spec)), key=lambda c: not c.is_reference)


def contenders_named(labels: str | None) -> list[Contender]:
    """The contenders a JSON list of labels names, in its order.

    The bench's defaults and :data:`REPAIR_TRACKER` when ``labels`` is None or no such list; a
    label that cannot be read is left out (a worker meets, and reports, the same problem).
    """
    try:
        named = json.loads(labels) if labels is not None else None
    except ValueError:
        named = None
    if not (isinstance(named, list) and all(isinstance(label, str) for label in named)):
        named = [*DEFAULT_SPECS, REPAIR_TRACKER]
    chosen = []
    for label in named:
        with contextlib.suppress(InvalidInputError):
            chosen.append(contender(label))
    return chosen


def warm_up(contenders: Iterable[Contender], profile: Profile | None = None) -> None:
    """Run each contender through the warm-up route (:func:`azgym.bench.run.worker.warm_up`).

    That loads (or compiles) its kernels for every specialization a run's frames reach. The
    workers' fork server does this for the run's built-ins (:func:`builtins_to_warm`) before it
    forks any worker. On a machine's first run the runner does it too, for those after the
    first, from the last, while the fork server compiles ``ransac``: each then finds in numba's
    cache what the other compiled, which shortens a first run by a third. Each is built as the
    run builds it, with the profile's defaults under its hyperparameters. Built-ins only: this
    runs in the caller's process, and a plug-in is skipped.
    """
    for contender in contenders:
        if not is_builtin(contender.spec):
            continue
        try:
            warm_up_tracker(make_tracker(contender.spec, **contender_params(
                contender.spec, contender.params, profile)))
        except Exception:  # noqa: BLE001, S112 - a worker meets (and scores) the same failure
            continue

