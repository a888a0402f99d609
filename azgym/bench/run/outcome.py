"""One contender's outcome on each case of a run: estimate or not, its errors, its time.

:class:`Outcome` holds what a per-frame results file keeps (a leaderboard entry's); a run's own
outcome, :class:`RunOutcome`, also keeps every estimate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from azgym.metrics import ErrorStats, summarize_errors

__all__ = ["Outcome", "RunOutcome"]


@dataclass
class Outcome:
    """One contender's outcome on each case.

    Attributes:
        ok: Whether it gave an estimate, shape (C,).
        position: Position error [m], NaN without an estimate, shape (C,).
        heading: Absolute heading error [rad], NaN without an estimate, shape (C,).
        micros: Time of the call [µs], NaN when it raised, shape (C,).
        errors: The exception it raised, "" for none, one per case.
    """

    ok: np.ndarray
    position: np.ndarray
    heading: np.ndarray
    micros: np.ndarray
    errors: list[str]

    @classmethod
    def empty(cls, count: int) -> Outcome:
        """No estimate yet on any of ``count`` cases."""
        return Outcome(np.zeros(count, dtype=bool), np.full(count, np.nan),
                       np.full(count, np.nan), np.full(count, np.nan), [""] * count)

    def select(self, which: np.ndarray) -> Outcome:
        """The outcome on some cases: a boolean mask over them, or their indices."""
        index = _indices(which)
        return Outcome(self.ok[index], self.position[index], self.heading[index],
                       self.micros[index], [self.errors[k] for k in index])

    def stats(self) -> ErrorStats[float]:
        """The error statistics (:func:`~azgym.metrics.summarize_errors`)."""
        return summarize_errors(self.position, self.heading, self.ok)


@dataclass
class RunOutcome(Outcome):
    """A run's own outcome: :class:`Outcome` and the estimates.

    Attributes:
        estimate: The estimated pose (x, y, heading), NaN without one, shape (C, 3).
    """

    estimate: np.ndarray

    @classmethod
    def empty(cls, count: int) -> RunOutcome:
        """No estimate yet on any of ``count`` cases."""
        return RunOutcome(**vars(Outcome.empty(count)), estimate=np.full((count, 3), np.nan))

    def select(self, which: np.ndarray) -> RunOutcome:
        """The outcome on some cases: a boolean mask over them, or their indices."""
        return RunOutcome(**vars(super().select(which)),
                          estimate=self.estimate[_indices(which)])


def _indices(which: np.ndarray) -> np.ndarray:
    """The indices of some cases, given as a boolean mask over them or as their indices."""
    return np.flatnonzero(which) if which.dtype == bool else which
