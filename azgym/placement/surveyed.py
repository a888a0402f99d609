"""A surveyed map for the layout analysis: ``survey.csv``'s beacons and covariances, checked.

``azgym survey`` writes ``survey.csv`` (:mod:`azgym.mapping.output`): one row per id detected,
with ``x``, ``y``, the covariance ``sxx``, ``sxy``, ``syy`` [m²] and ``observable`` (1 or 0; an
unobservable beacon's numbers are empty). The analysis takes the scenario's beacons that the
survey placed (observable) with their covariances; every other beacon of the scenario
(unobservable, or never detected) is absent from the surveyed map, so a localizer cannot use it
and the prediction leaves it out. An id the scenario does not have is refused: the survey is
not of this site. The kept beacons stay at the scenario's places: the geometry (visibility,
distances) is the site's, and the surveyed places differ from it by the very error the
covariance describes. Taking the surveyed places instead would let a millimetre of that error
put a wall-mounted beacon behind its wall, out of every cell's sight. A beacon the survey found
moved is therefore analysed where the scenario puts it.
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from azgym.core import FloatArray, IntArray
from azgym.errors import InvalidInputError
from azgym.site import Scenario

__all__ = ["MAX_SURVEY_BYTES", "SurveyedMap", "read_survey", "surveyed_scenario"]

MAX_SURVEY_BYTES = 16 * 2**20
"""The largest ``survey.csv`` read (a row is under 100 bytes: far beyond any site)."""
SURVEY_NAME = "survey.csv"
"""The table's name in a survey's output folder."""
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


def read_survey(folder: Path) -> SurveyedMap:
    """``folder/survey.csv`` as :class:`SurveyedMap`; a malformed table is a named error.

    ``folder`` may also be the ``survey.csv`` file itself.
    """
    path = folder / SURVEY_NAME if folder.is_dir() else folder
    where = f"--survey {path}"
    try:
        with path.open("rb") as stream:
            data = stream.read(MAX_SURVEY_BYTES + 1)
    except OSError as error:
        raise InvalidInputError(f"{where}: cannot be read ({error.strerror or error})") from None
    if len(data) > MAX_SURVEY_BYTES:
        raise InvalidInputError(f"{where}: larger than {MAX_SURVEY_BYTES} bytes")
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


def surveyed_scenario(scenario: Scenario,
                      surveyed: SurveyedMap) -> tuple[Scenario, FloatArray, tuple[int, ...]]:
    """The scenario with only the surveyed beacons, their covariances in its order, the absent.

    Returns:
        The scenario keeping the beacons the survey placed (at the scenario's places), Σ_b of
        each, shape (B, 2, 2), and the scenario's ids absent from the surveyed map (unobservable
        or never detected), ascending.

    Raises:
        InvalidInputError: An id of the survey is not in the scenario, or it places none of the
            scenario's beacons.
    """
    beacons = scenario.beacons
    known = set(beacons.ids.tolist())
    foreign = sorted({*surveyed.ids.tolist(), *surveyed.unobservable} - known)
    if foreign:
        raise InvalidInputError(f"--survey: ids {foreign} are not beacons of {scenario.name!r}; "
                                "is the survey of another site?")
    keep = np.isin(beacons.ids, surveyed.ids)
    if not keep.any():
        raise InvalidInputError(f"--survey: it places none of the beacons of {scenario.name!r}")
    order = {beacon: k for k, beacon in enumerate(surveyed.ids.tolist())}
    covariance = surveyed.covariance[[order[b] for b in beacons.ids[keep].tolist()]]
    absent = tuple(sorted(beacons.ids[~keep].tolist()))
    kept = type(beacons)(beacons.ids[keep], beacons.xyz[keep], beacons.width[keep])
    physical = None if scenario.physical_xyz is None else scenario.physical_xyz[keep]
    return replace(scenario, beacons=kept, physical_xyz=physical), covariance, absent


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
