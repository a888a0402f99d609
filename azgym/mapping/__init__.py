"""Mapping: the beacons surveyed from a drive, as bearing-only SLAM (docs/mapping.md).

:func:`survey` takes drives (frames with their motion: :func:`simulated_drive`,
:func:`log_drives`), what is known beforehand (:class:`Prior`: a map and its anchors) and the
settings (:class:`Settings`, :func:`settings_from_profile`), and answers every beacon's position
and covariance, or why it is unobservable (:class:`Survey`). gtsam is imported only when a
survey runs (``pip install "azgym[mapping]"``).
"""

from azgym.mapping.problem import (
    Drive,
    Prior,
    Settings,
    SurveyFrame,
    log_drives,
    settings_from_profile,
    simulated_drive,
)
from azgym.mapping.survey import Survey, survey

__all__ = ["Drive", "Prior", "Settings", "Survey", "SurveyFrame", "log_drives",
           "settings_from_profile", "simulated_drive", "survey"]
