"""Sensor, vehicle and motion profiles: what a recording's camera and vehicle are like, in numbers.

A profile says how noisy a camera's azimuths are (eq. 1-3's parameters) and how wide it sees,
what kind of vehicle carries it and where, and how its odometry and turn-rate sensor err. Every
localizer and tracker takes its defaults from a profile when one is given: a log's manifest
holds one (its ``[vehicle]``, ``[sensor]`` and ``[motion]`` sections), ``azgym calibrate``
fits one from a log with truth, and ``azgym bench --profile PROFILE.toml`` applies one.

A field's name is the name of the hyperparameter it sets (``delta_alpha_d`` is ransac's
``delta_alpha_d``), so one name means one thing everywhere. A field left out sets nothing: the
contender keeps its own default. A hyperparameter written in a contender's spec always wins over
a profile's value (:func:`profile_defaults`).

The TOML form (docs/logs.md)::

    [vehicle]
    kind = "differential-drive"   # or "forklift"
    camera_ahead = 0.0            # the camera's offset ahead of the turning axis [m]

    [sensor]
    delta_alpha_d = 0.0087        # eq. 1's half-width Δα_d [rad]
    coverage = false              # whether eq. 2's coverage error applies
    field_of_view = 1.2           # the camera's full horizontal view [rad]; 2π: all round

    [motion]
    speed_factor = 1.0            # true / read distance of the odometry
    speed_noise = 0.02            # white noise of one speed sample [m/s]
    turn_rate_noise = 0.005       # white noise of one turn-rate sample [rad/s]
"""

from __future__ import annotations

import math
import tomllib
from collections.abc import Callable
from dataclasses import dataclass, fields, replace
from pathlib import Path
from typing import Any

from azgym.errors import InvalidInputError
from azgym.fields import FLAG, Fields, Number

__all__ = ["VEHICLE_KINDS", "MotionProfile", "Profile", "SensorProfile", "VehicleProfile",
           "field_texts", "parse_profile", "profile_defaults", "profile_toml",
           "read_profile"]

FORKLIFT = "forklift"
"""A steered vehicle: odometry reports speed and steering angle (the bicycle model)."""
DIFFERENTIAL_DRIVE = "differential-drive"
"""A vehicle turning on the spot: odometry reports speed and turn rate (the unicycle model)."""
VEHICLE_KINDS = (FORKLIFT, DIFFERENTIAL_DRIVE)
"""The kinds of vehicle azgym models."""
MAX_PROFILE_BYTES = 64 * 1024
"""The largest profile file read [bytes]."""


@dataclass(frozen=True)
class VehicleProfile:
    """The vehicle and where its camera sits on it.

    Attributes:
        kind: One of :data:`VEHICLE_KINDS` (sets a tracker's ``vehicle``).
        camera_ahead: The camera's offset ahead of the turning axis along the heading [m]
            (negative: behind it); a tracker's lever arm.
        wheelbase: A steered vehicle's wheelbase [m] (turn rate = speed · tan(steer) / wheelbase).
    """

    kind: str | None = None
    camera_ahead: float | None = None
    wheelbase: float | None = None


@dataclass(frozen=True)
class SensorProfile:
    """The camera's azimuth errors (eq. 1-3) and view.

    Attributes:
        delta_alpha_d: Half-width Δα_d of the centre-detection error [rad] (eq. 1).
        coverage: Whether eq. 2's coverage error (half a beacon's width) applies.
        field_of_view: The camera's full horizontal view, centred on its axis [rad]; 2π: all
            round.
    """

    delta_alpha_d: float | None = None
    coverage: bool | None = None
    field_of_view: float | None = None


@dataclass(frozen=True)
class MotionProfile:
    """How the vehicle's motion sensors err (a tracker's process noise).

    Attributes:
        speed_factor: True distance over the distance the odometry reads [1] (its mean scale).
        speed_noise: White noise of one odometry speed sample [m/s].
        speed_scale: Standard deviation of the odometry's scale error at the start [1].
        scale_walk: Random walk of that scale error [1/√s].
        turn_rate_noise: White noise of one turn-rate sample (gyro or odometry) [rad/s].
        bias_walk: Random walk of the turn rate's bias [rad/s/√s].
        heading_walk: Model error of the heading [rad/√s].
        position_walk: Model error of the position [m/√s].
    """

    speed_factor: float | None = None
    speed_noise: float | None = None
    speed_scale: float | None = None
    scale_walk: float | None = None
    turn_rate_noise: float | None = None
    bias_walk: float | None = None
    heading_walk: float | None = None
    position_walk: float | None = None


@dataclass(frozen=True)
class Profile:
    """A vehicle, sensor and motion profile (module docstring); every field optional."""

    vehicle: VehicleProfile = VehicleProfile()
    sensor: SensorProfile = SensorProfile()
    motion: MotionProfile = MotionProfile()

    def hyperparameters(self) -> dict[str, Any]:
        """Every field given, by the hyperparameter name it sets (``kind`` sets ``vehicle``)."""
        values: dict[str, Any] = {}
        for section in (self.vehicle, self.sensor, self.motion):
            for field in fields(section):
                value = getattr(section, field.name)
                if value is not None:
                    values["vehicle" if field.name == "kind" else field.name] = value
        return values

    def over(self, base: Profile) -> Profile:
        """This profile's fields, and ``base``'s where this one leaves a field out."""
        sections = {}
        for name in ("vehicle", "sensor", "motion"):
            mine, theirs = getattr(self, name), getattr(base, name)
            given = {f.name: getattr(mine, f.name) for f in fields(mine)
                     if getattr(mine, f.name) is not None}
            sections[name] = replace(theirs, **given)
        return Profile(**sections)

    @property
    def empty(self) -> bool:
        """Whether no field is given."""
        return not self.hyperparameters()


_NUMBERS: dict[str, dict[str, Number]] = {
    "vehicle": {"camera_ahead": Number(-10.0, 10.0, unit="m"),
                "wheelbase": Number(0.0, 20.0, low_open=True, unit="m")},
    "sensor": {"delta_alpha_d": Number(0.0, math.pi / 2, high_open=True, unit="rad"),
               "field_of_view": Number(0.0, 2 * math.pi, low_open=True, unit="rad")},
    "motion": {"speed_factor": Number(0.0, 10.0, low_open=True),
               "speed_noise": Number(0.0, 10.0, unit="m/s"),
               "speed_scale": Number(0.0, 1.0),
               "scale_walk": Number(0.0, 1.0, unit="1/√s"),
               "turn_rate_noise": Number(0.0, 10.0, unit="rad/s"),
               "bias_walk": Number(0.0, 1.0, unit="rad/s/√s"),
               "heading_walk": Number(0.0, 10.0, unit="rad/√s"),
               "position_walk": Number(0.0, 10.0, unit="m/√s")},
}
"""Each number's rule (its bounds are what makes physical sense; each has both, so no cap)."""
_OTHER = {"vehicle": {"kind"}, "sensor": {"coverage"}, "motion": set()}
SECTIONS = tuple(_NUMBERS)
"""The TOML sections a profile is read from."""


def parse_profile(data: dict[str, Any], report: Callable[[str], None]) -> Profile:
    """The profile in parsed TOML's ``[vehicle]``, ``[sensor]`` and ``[motion]`` sections.

    Other top-level keys are not looked at (a log's manifest holds more). Each problem is passed
    to ``report`` as ``section.field: what is wrong``; a field with a problem is left out.
    """
    read = Fields(report=report)
    sections: dict[str, dict[str, Any]] = {}
    for section in SECTIONS:
        given = data.get(section, {})
        if not isinstance(given, dict):
            report(f"{section}: must be a table ([{section}])")
            given = {}
        read.keys(given, set(_NUMBERS[section]) | _OTHER[section], section)
        values: dict[str, Any] = {}
        for key, rule in _NUMBERS[section].items():
            if key in given and read.check(given[key], f"{section}.{key}", rule):
                values[key] = float(given[key])
        sections[section] = values
    vehicle, sensor = data.get("vehicle"), data.get("sensor")
    kind = vehicle.get("kind") if isinstance(vehicle, dict) else None
    if kind is not None and kind not in VEHICLE_KINDS:
        report(f"vehicle.kind: must be one of {', '.join(map(repr, VEHICLE_KINDS))}, got "
               f"{kind!r}")
    elif kind is not None:
        sections["vehicle"]["kind"] = kind
    coverage = sensor.get("coverage") if isinstance(sensor, dict) else None
    if coverage is not None and read.check(coverage, "sensor.coverage", FLAG):
        sections["sensor"]["coverage"] = coverage
    if sections["vehicle"].get("kind") == DIFFERENTIAL_DRIVE and \
            sections["vehicle"].pop("wheelbase", None) is not None:
        report("vehicle.wheelbase: a differential-drive vehicle has no steering wheelbase")
    return Profile(VehicleProfile(**sections["vehicle"]), SensorProfile(**sections["sensor"]),
                   MotionProfile(**sections["motion"]))


def read_profile(path: str | Path) -> Profile:
    """Read a profile file (``PROFILE.toml``: the sections above and nothing else).

    Raises:
        InvalidInputError: The file is missing, too large, not TOML, or holds bad fields (every
            problem listed, each naming its field).
    """
    path = Path(path)
    if not path.is_file():
        raise InvalidInputError(f"profile {str(path)!r}: no such file")
    with path.open("rb") as stream:
        raw = stream.read(MAX_PROFILE_BYTES + 1)
    if len(raw) > MAX_PROFILE_BYTES:
        raise InvalidInputError(f"profile {str(path)!r}: larger than {MAX_PROFILE_BYTES} bytes")
    try:
        data = tomllib.loads(raw.decode("utf-8"))
    except UnicodeDecodeError as exc:
        raise InvalidInputError(f"profile {str(path)!r}: not UTF-8 text (byte offset "
                                f"{exc.start})") from None
    except (tomllib.TOMLDecodeError, RecursionError) as exc:
        raise InvalidInputError(f"profile {str(path)!r}: not valid TOML: {exc}") from None
    problems = [f"{key}: unknown section (known: {', '.join(SECTIONS)})"
                for key in sorted(set(data) - set(SECTIONS))]
    profile = parse_profile(data, problems.append)
    if problems:
        raise InvalidInputError(f"profile {str(path)!r}:\n" + "\n".join(
            f"  {problem}" for problem in problems))
    return profile


def profile_toml(profile: Profile) -> dict[str, dict[str, Any]]:
    """The profile as TOML data (the sections of the fields given), for ``to_toml``."""
    data: dict[str, dict[str, Any]] = {}
    for name in SECTIONS:
        section = getattr(profile, name)
        given = {f.name: getattr(section, f.name) for f in fields(section)
                 if getattr(section, f.name) is not None}
        if given:
            data[name] = given
    return data


def field_texts(data: dict[str, dict[str, Any]]) -> dict[str, str]:
    """Each field of a profile's TOML data (:func:`profile_toml`) as ``section.field=value``.

    Keyed by ``section.field``; a flag is written ``true``/``false``, a number to 6 digits.
    """
    def written(value: Any) -> str:
        if isinstance(value, bool):
            return str(value).lower()
        return f"{value:g}" if isinstance(value, float) else str(value)

    return {f"{section}.{name}": f"{section}.{name}={written(value)}"
            for section, values in data.items() for name, value in values.items()}


def profile_defaults(accepted: tuple[str, ...], profile: Profile, given: dict[str, Any]
                     ) -> dict[str, Any]:
    """The hyperparameters a profile sets for a class: those it accepts and ``given`` leaves out.

    Args:
        accepted: The class's hyperparameter names (its keyword-only ``__init__`` arguments).
        profile: The profile.
        given: The hyperparameters the contender's spec writes (these win).
    """
    return {key: value for key, value in profile.hyperparameters().items()
            if key in accepted and key not in given}
