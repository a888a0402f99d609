"""Who runs in a benchmark: a contender is a localizer spec with its hyperparameters and a label."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

REFERENCE = "ransac"
"""The localizer every runtime is compared with (added to a run that lacks it)."""


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


def default_contenders() -> list[Contender]:
    """The built-in localizers; mex runs coarse-to-fine (10 cm, then the 1 cm lattice)."""
    return [Contender("ransac", "ransac"),
            Contender("ransac-weighted", "ransac", {"weighted": True}),
            Contender("loo", "loo"), Contender("lsq", "lsq"), Contender("triplet", "triplet"),
            Contender("mex", "mex", {"coarse_step": 0.1})]
