"""The built-in mappers: ``survey``, ``rays``, ``prior`` and ``repair`` (docs/mappers.md).

* :class:`SurveyMapper` (``survey``): azgym's bearing-only SLAM (:func:`azgym.mapping.survey`):
  the beacons it finds observable placed with their covariances, the moved ones its own test's.
* :class:`RaysMapper` (``rays``): no graph, each id's rays from the dead-reckoned poses
  intersected (:mod:`azgym.mapping.rays`), moved by the survey's test.
* :class:`PriorMapper` (``prior``): places nothing; the map goes on as the prior had it (the
  null baseline a stale map gives).
* :class:`RepairMapper` (``repair``): robust's map repair (``robust:repair=true``,
  :mod:`azgym.track.repair`) run along the drive from its start on the prior map: the beacons
  it repaired placed where it put them, every one of them moved.

Their hyperparameters are keyword-only and checked when set, as localizers' are; a profile's
fields set those of the same names (:func:`~azgym.mapping.registry.make_mapper`). Every built-in
refuses by name a drive without frames, and one it cannot place (:class:`SurveyMapper` and
:class:`RaysMapper`: no start pose and fewer than two anchors; :class:`RepairMapper`: no start
pose or no prior map).
"""

from __future__ import annotations

import numpy as np

from azgym.core import FloatArray
from azgym.errors import InvalidInputError
from azgym.hyperparameters import check_flag, check_range
from azgym.mapping.base import MapAnswer, Mapper
from azgym.mapping.problem import Drive, Prior, Settings, settings_from_profile
from azgym.mapping.rays import require_frames, survey_by_rays
from azgym.mapping.survey import Survey, survey
from azgym.profile import Profile
from azgym.track.robust import Robust

__all__ = ["PriorMapper", "RaysMapper", "RepairMapper", "SurveyMapper"]

SETTINGS = Settings()
"""The survey's settings as shipped: the defaults of the mappers' hyperparameters."""
NOISE = SETTINGS.noise
NON_NEGATIVE = ("speed_noise", "speed_scale", "scale_walk", "turn_rate_noise", "bias_walk",
                "position_walk", "heading_walk", "max_speed", "max_turn_rate", "delta_alpha_d",
                "extra_sigma")
"""The settings' hyperparameters that are numbers of zero or more."""
POSITIVE = ("wheelbase", "speed_factor", "loss_scale", "map_sigma")
"""... and those that are numbers above zero (the choices
:class:`~azgym.mapping.problem.Settings` checks itself)."""


def _answer(result: Survey) -> MapAnswer:
    """A survey's observable beacons (anchors aside) as an answer, with its moved ones."""
    keep = result.observable & ~np.isin(result.ids, list(result.anchors))
    covariances = result.covariances[keep]
    return MapAnswer(result.ids[keep], result.xy[keep],
                     0.5 * (covariances + covariances.transpose(0, 2, 1)), result.moved)


class _Settled(Mapper):
    """A mapper whose hyperparameters are the survey's settings, checked and made settings.

    They are :class:`Settings`' fields, the motion noise's spelled out.
    """

    def _settings(self) -> Settings:
        params = self.get_params()
        name = type(self).__name__
        for field in NON_NEGATIVE:
            check_range(name, field, params[field], low=0.0)
        for field in POSITIVE:
            if field in params:
                check_range(name, field, params[field], low=0.0, low_open=True)
        if params["start_bias"] is not None:
            check_range(name, "start_bias", params["start_bias"], low=0.0)
        if params["camera_ahead"] is not None:
            check_range(name, "camera_ahead", params["camera_ahead"], low=-10.0, high=10.0)
        check_flag(name, "coverage", params["coverage"])
        try:
            return settings_from_profile(Profile(), **params)
        except InvalidInputError as exc:
            raise InvalidInputError(f"{name}.{exc}") from None

    def _check_params(self) -> None:
        self._settings()


class SurveyMapper(_Settled):
    """azgym's bearing-only SLAM as a mapper (module docstring).

    Args:
        vehicle, yaw_source, camera_ahead, wheelbase, speed_factor, start_bias, delta_alpha_d,
        coverage, extra_sigma, loss, loss_scale, map_sigma: As
            :class:`~azgym.mapping.problem.Settings`.
        speed_noise, speed_scale, scale_walk, turn_rate_noise, bias_walk, position_walk,
        heading_walk, max_speed, max_turn_rate: As :class:`~azgym.track.unicycle.MotionNoise`.
    """

    name = "survey"

    def __init__(self, *, vehicle: str = SETTINGS.vehicle, yaw_source: str | None = None,
                 camera_ahead: float | None = None, wheelbase: float = SETTINGS.wheelbase,
                 speed_factor: float = SETTINGS.speed_factor,
                 speed_noise: float = NOISE.speed_noise, speed_scale: float = NOISE.speed_scale,
                 scale_walk: float = NOISE.scale_walk,
                 turn_rate_noise: float = NOISE.turn_rate_noise,
                 bias_walk: float = NOISE.bias_walk, position_walk: float = NOISE.position_walk,
                 heading_walk: float = NOISE.heading_walk, max_speed: float = NOISE.max_speed,
                 max_turn_rate: float = NOISE.max_turn_rate, start_bias: float | None = None,
                 delta_alpha_d: float = SETTINGS.delta_alpha_d,
                 coverage: bool = SETTINGS.coverage, extra_sigma: float = SETTINGS.extra_sigma,
                 loss: str = SETTINGS.loss, loss_scale: float = SETTINGS.loss_scale,
                 map_sigma: float = SETTINGS.map_sigma) -> None:
        self._take(locals())

    def _survey(self, drive: Drive, prior: Prior) -> MapAnswer:
        require_frames(drive)
        return _answer(survey(drive, prior, self._settings()))


class RaysMapper(_Settled):
    """Each id's rays from the dead-reckoned poses, intersected: no graph (mapping/rays.py).

    Args:
        vehicle, yaw_source, camera_ahead, wheelbase, speed_factor, start_bias, delta_alpha_d,
        coverage, extra_sigma: As :class:`~azgym.mapping.problem.Settings`.
        speed_noise, speed_scale, scale_walk, turn_rate_noise, bias_walk, position_walk,
        heading_walk, max_speed, max_turn_rate: As :class:`~azgym.track.unicycle.MotionNoise`.
    """

    name = "rays"

    def __init__(self, *, vehicle: str = SETTINGS.vehicle, yaw_source: str | None = None,
                 camera_ahead: float | None = None, wheelbase: float = SETTINGS.wheelbase,
                 speed_factor: float = SETTINGS.speed_factor,
                 speed_noise: float = NOISE.speed_noise, speed_scale: float = NOISE.speed_scale,
                 scale_walk: float = NOISE.scale_walk,
                 turn_rate_noise: float = NOISE.turn_rate_noise,
                 bias_walk: float = NOISE.bias_walk, position_walk: float = NOISE.position_walk,
                 heading_walk: float = NOISE.heading_walk, max_speed: float = NOISE.max_speed,
                 max_turn_rate: float = NOISE.max_turn_rate, start_bias: float | None = None,
                 delta_alpha_d: float = SETTINGS.delta_alpha_d,
                 coverage: bool = SETTINGS.coverage,
                 extra_sigma: float = SETTINGS.extra_sigma) -> None:
        self._take(locals())

    def _survey(self, drive: Drive, prior: Prior) -> MapAnswer:
        return _answer(survey_by_rays(drive, prior, self._settings()))


class PriorMapper(Mapper):
    """Places nothing: the prior map goes on unchanged (the null baseline of a stale map)."""

    name = "prior"

    def __init__(self) -> None:
        self._validate_once()

    def _survey(self, drive: Drive, prior: Prior) -> MapAnswer:
        require_frames(drive)
        return MapAnswer(np.zeros(0, np.int64), np.zeros((0, 2)), np.zeros((0, 2, 2)))


class RepairMapper(Mapper):
    """robust's map repair run along the drive from its start on the prior map (module docstring).

    Each hyperparameter is robust's of the same name (None: robust's own default); robust's
    others keep their defaults.

    Args:
        vehicle, yaw_source, camera_ahead, wheelbase, speed_factor, speed_noise, speed_scale,
        scale_walk, turn_rate_noise, bias_walk, position_walk, heading_walk, delta_alpha_d,
        coverage, extra_sigma, repair_sightings, repair_after, repair_span, repair_std: As
        :class:`~azgym.track.robust.Robust`.
    """

    name = "repair"

    def __init__(self, *, vehicle: str | None = None, yaw_source: str | None = None,
                 camera_ahead: float | None = None, wheelbase: float | None = None,
                 speed_factor: float | None = None, speed_noise: float | None = None,
                 speed_scale: float | None = None, scale_walk: float | None = None,
                 turn_rate_noise: float | None = None, bias_walk: float | None = None,
                 position_walk: float | None = None, heading_walk: float | None = None,
                 delta_alpha_d: float | None = None, coverage: bool | None = None,
                 extra_sigma: float | None = None, repair_sightings: int | None = None,
                 repair_after: float | None = None, repair_span: float | None = None,
                 repair_std: float | None = None) -> None:
        self.vehicle, self.yaw_source, self.camera_ahead = vehicle, yaw_source, camera_ahead
        self.wheelbase, self.speed_factor = wheelbase, speed_factor
        self.speed_noise, self.speed_scale, self.scale_walk = speed_noise, speed_scale, scale_walk
        self.turn_rate_noise, self.bias_walk = turn_rate_noise, bias_walk
        self.position_walk, self.heading_walk = position_walk, heading_walk
        self.delta_alpha_d, self.coverage, self.extra_sigma = delta_alpha_d, coverage, extra_sigma
        self.repair_sightings, self.repair_after = repair_sightings, repair_after
        self.repair_span, self.repair_std = repair_span, repair_std
        self._validate_once()

    def _tracker(self) -> Robust:
        """A fresh ``robust:repair=true`` with the hyperparameters given (robust checks them)."""
        given = {name: value for name, value in self.get_params().items() if value is not None}
        return Robust(repair=True, **given)

    def _check_params(self) -> None:
        self._tracker()

    def _survey(self, drive: Drive, prior: Prior) -> MapAnswer:
        require_frames(drive)
        if drive.start is None:
            raise InvalidInputError(f"repair: {drive.name} has no start pose; robust's map "
                                    "repair tracks the drive from a known start")
        if prior.beacons is None:
            raise InvalidInputError("repair: no prior map; robust's map repair tracks on a map "
                                    "and repairs the beacons that moved")
        tracker = self._tracker()
        tracker.reset(seed=0, initial=drive.start)
        for frame in drive.frames:
            tracker.predict(frame.motion)
            tracker.update(frame.measurements, prior.beacons)
        latest = {b: r for b, r in tracker.placed.items() if b not in prior.anchors}
        ids = sorted(latest)
        covariances: FloatArray = np.array([latest[i].covariance for i in ids]).reshape(-1, 2, 2)
        return MapAnswer(np.array(ids, np.int64),
                         np.array([latest[i].new for i in ids]).reshape(-1, 2),
                         0.5 * (covariances + covariances.transpose(0, 2, 1)), tuple(ids))
