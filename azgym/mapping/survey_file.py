"""``survey.csv`` read back: the observable beacons of a survey with their covariances, checked.

``azgym survey`` writes the table (:func:`azgym.mapping.output.survey_csv`): one row per id
detected, with ``x``, ``y``, the covariance ``sxx``, ``sxy``, ``syy`` [m²] and ``observable``
(1 or 0; an unobservable beacon's numbers are empty). :func:`read_survey` reads it as a user's
file, every problem named with its line and field.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from azgym.core import FloatArray, IntArray
from azgym.errors import InvalidInputError
from azgym.mapping.output import SURVEY_FILE
from azgym.untrusted import read_regular_file

__all__ = ["MAX_SURVEY_BYTES", "SurveyedMap", "read_survey"]

MAX_SURVEY_BYTES = 16 * 2**20
"""The largest ``survey.csv`` read (a row is under 100 bytes: far beyond any site)."""
_COLUMNS = ("id", "x", "y", "sxx", "sxy", "syy", "observable")
_COVARIANCE_TOLERANCE = 1e-9
"""How far below zero det Σ_b may be (relative to sxx·syy) for rounding in the file."""


@dataclass(frozen=True)
class SurveyedMap:
    """The observable beacons of a survey and the ids it could not place.

    Attributes:
        ids: Observable beacons' ids, shape (B,).
        xy: Their surveyed positions, shape (B, 2) [m].
        covariance: Their position covariances Σ_b, shape (B, 2, 2) [m²].
        unobservable: Ids detected but not surveyed, ascending.
    """

    ids: IntArray
    xy: FloatArray
    covariance: FloatArray
    unobservable: tuple[int, ...]


def read_survey(folder: Path, option: str = "--survey") -> SurveyedMap:
    """``folder/survey.csv`` as :class:`SurveyedMap`; a malformed table is a named error.

    ``folder`` may also be the ``survey.csv`` file itself. It is read as an untrusted file (a
    regular file, without blocking, at most :data:`MAX_SURVEY_BYTES`); ``option`` names it in
    the messages.
    """
    path = folder / SURVEY_FILE if folder.is_dir() else folder
    where = f"{option} {path}"
    data = read_regular_file(path, MAX_SURVEY_BYTES, "survey table",
                             lambda message: InvalidInputError(f"{option}: {message}"))
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise InvalidInputError(f"{where}: not UTF-8 text") from None
    rows = csv.DictReader(io.StringIO(text))
    missing = [c for c in _COLUMNS if c not in (rows.fieldnames or ())]
    if missing:
        raise InvalidInputError(f"{where}: no column {', '.join(missing)} (a survey.csv of "
                                "azgym survey has id, x, y, sxx, sxy, syy, observable)")
    ids: list[int] = []
    xy: list[tuple[float, float]] = []
    covariance: list[list[list[float]]] = []
    unobservable: list[int] = []
    seen: set[int] = set()
    try:
        for row in rows:
            line = f"{where} line {rows.line_num}"
            beacon = _integer(row["id"], f"{line}, id")
            if beacon in seen:
                raise InvalidInputError(f"{line}: id {beacon} is listed twice")
            seen.add(beacon)
            observable = row["observable"]
            if observable not in ("0", "1"):
                raise InvalidInputError(f"{line}: observable must be 0 or 1, got {observable!r}")
            if observable == "0":
                unobservable.append(beacon)
                continue
            x, y, sxx, sxy, syy = (_number(row[c], f"{line}, {c}")
                                   for c in ("x", "y", "sxx", "sxy", "syy"))
            if sxx < 0 or syy < 0 or sxx * syy - sxy * sxy < -_COVARIANCE_TOLERANCE * sxx * syy:
                raise InvalidInputError(f"{line}: the covariance of id {beacon} (sxx {sxx:g}, "
                                        f"sxy {sxy:g}, syy {syy:g}) is not positive semidefinite")
            ids.append(beacon)
            xy.append((x, y))
            covariance.append([[sxx, sxy], [sxy, syy]])
    except csv.Error as error:
        raise InvalidInputError(f"{where} line {rows.line_num}: {error}") from None
    return SurveyedMap(np.array(ids, dtype=np.int64), np.array(xy, dtype=float).reshape(-1, 2),
                       np.array(covariance, dtype=float).reshape(-1, 2, 2),
                       tuple(sorted(unobservable)))


def _integer(text: str | None, field: str) -> int:
    """A whole number field of the table."""
    try:
        return int(text or "")
    except ValueError:
        raise InvalidInputError(f"{field} must be an integer, got {text!r}") from None


def _number(text: str | None, field: str) -> float:
    """A finite number field of the table."""
    try:
        value = float(text or "")
    except ValueError:
        raise InvalidInputError(f"{field} must be a number, got {text!r}") from None
    if not math.isfinite(value):
        raise InvalidInputError(f"{field} must be finite, got {text!r}")
    return value
