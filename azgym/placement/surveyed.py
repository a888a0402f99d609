"""A surveyed map for the layout analysis: the scenario's beacons a survey placed.

``survey.csv`` is read by :func:`azgym.mapping.survey_file.read_survey`. The analysis takes the
scenario's beacons that the survey placed (observable) with their covariances; every other
beacon of the scenario (unobservable, or never detected) is absent from the surveyed map, so a
localizer cannot use it and the prediction leaves it out. An id the scenario does not have is
refused: the survey is not of this site. The kept beacons stay at the scenario's places: the
geometry (visibility, distances) is the site's, and the surveyed places differ from it by the
very error the covariance describes. Taking the surveyed places instead would let a millimetre
of that error put a wall-mounted beacon behind its wall, out of every cell's sight. A beacon the
survey found moved is therefore analysed where the scenario puts it.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from azgym.core import FloatArray
from azgym.errors import InvalidInputError
from azgym.mapping.survey_file import SurveyedMap
from azgym.site import Scenario

__all__ = ["surveyed_scenario"]


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
