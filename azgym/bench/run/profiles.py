"""A profile in a benchmark: the contenders' defaults, and the simulator's sensor and motion noise.

A profile (:mod:`azgym.profile`) says what a camera and a vehicle are like. ``azgym bench
--profile PROFILE.toml`` applies it twice:

- **to every contender**: each hyperparameter the profile gives becomes the contender's default
  (:func:`contender_params`), where its class takes a hyperparameter of that name; one its spec
  writes wins (:func:`~azgym.localize.registry.profile_params`: a mapper's the same). This runs
  where the contender's class is resolved, in its worker process: the runner never imports a
  plug-in.
- **to a suite's simulator** (:class:`SimulatedNoise`): the camera's azimuth noise (eq. 1-3)
  and the odometry's and gyro's noise are drawn as the profile says, so a site's simulated
  figures can be set beside its real ones. A suite lists the fields its simulator takes
  (``Suite.simulates``); the others set the contenders' defaults only.

What a profile field sets in the simulator (as shipped where it is left out):

==========================  =============================================================
``sensor.delta_alpha_d``    the scenario's :class:`~azgym.site.error_model.ErrorModel`
``sensor.coverage``         the same (eq. 2; a geometry sensor draws it from occlusion)
``motion.speed_factor``     the odometry reads 1/speed_factor of the distance driven
``motion.speed_noise``      :class:`~azgym.sensing.motion.OdometryModel` ``speed_noise``
``motion.scale_walk``       :class:`~azgym.sensing.motion.OdometryModel` ``scale_walk``
``motion.turn_rate_noise``  :class:`~azgym.sensing.motion.ImuModel` ``gyro_noise``
``motion.bias_walk``        :class:`~azgym.sensing.motion.ImuModel` ``gyro_bias_walk``
==========================  =============================================================

A differential drive's odometry takes the motion fields of the same names
(:meth:`SimulatedNoise.differential_odometry`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Collection
from dataclasses import dataclass
from typing import Any

from azgym.localize.registry import parse_spec, profile_params, resolve
from azgym.profile import Profile, field_texts, profile_toml
from azgym.sensing.motion import DifferentialOdometryModel, ImuModel, Motion, OdometryModel
from azgym.site import Scenario
from azgym.site.error_model import ErrorModel

__all__ = ["AS_SHIPPED", "DIFFERENTIAL_MOTION_NOISE", "MOTION_NOISE", "SENSOR_NOISE",
           "SimulatedNoise", "contender_params", "describe_profile"]

SENSOR_NOISE = ("sensor.delta_alpha_d", "sensor.coverage")
"""The profile fields a simulated camera's azimuth noise takes."""
MOTION_NOISE = ("motion.speed_factor", "motion.speed_noise", "motion.scale_walk",
                "motion.turn_rate_noise", "motion.bias_walk")
"""The profile fields the simulated odometry's and gyro's noise take (a forklift's)."""
DIFFERENTIAL_MOTION_NOISE = ("motion.speed_factor", "motion.speed_scale", "motion.speed_noise",
                             "motion.turn_rate_noise", "motion.bias_walk")
"""The profile fields a differential drive's simulated odometry takes
(:meth:`SimulatedNoise.differential_odometry`)."""


def contender_params(spec: str, params: dict[str, Any], profile: Profile | None
                     ) -> dict[str, Any]:
    """The hyperparameters a contender is built with: ``params``, and a profile's under them.

    The class the spec names is resolved (a preset's class; a localizer's own class, not the
    tracker that wraps it), so call this where the contender runs, never in the runner: a
    plug-in's module runs its code when imported. A hyperparameter the spec writes, inline or
    in ``params``, wins over the profile's.

    Args:
        spec: The contender's spec.
        params: The hyperparameters given beside it.
        profile: The profile (None: none).
    """
    if profile is None or profile.empty:
        return params
    target, inline = parse_spec(spec)
    return {**profile_params(resolve(target), {**inline, **params}, profile), **params}


def describe_profile(profile: Profile, simulated: Collection[str] | None = None) -> str:
    """A profile in one line, ``section.field=value`` each; with ``simulated``, who takes them.

    Args:
        profile: The profile.
        simulated: The fields a suite's simulator takes (None: no simulator, a log's run).
    """
    written = field_texts(profile_toml(profile))
    if not written:
        return "profile: empty (every default as shipped)"
    if simulated is None:
        return f"profile: {', '.join(written.values())} (the contenders' defaults)"
    parts = []
    both = [text for key, text in written.items() if key in simulated]
    only = [text for key, text in written.items() if key not in simulated]
    if both:
        parts.append(f"{', '.join(both)} (simulated, and the contenders' defaults)")
    if only:
        parts.append(f"{', '.join(only)} (the contenders' defaults only: not simulated)")
    return f"profile: {'; '.join(parts)}"


@dataclass(frozen=True)
class SimulatedNoise:
    """The simulator's sensor and motion noise as a profile sets it (module docstring).

    A field the profile leaves out keeps the model's own value, so ``SimulatedNoise()`` draws
    exactly what the simulator draws as shipped.

    Attributes:
        profile: The profile.
    """

    profile: Profile = Profile()

    def scenario(self, scenario: Scenario) -> Scenario:
        """The scenario with the profile's azimuth noise (eq. 1-3)."""
        sensor = self.profile.sensor
        if sensor.delta_alpha_d is None and sensor.coverage is None:
            return scenario
        model = scenario.error_model
        return dataclasses.replace(scenario, error_model=ErrorModel(
            delta_alpha_d=model.delta_alpha_d if sensor.delta_alpha_d is None
            else sensor.delta_alpha_d,
            coverage=model.coverage if sensor.coverage is None else sensor.coverage))

    def odometry(self, base: OdometryModel | None = None) -> OdometryModel | None:
        """The odometry's errors: the profile's speed noise and scale walk over ``base``'s.

        None when the profile sets none of them (the simulator's own model, as shipped). The
        speed noise is drawn ``speed_factor`` times larger, so that once :meth:`read` divides
        the speeds by the factor it is the profile's (or ``base``'s).

        Args:
            base: The model the profile's fields go over (default: :class:`OdometryModel`).
        """
        motion = self.profile.motion
        if motion.speed_noise is None and motion.scale_walk is None and \
                motion.speed_factor is None:
            return base
        base = OdometryModel() if base is None else base
        noise = base.speed_noise if motion.speed_noise is None else motion.speed_noise
        return dataclasses.replace(
            base, speed_noise=noise * self._speed_factor,
            scale_walk=base.scale_walk if motion.scale_walk is None else motion.scale_walk)

    def imu(self, base: ImuModel | None = None) -> ImuModel | None:
        """The gyro's errors: the profile's turn-rate noise and bias walk over ``base``'s.

        None when the profile sets neither (the simulator's own model, as shipped).

        Args:
            base: The model the profile's fields go over (default: :class:`ImuModel`).
        """
        motion = self.profile.motion
        if motion.turn_rate_noise is None and motion.bias_walk is None:
            return base
        base = ImuModel() if base is None else base
        return dataclasses.replace(
            base,
            gyro_noise=base.gyro_noise if motion.turn_rate_noise is None
            else motion.turn_rate_noise,
            gyro_bias_walk=base.gyro_bias_walk if motion.bias_walk is None else motion.bias_walk)

    def differential_odometry(self, base: DifferentialOdometryModel
                              ) -> DifferentialOdometryModel:
        """A differential drive's odometry model with the profile's motion fields over ``base``'s.

        Each motion field the profile gives sets the model's field of the same name
        (``speed_factor``, ``speed_scale``, ``speed_noise``, ``turn_rate_noise``, ``bias_walk``).
        """
        names = {field.name for field in dataclasses.fields(base)}
        given = {name: value for name, value in dataclasses.asdict(self.profile.motion).items()
                 if value is not None and name in names}
        return dataclasses.replace(base, **given)

    def read(self, motion: Motion | None) -> Motion | None:
        """What a forklift's odometry reads: each speed sample over ``speed_factor`` (true/read).

        :class:`~azgym.sensing.motion.OdometryModel` has no speed factor of its own, so it is
        applied to the samples drawn. A differential drive's samples (they report the turn
        rate) are left as they are: their model applies its ``speed_factor`` itself
        (:meth:`differential_odometry`).
        """
        if motion is None or self._speed_factor == 1.0 or motion.odometry.reports_yaw_rate:
            return motion
        odometry = dataclasses.replace(motion.odometry,
                                       speed=motion.odometry.speed / self._speed_factor)
        return dataclasses.replace(motion, odometry=odometry)

    @property
    def _speed_factor(self) -> float:
        factor = self.profile.motion.speed_factor
        return 1.0 if factor is None else factor


AS_SHIPPED = SimulatedNoise()
"""The simulator's noise as shipped (no profile)."""
