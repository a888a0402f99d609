"""A log simulated with known noise, exactly as ``azgym calibrate``'s models state it.

A vehicle drives a wandering loop among 16 beacons with the exact kinematics of a unicycle
(speed and turn rate constant over each 20 ms step, the camera ``camera_ahead`` ahead of the
turning axis); its odometry and gyro are azgym's :class:`~azgym.sensing.motion.Odometer` and
:class:`~azgym.sensing.motion.Imu`, fed the rates each step holds; its camera sees the beacons
within its field of view with eq. 3's errors (:class:`~azgym.site.error_model.ErrorModel`), plus
gross outliers and ids not in the map. :func:`write_robot` writes a route of the simulated
differential-drive robot instead.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from azgym.core import wrap_angle
from azgym.sensing.motion import DifferentialOdometryModel, Imu, ImuModel, Odometer, OdometryModel
from azgym.site.error_model import ErrorModel
from azgym.world.drive import simulate

STEP = 0.02
"""Physics step [s]: the motion sensors' period, so that a sample holds its step exactly."""
CAMERA_HZ = 10.0
WHEELBASE = 1.6


@dataclass(frozen=True)
class Truth:
    """The known parameters a log is simulated with."""

    delta_alpha_d: float = math.radians(0.5)
    coverage: bool = True
    field_of_view: float = 2.0
    camera_ahead: float = -0.5
    speed_noise: float = 0.02
    scale_walk: float = 0.002
    turn_rate_noise: float = 0.005
    bias_walk: float = 1e-4
    seconds: float = 120.0
    outliers: float = 0.03
    unmapped: float = 0.02
    width: float = 0.3


def beacons() -> list[tuple[int, float, float]]:
    """Twelve beacons on a ring of 11 m and four inside, about the origin."""
    ring = [(k, 11.0 * math.cos(k * math.pi / 6), 11.0 * math.sin(k * math.pi / 6))
            for k in range(12)]
    return ring + [(12 + k, 3.0 * math.cos(k * math.pi / 2 + 0.4),
                    3.0 * math.sin(k * math.pi / 2 + 0.4)) for k in range(4)]


def write_simulated(folder: Path, seed: int, truth: Truth = Truth(), *, turn: str = "imu",
                    heading: bool = True, glitch: float = 0.0) -> Path:
    """Simulate and write the log; returns its folder.

    Args:
        folder: Where to write it.
        seed: The seed of every draw.
        truth: The noise to draw.
        turn: ``"imu"``: odometry with a steering angle and a gyro in imu.csv; ``"odometry"``:
            the gyro's samples as the odometry's ``yaw_rate``, no IMU (a differential drive).
        heading: Whether the truth has headings (else position-only).
        glitch: The truth written for frames 300 and 900 is this far off east [m] (a motion
            capture's glitch; the camera saw from the true pose).
    """
    rng = np.random.default_rng(seed)
    frames, odometry, gyro = _drive(truth, rng)
    detections = _detections(frames, truth, rng)
    for k in (300, 900) if glitch else ():
        t, x, y, h = frames[k]
        frames[k] = (t, x + glitch, y, h)
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "log.toml").write_text(
        'format = 2\nname = "known-noise"\ndescription = "simulated with known noise"\n'
        'simulated = true\n\n[map]\nbeacons = "beacons.csv"\n', encoding="utf-8")
    _write(folder / "beacons.csv", ["id", "x", "y", "z", "width"],
           [(i, bx, by, 2.0, truth.width) for i, bx, by in beacons()])
    _write(folder / "frames.csv", ["frame", "time", "x", "y", *(["heading"] if heading else [])],
           [(k, *row[:4 if heading else 3]) for k, row in enumerate(frames)])
    _write(folder / "detections.csv", ["frame", "id", "azimuth"], detections)
    if turn == "odometry":
        _write(folder / "odometry.csv", ["time", "speed", "yaw_rate"],
               zip(odometry.time.tolist(), odometry.speed.tolist(), gyro.yaw_rate.tolist(),
                   strict=True))
    else:
        _write(folder / "odometry.csv", ["time", "speed", "steer"],
               zip(odometry.time.tolist(), odometry.speed.tolist(), odometry.steer.tolist(),
                   strict=True))
        _write(folder / "imu.csv", ["time", "yaw_rate"],
               zip(gyro.time.tolist(), gyro.yaw_rate.tolist(), strict=True))
    return folder


def _write(path: Path, header: list[str], rows) -> None:
    """A CSV table, floats by repr (they read back exactly)."""
    path.write_text(",".join(header) + "\n" + "".join(
        ",".join(repr(value) if isinstance(value, float) else str(value) for value in row)
        + "\n" for row in rows), encoding="utf-8")


def _drive(truth: Truth, rng: np.random.Generator):
    """The camera's true poses at 10 Hz, and the odometry's and gyro's samples."""
    phases = rng.uniform(0, 2 * math.pi, 3)
    odometer = Odometer(OdometryModel(rate_hz=50.0, speed_noise=truth.speed_noise,
                                      scale_walk=truth.scale_walk), rng)
    imu = Imu(ImuModel(rate_hz=50.0, gyro_noise=truth.turn_rate_noise,
                       gyro_bias_walk=truth.bias_walk), rng)
    x, y, heading = 6.0, 0.0, math.pi / 2
    frames = []
    every = round(1.0 / (CAMERA_HZ * STEP))
    for k in range(round(truth.seconds / STEP) + 1):
        t = k * STEP
        if k % every == 0:
            c, s = math.cos(heading), math.sin(heading)
            frames.append((t, x + truth.camera_ahead * c, y + truth.camera_ahead * s,
                           math.remainder(heading, 2 * math.pi)))
        speed = 1.0 + 0.3 * math.sin(2 * math.pi * t / 9.0 + phases[0])
        rate = speed / 6.0 + 0.4 * math.sin(2 * math.pi * t / 6.0 + phases[1]) \
            + 0.2 * math.sin(2 * math.pi * t / 2.3 + phases[2])
        odometer.update(t, speed, math.atan2(rate * WHEELBASE, speed))
        imu.update(t, rate, (0.0, 0.0), heading)
        turn = rate * STEP  # the exact arc of one step
        chord = speed * STEP * (math.sin(0.5 * turn) / (0.5 * turn) if turn else 1.0)
        x += chord * math.cos(heading + 0.5 * turn)
        y += chord * math.sin(heading + 0.5 * turn)
        heading += turn
    return frames, odometer.take(), imu.take()


def _detections(frames: list[tuple[float, float, float, float]], truth: Truth,
                rng: np.random.Generator) -> list[tuple[int, int, float]]:
    """Each frame's beacons in view with eq. 3's errors, some gross outliers and unmapped ids."""
    model = ErrorModel(truth.delta_alpha_d, truth.coverage)
    table = np.array(beacons())
    rows = []
    for k, (_, fx, fy, fh) in enumerate(frames):
        dx, dy = table[:, 1] - fx, table[:, 2] - fy
        azimuth = wrap_angle(np.arctan2(dy, dx) - fh)
        seen = np.abs(azimuth) <= 0.5 * truth.field_of_view
        distance = np.hypot(dx, dy)[seen]
        measured = azimuth[seen] + model.sample(distance, np.full(distance.size, truth.width),
                                                rng)
        gross = rng.random(measured.size) < truth.outliers
        measured[gross] += rng.choice([-1, 1], gross.sum()) * rng.uniform(0.2, 1.0, gross.sum())
        measured = wrap_angle(measured)
        rows += [(k, int(i), float(a)) for i, a in zip(table[seen, 0], measured, strict=True)]
        if rng.random() < truth.unmapped * 5:
            rows.append((k, 999, float(rng.uniform(-0.5, 0.5))))
    return rows


def write_robot(folder: Path, seed: int, model: DifferentialOdometryModel) -> Path:
    """A route of the simulated differential-drive robot (robot-arena) as a log.

    Its odometry reports speed and turn rate at a busy logger's stamps (``model``), its forward
    camera sees the arena's landmarks with the scenario's azimuth noise.
    """
    frames = list(simulate("robot-arena", None, seed, odometry=model))
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "log.toml").write_text(
        'format = 2\nname = "robot"\ndescription = "the simulated robot"\nsimulated = true\n\n'
        '[map]\nscenario = "robot-arena"\n', encoding="utf-8")
    _write(folder / "frames.csv", ["frame", "time", "x", "y", "heading"],
           [(f.index, f.time, *map(float, f.pose)) for f in frames])
    _write(folder / "detections.csv", ["frame", "id", "azimuth"],
           [(f.index, int(i), float(a)) for f in frames
            for i, a in zip(f.measurements.ids, f.measurements.azimuth, strict=True)])
    _write(folder / "odometry.csv", ["time", "speed", "yaw_rate"],
           [row for f in frames for row in zip(f.odometry.time.tolist(), f.odometry.speed.tolist(),
                                              f.odometry.yaw_rate.tolist(), strict=True)])
    return folder
