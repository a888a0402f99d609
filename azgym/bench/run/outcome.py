"""One contender's outcome on each case of a run: estimate or not, its errors, its time."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from azgym.metrics import summarize_errors


@dataclass
class Outcome:
    """One contender's outcome on each case.

    Attributes:
        ok: Whether it gave an estimate, shape (C,).
        position: Position error [m], NaN without an estimate, shape (C,).
        heading: Absolute heading error [rad], NaN without an estimate, shape (C,).
        micros: Time of the call [µs], NaN when it raised, shape (C,).
        errors: The exception it raised, "" for none, one per case.
        estimate: The estimated pose (x, y, heading), NaN without one, shape (C, 3); None when
            the outcome was read back from a per-frame file, which keeps only the errors.
    """

    ok: np.ndarray
    position: np.ndarray
    heading: np.ndarray
    micros: np.ndarray
    errors: list[str]
    estimate: np.ndarray | None = None

    @classmethod
    def empty(cls, count: int) -> Outcome:
        """No estimate yet on any of ``count`` cases."""
        return cls(np.zeros(count, dtype=bool), np.full(count, np.nan), np.full(count, np.nan),
                   np.full(count, np.nan), [""] * count, np.full((count, 3), np.nan))

    @classmethod
    def concatenate(cls, parts: Sequence[Outcome]) -> Outcome:
        """The outcomes of consecutive chunks of cases, joined."""
        estimates = [p.estimate for p in parts]
        return cls(*(np.concatenate([getattr(p, key) for p in parts])
                     for key in ("ok", "position", "heading", "micros")),
                   [error for p in parts for error in p.errors],
                   None if any(e is None for e in estimates) else np.concatenate(estimates))

    def select(self, which: np.ndarray) -> Outcome:
        """The outcome on some cases: a boolean mask over them, or their indices."""
        index = np.flatnonzero(which) if which.dtype == bool else which
        return Outcome(self.ok[index], self.position[index], self.heading[index],
                       self.micros[index], [self.errors[k] for k in index],
                       None if self.estimate is None else self.estimate[index])

    def stats(self) -> dict[str, Any]:
        """The error statistics (:func:`~azgym.metrics.summarize_errors`)."""
        return summarize_errors(self.position, self.heading, self.ok)
