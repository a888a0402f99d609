"""Profiles: read from TOML sections, every bad field named, merged, and applied by name."""

from __future__ import annotations

import math
import tomllib

import pytest

from azgym.errors import InvalidInputError
from azgym.profile import (
    MotionProfile,
    Profile,
    SensorProfile,
    VehicleProfile,
    parse_profile,
    profile_defaults,
    profile_toml,
    read_profile,
)
from azgym.site.toml_writer import to_toml

GOOD = """
[vehicle]
kind = "differential-drive"
camera_ahead = 0.1

[sensor]
delta_alpha_d = 0.0087
coverage = false
field_of_view = 1.2

[motion]
speed_factor = 1.1
turn_rate_noise = 0.01
"""


def _parse(text: str) -> tuple[Profile, list[str]]:
    problems: list[str] = []
    return parse_profile(tomllib.loads(text), problems.append), problems


def test_good_profile_reads_every_field() -> None:
    profile, problems = _parse(GOOD)
    assert problems == []
    assert profile == Profile(VehicleProfile("differential-drive", 0.1),
                              SensorProfile(0.0087, False, 1.2),
                              MotionProfile(speed_factor=1.1, turn_rate_noise=0.01))
    assert profile.hyperparameters() == {
        "vehicle": "differential-drive", "camera_ahead": 0.1, "delta_alpha_d": 0.0087,
        "coverage": False, "field_of_view": 1.2, "speed_factor": 1.1, "turn_rate_noise": 0.01}


@pytest.mark.parametrize(("text", "problem"), [
    ("[sensor]\ndelta_alpha_d = 2.0", "sensor.delta_alpha_d: must be in [0, 1.5708) rad"),
    ("[sensor]\ndelta_alpha_d = 'big'", "sensor.delta_alpha_d: must be a finite number [rad]"),
    ("[sensor]\nfield_of_view = 0.0", "sensor.field_of_view: must be in (0, 6.28319] rad"),
    ("[sensor]\ncoverage = 1", "sensor.coverage: must be true or false"),
    ("[sensor]\nnoise = 1", "sensor: unknown key 'noise'"),
    ("[vehicle]\nkind = 'tank'", "vehicle.kind: must be one of 'forklift', 'differential-drive'"),
    ("[vehicle]\nkind = 'differential-drive'\nwheelbase = 1.0", "vehicle.wheelbase: a "
     "differential-drive vehicle has no steering wheelbase"),
    ("[motion]\nspeed_noise = -0.1", "motion.speed_noise: must be in [0, 10] m/s"),
    ("[motion]\nspeed_factor = true", "motion.speed_factor: must be a finite number"),
    ("motion = 3", "motion: must be a table"),
])
def test_each_bad_field_is_named(text: str, problem: str) -> None:
    profile, problems = _parse(text)
    assert len(problems) == 1 and problems[0].startswith(problem), problems
    assert set(profile.hyperparameters()) <= {"vehicle"}  # a field with a problem sets nothing


def test_nan_and_infinity_refused() -> None:
    _, problems = _parse("[motion]\nbias_walk = nan\nscale_walk = inf")
    assert [p.split(":")[0] for p in problems] == ["motion.scale_walk", "motion.bias_walk"]


def test_over_keeps_base_where_left_out() -> None:
    base, _ = _parse(GOOD)
    top, _ = _parse("[sensor]\ndelta_alpha_d = 0.04")
    merged = top.over(base)
    assert merged.sensor == SensorProfile(0.04, False, 1.2)
    assert merged.vehicle == base.vehicle and merged.motion == base.motion


def test_defaults_only_for_accepted_names_and_never_over_the_spec() -> None:
    profile, _ = _parse(GOOD)
    accepted = ("delta_alpha_d", "coverage", "weighted")
    assert profile_defaults(accepted, profile, {}) == {"delta_alpha_d": 0.0087,
                                                       "coverage": False}
    assert profile_defaults(accepted, profile, {"delta_alpha_d": 0.01}) == {"coverage": False}


def test_written_profile_reads_back_bit_for_bit(tmp_path) -> None:
    profile, _ = _parse(GOOD)
    path = tmp_path / "profile.toml"
    path.write_text(to_toml(profile_toml(profile), comment="fitted"))
    assert read_profile(path) == profile


def test_read_profile_refuses_with_every_problem(tmp_path) -> None:
    path = tmp_path / "p.toml"
    path.write_text("[camera]\nx = 1\n[sensor]\ndelta_alpha_d = -1\n")
    with pytest.raises(InvalidInputError) as error:
        read_profile(path)
    assert "camera: unknown section" in str(error.value)
    assert "sensor.delta_alpha_d: must be in" in str(error.value)
    with pytest.raises(InvalidInputError, match="no such file"):
        read_profile(tmp_path / "missing.toml")
    path.write_bytes(b"\xff\xfe")
    with pytest.raises(InvalidInputError, match="not UTF-8"):
        read_profile(path)
    path.write_text("x" * 70_000)
    with pytest.raises(InvalidInputError, match="larger than"):
        read_profile(path)


def test_degrees_mistake_is_caught() -> None:
    """A Δα_d of 2.2 written in degrees is outside [0, π/2] rad."""
    _, problems = _parse(f"[sensor]\ndelta_alpha_d = {2.2:.1f}")
    assert problems and math.radians(2.2) < math.pi / 2


def test_delta_alpha_d_of_a_right_angle_is_refused() -> None:
    """Eq. 1's half-width is below π/2 (the error model and ransac need it so)."""
    _, problems = _parse(f"[sensor]\ndelta_alpha_d = {math.pi / 2!r}")
    assert problems and problems[0].startswith("sensor.delta_alpha_d: must be in [0, 1.5708)")


def test_a_huge_whole_number_is_out_of_range_not_a_crash() -> None:
    """TOML integers are unbounded: 10**400 compares exactly with the bounds (no OverflowError)."""
    _, problems = _parse("[motion]\nspeed_factor = 1" + "0" * 400)
    assert len(problems) == 1 and problems[0].startswith("motion.speed_factor: must be in (0, 10]")
