"""The mapper interface: ``survey(drive, prior) -> MapAnswer``, a plug-in's way into the benchmark.

A mapper turns one drive (camera frames with their detections and the odometry and IMU samples
between them, and the start pose when it is known: :class:`~azgym.mapping.problem.Drive`) and
what was known beforehand (:class:`~azgym.mapping.problem.Prior`: a map, possibly stale, and the
ids of its surveyed anchors) into a :class:`MapAnswer`: the beacons it places, each with its
covariance, and the prior's beacons it says moved.

What the answer leaves out keeps its prior position: the map a user goes on with is the prior
map updated by the answer (:meth:`MapAnswer.updated`). A mapper that places nothing answers the
prior map unchanged; a beacon the prior lacks and the answer leaves out has no position at all.

Any object with a ``survey`` method of this signature is a mapper (:class:`SupportsSurvey`);
:class:`Mapper` adds keyword-only hyperparameters validated as localizers' are
(:mod:`azgym.hyperparameters`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Sequence
from dataclasses import dataclass
from numbers import Integral
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np

from azgym.core import BeaconMap, FloatArray, IntArray
from azgym.errors import InvalidInputError
from azgym.hyperparameters import Hyperparameters
from azgym.mapping.first_guess import DEFAULT_WIDTH
from azgym.mapping.problem import Drive, Prior

__all__ = ["MAX_BEACONS", "MapAnswer", "Mapper", "SupportsSurvey", "map_answer"]

MAX_BEACONS = 100_000
"""Most beacons an answer may place (a bound on what a plug-in can make the runner hold)."""


@dataclass(frozen=True, eq=False)
class MapAnswer:
    """What a mapper answers (module docstring); checked when made.

    Attributes:
        ids: The beacons it places (N,), distinct.
        xy: Their positions (N, 2) [m], finite.
        covariances: Their covariances (N, 2, 2) [m²], symmetric positive definite.
        moved: Ids of the prior's beacons it says moved (each placed, none an anchor), sorted.
    """

    ids: IntArray
    xy: FloatArray
    covariances: FloatArray
    moved: tuple[int, ...] = ()

    def __post_init__(self) -> None:
        ids = np.asarray(self.ids)
        xy = np.asarray(self.xy, dtype=np.float64)
        cov = np.asarray(self.covariances, dtype=np.float64)
        if ids.ndim != 1 or ids.size > MAX_BEACONS or (
                ids.size and not np.issubdtype(ids.dtype, np.integer)):
            raise InvalidInputError(
                f"MapAnswer.ids must be a 1-D array of at most {MAX_BEACONS} integers, got "
                f"shape {ids.shape} of {ids.dtype}")
        n = ids.size
        if xy.shape != (n, 2):
            raise InvalidInputError(f"MapAnswer.xy must have shape ({n}, 2), got {xy.shape}")
        if cov.shape != (n, 2, 2):
            raise InvalidInputError(
                f"MapAnswer.covariances must have shape ({n}, 2, 2), got {cov.shape}")
        if np.unique(ids).size != n:
            raise InvalidInputError("MapAnswer.ids repeat an id")
        if not np.isfinite(xy).all():
            raise InvalidInputError("MapAnswer.xy holds a NaN or infinite position")
        if not np.isfinite(cov).all() or not np.allclose(cov, cov.transpose(0, 2, 1),
                                                         rtol=1e-9, atol=1e-15):
            raise InvalidInputError("MapAnswer.covariances must be finite and symmetric")
        if n and (np.linalg.eigvalsh(cov)[:, 0] <= 0.0).any():
            raise InvalidInputError("MapAnswer.covariances must be positive definite")
        if not isinstance(self.moved, (tuple, list)) or len(self.moved) > n:
            raise InvalidInputError(
                f"MapAnswer.moved must be a tuple or list of at most {n} ids (those it places), "
                f"got {type(self.moved).__name__}")
        if not all(isinstance(i, Integral) and not isinstance(i, bool) for i in self.moved):
            raise InvalidInputError("MapAnswer.moved must hold integer ids")
        placed = set(ids.tolist())
        stray = [i for i in self.moved if i not in placed]
        if stray:
            raise InvalidInputError(f"MapAnswer.moved names ids it does not place: {stray[:10]}")
        object.__setattr__(self, "ids", ids.astype(np.int64))
        object.__setattr__(self, "xy", xy)
        object.__setattr__(self, "covariances", cov)
        object.__setattr__(self, "moved", tuple(sorted(int(i) for i in self.moved)))

    def updated(self, prior: BeaconMap | None) -> BeaconMap:
        """The prior map updated by the answer: placed beacons where placed, the rest as before.

        A placed beacon keeps the prior's height and width where the prior holds it (else 0 m
        and :data:`DEFAULT_WIDTH`).
        """
        rows = {} if prior is None else {int(i): k for k, i in enumerate(prior.ids.tolist())}
        placed = {int(i): k for k, i in enumerate(self.ids.tolist())}
        ids = sorted(set(rows) | set(placed))
        xyz = np.zeros((len(ids), 3))
        width = np.full(len(ids), DEFAULT_WIDTH)
        for n, beacon in enumerate(ids):
            if beacon in rows and prior is not None:
                xyz[n] = prior.xyz[rows[beacon]]
                width[n] = prior.width[rows[beacon]]
            if beacon in placed:
                xyz[n, :2] = self.xy[placed[beacon]]
        return BeaconMap(np.array(ids, dtype=np.int64), xyz, width)


def map_answer(ids: Sequence[int] | IntArray, xy: FloatArray, covariances: FloatArray,
               moved: Sequence[int] = ()) -> MapAnswer:
    """A :class:`MapAnswer` from plain sequences (each checked)."""
    return MapAnswer(np.asarray(ids), np.asarray(xy, dtype=np.float64).reshape(-1, 2),
                     np.asarray(covariances, dtype=np.float64).reshape(-1, 2, 2),
                     tuple(int(i) for i in moved))


@runtime_checkable
class SupportsSurvey(Protocol):
    """What azgym needs of a mapper: one method. :class:`Mapper` adds validation on top."""

    def survey(self, drive: Drive, prior: Prior) -> MapAnswer:
        """The beacons placed from ``drive``, given ``prior``."""
        ...


class Mapper(Hyperparameters, ABC):
    """Base class of the built-in mappers; subclasses set ``name`` and implement ``_survey``."""

    name: ClassVar[str] = ""

    def survey(self, drive: Drive, prior: Prior) -> MapAnswer:
        """The beacons placed from ``drive``, given ``prior`` (module docstring).

        Raises:
            InvalidInputError: Arguments of the wrong type; a drive the method cannot survey,
                named.
        """
        self._validate_once()
        if not isinstance(drive, Drive):
            raise InvalidInputError(f"drive must be an azgym.mapping.Drive, got "
                                    f"{type(drive).__name__}")
        if not isinstance(prior, Prior):
            raise InvalidInputError(f"prior must be an azgym.mapping.Prior, got "
                                    f"{type(prior).__name__}")
        return self._survey(drive, prior)

    @abstractmethod
    def _survey(self, drive: Drive, prior: Prior) -> MapAnswer:
        """The method itself."""
