"""Mapping: the beacons surveyed from a drive, as bearing-only SLAM (docs/mapping.md).

:func:`survey` takes drives (frames with their motion: :func:`simulated_drive`,
:func:`log_drives`), what is known beforehand (:class:`Prior`: a map and its anchors) and the
settings (:class:`Settings`, :func:`settings_from_profile`), and answers every beacon's position
and covariance, or why it is unobservable (:class:`Survey`). gtsam is imported only when a
survey runs (``pip install "azgym[mapping]"``).

A **mapper** is any method that places beacons from one drive (docs/mappers.md): an object with
``survey(drive, prior) -> MapAnswer`` (:class:`SupportsSurvey`; :class:`Mapper` adds checked
hyperparameters), named by a spec (:func:`make_mapper`, :func:`list_mappers`: the built-ins
``survey``, ``rays``, ``prior`` and ``repair``, plug-ins) and checked by :func:`check_mapper`.
"""

from azgym.mapping.base import MapAnswer, Mapper, SupportsSurvey
from azgym.mapping.checks import check_mapper
from azgym.mapping.problem import (
    Drive,
    Prior,
    Settings,
    SurveyFrame,
    log_drives,
    settings_from_profile,
    simulated_drive,
)
from azgym.mapping.registry import list_mappers, make_mapper
from azgym.mapping.survey import Survey, survey

__all__ = ["Drive", "MapAnswer", "Mapper", "Prior", "Settings", "SupportsSurvey", "Survey",
           "SurveyFrame", "check_mapper", "list_mappers", "log_drives", "make_mapper",
           "settings_from_profile", "simulated_drive", "survey"]
