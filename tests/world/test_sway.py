"""The camera's sway: a damped mast shaken on bumps (azgym.world.sway)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from azgym import InvalidInputError
from azgym.site import parse_scenario
from azgym.world.forklift import ForkliftSpec
from azgym.world.sway import CameraSway

TILT = math.radians(2.0)


def bumpy_floor():
    """A floor with one bump of 2° tilt over x in [-10, 10]."""
    return parse_scenario({
        "name": "bumpy", "description": "a bump", "version": 1,
        "room": {"bounds": [-20.0, -20.0, 20.0, 20.0]},
        "beacons": [{"id": k, "xyz": [-19.0, -19.0 + k, 4.0]} for k in range(3)],
        "bumps": [{"center": [0.0, 0.0], "size": [20.0, 20.0], "tilt_deg": 2.0}],
    }, "bumpy.toml")


def sway_on_bump(frames, rate_hz=30.0, seed=0):
    sway = CameraSway(bumpy_floor(), 1.0 / rate_hz)
    rng = np.random.default_rng(seed)
    return np.array([sway.step(0.0, 0.0, rng) for _ in range(frames)])


def test_on_a_long_bump_pitch_and_roll_spread_by_the_bumps_tilt():
    tilts = sway_on_bump(60_000)[300:]  # past the first second's build-up
    assert np.std(tilts, axis=0) == pytest.approx([TILT, TILT], rel=0.05)
    assert abs(np.corrcoef(tilts.T)[0, 1]) < 0.05  # pitch and roll are independent


def test_frame_to_frame_changes_follow_the_oscillators_autocorrelation():
    # Stationary autocorrelation of x'' + 2ζω x' + ω² x = noise, at lag T:
    # ρ(T) = exp(-ζωT) (cos ω_d T + ζ / sqrt(1 - ζ²) sin ω_d T), ω_d = ω sqrt(1 - ζ²);
    # so Var(x[k+1] - x[k]) = 2 tilt² (1 - ρ(T)).
    spec = ForkliftSpec()
    omega, zeta, lag = 2 * math.pi * spec.sway_hz, spec.sway_damping, 1 / 30
    damped = omega * math.sqrt(1 - zeta**2)
    rho = math.exp(-zeta * omega * lag) * (math.cos(damped * lag)
                                           + zeta / math.sqrt(1 - zeta**2)
                                           * math.sin(damped * lag))
    steps = np.diff(sway_on_bump(60_000)[300:], axis=0)
    expected = TILT * math.sqrt(2 * (1 - rho))
    assert np.std(steps, axis=0) == pytest.approx([expected, expected], rel=0.05)
    assert expected < 0.5 * TILT  # far below independent draws' sqrt(2) tilt


def test_off_the_bump_the_sway_rings_down_without_drawing_numbers():
    sway = CameraSway(bumpy_floor(), 1.0 / 30.0)
    rng = np.random.default_rng(1)
    for _ in range(90):
        sway.step(0.0, 0.0, rng)
    state = rng.bit_generator.state
    off = np.array([sway.step(15.0, 0.0, rng) for _ in range(90)])  # 3 s past the bump
    assert rng.bit_generator.state == state
    assert np.abs(off[-15:]).max() < 1e-3 * TILT  # envelope exp(-ζω t) ≈ 1e-5 after 2.5 s
    sway.reset()
    assert sway.step(15.0, 0.0, rng) == (0.0, 0.0)


def test_a_still_camera_starts_level_and_the_sway_builds_up_within_a_second():
    runs = np.array([sway_on_bump(30, seed=seed) for seed in range(1000)])  # (run, frame, axis)
    spread = runs.std(axis=0).mean(axis=1)  # per frame, over runs
    assert spread[0] < 0.3 * TILT
    assert spread[-1] == pytest.approx(TILT, rel=0.1)


def test_the_same_seed_gives_the_same_sway():
    assert np.array_equal(sway_on_bump(200, seed=5), sway_on_bump(200, seed=5))


@pytest.mark.parametrize("field", ["sway_hz", "sway_damping"])
def test_a_non_positive_sway_setting_is_refused_by_name(field):
    with pytest.raises(InvalidInputError, match=field):
        ForkliftSpec(**{field: 0.0})


def test_a_non_positive_frame_period_is_refused():
    with pytest.raises(InvalidInputError, match="frame_period"):
        CameraSway(bumpy_floor(), 0.0)
