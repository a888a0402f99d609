"""Who runs in a benchmark: a contender is a localizer spec with its hyperparameters and a label.

A contender's label is its canonical spec (:func:`azgym.localize.registry.spec_label`): the
target and its hyperparameters written as ``--localizer`` takes them (``ransac``,
``mex:coarse_step=0.2``, ``path/mine.py:Mine:tag=fast``), or the name of the preset they match
(``ransac-weighted`` is ``ransac:weighted=true``). So every label in a table is something
``--localizer`` accepts and builds exactly that contender, and one label never means two
localizers.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from azgym.core import BeaconMap, Measurements
from azgym.errors import AzgymError, InvalidInputError
from azgym.localize.registry import make_localizer, parse_spec, spec_label

REFERENCE = "ransac"
"""The localizer every runtime is compared with (added to a run that lacks it)."""

DEFAULT_SPECS = ("ransac", "ransac-weighted", "loo", "lsq", "triplet", "mex-coarse")
"""The bench's default contenders; mex runs coarse-to-fine (10 cm, then the 1 cm lattice), as
the exhaustive 1 cm search takes about 0.1 s a frame."""


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


def with_defaults(contenders: Iterable[Contender]) -> list[Contender]:
    """The default contenders, then the given ones that are not among them."""
    defaults = default_contenders()
    labels = {c.label for c in defaults}
    return defaults + [c for c in contenders if c.label not in labels]


def check_buildable(candidate: Contender) -> None:
    """Build the contender once: a bad name, spec or hyperparameter raises here, not per frame.

    For a :class:`~azgym.localize.base.Localizer`, the hyperparameters are checked too (they are
    validated on its first frame: here an empty one). This runs the localizer's code in the
    calling process: a plug-in's module and its constructor.

    Raises:
        InvalidInputError: Naming the contender and what went wrong.
    """
    from azgym.localize.base import Localizer  # here: it loads the compiled kernels

    beacons = BeaconMap(np.arange(3), np.array([[1.0, 0.0, 2.5], [0.0, 1.0, 2.5],
                                                [-1.0, 0.0, 2.5]]))
    try:
        localizer = make_localizer(candidate.spec, **candidate.params)
        if isinstance(localizer, Localizer):
            localizer.localize(Measurements(np.arange(0), np.zeros(0)), beacons)
    except AzgymError as exc:
        raise InvalidInputError(f"cannot build {candidate.label}: {exc}") from None
    except Exception as exc:  # noqa: BLE001 - a plug-in's own error, reported, not a traceback
        raise InvalidInputError(
            f"cannot build {candidate.label}: {type(exc).__name__}: {exc}") from None
