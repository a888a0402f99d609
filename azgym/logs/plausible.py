"""Unit and clock mistakes a log's values reveal: plausibility checks beyond each cell's syntax.

A value can be a valid number and still wrong by a unit: a heading in degrees, times in
milliseconds, a truth in millimetres, azimuths measured clockwise. Such a log would be scored
without complaint and give wrong figures, so :func:`check_plausible` refuses it, naming what the
values look like:

- headings (truth, IMU) in [−π, π]; odometry |speed| ≤ :data:`MAX_SPEED`, |steer| ≤ π;
  odometry and IMU |yaw_rate| ≤ :data:`MAX_YAW_RATE`, |ax|, |ay| ≤ :data:`MAX_ACCEL`
  (:data:`BOUNDS`);
- the truth's x, y within the map's extent (:class:`Extent`);
- with ``camera.rate_hz``, the median frame interval within a factor :data:`RATE_FACTOR` of
  1 / rate;
- with the truth and odometry, the time unit: over the frame intervals the odometry says the
  vehicle moves in (its mean |speed| over the interval at least :data:`MIN_SPEED`, which a
  wrong time unit leaves as it is), the distance the odometry's speed integrates to over the
  tables' times is within a factor :data:`TIME_FACTOR` of the distance the truth moves
  (milliseconds read as seconds make it 1000 times longer, minutes 60 times shorter); the same
  for the IMU's yaw rate against the true heading's change, where the truth has a heading
  (:data:`MIN_YAW_RATE`). Fewer than :data:`MIN_INTERVALS` such intervals (a static log) are not
  checked;
- with the truth, the detections of map beacons agree with the azimuths the true poses predict
  (α = atan2(y_b − y, x_b − x) − φ, :mod:`azgym.core`): the median absolute difference at most
  :data:`MAX_AZIMUTH_RESIDUAL` (a median, since misread ids and mirror images disagree). With
  position-only truth each frame's φ is the one that fits its detections best (their circular
  mean), and only frames with two or more detections of map beacons count.

Whether the motion samples are on the frames' clock is :mod:`azgym.logs.clocks`' question.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from azgym.core import BeaconMap, wrap_angle
from azgym.logs.problems import Problems
from azgym.logs.tables import Columns, Table

__all__ = ["Extent", "check_plausible"]

MAX_SPEED = 20.0
"""The largest odometry |speed| [m/s] (72 km/h: far beyond an indoor vehicle)."""
MAX_YAW_RATE = 20.0
"""The largest IMU |yaw_rate| [rad/s] (three turns a second)."""
MAX_ACCEL = 100.0
"""The largest IMU |ax|, |ay| [m/s²] (10 g)."""
BOUNDS = {
    ("frames", "heading"): (math.pi, "radians, counter-clockwise from the x-axis; degrees?"),
    ("odometry", "speed"): (MAX_SPEED, "m/s; km/h or mm/s?"),
    ("odometry", "steer"): (math.pi, "radians; degrees?"),
    ("odometry", "yaw_rate"): (MAX_YAW_RATE, "rad/s; degrees per second?"),
    ("imu", "yaw_rate"): (MAX_YAW_RATE, "rad/s; degrees per second?"),
    ("imu", "ax"): (MAX_ACCEL, "m/s²; mm/s²?"),
    ("imu", "ay"): (MAX_ACCEL, "m/s²; mm/s²?"),
    ("imu", "heading"): (math.pi, "radians, counter-clockwise from the x-axis; degrees?"),
}
"""(table, column) → (the largest absolute value, a hint at the unit mistake)."""
RATE_FACTOR = 1.5
"""How far the median frame interval may be from 1 / ``camera.rate_hz`` (either way)."""
SCENARIO_MARGIN = 5.0
"""How far outside a scenario's bounds a true position may lie [m]."""
BEACONS_MARGIN = 50.0
"""How far outside the beacons' bounding box a true position may lie [m] (a beacons.csv map
says nothing of the room)."""
TIME_FACTOR = 10.0
"""How far the motion a stream's rate integrates to over the tables' times may be from the
truth's (either way) before the time unit is called wrong."""
MIN_SPEED = 0.05
"""The mean odometry |speed| over a frame interval that makes it one the vehicle moves in [m/s]."""
MIN_YAW_RATE = 0.05
"""The mean IMU |yaw_rate| over a frame interval that makes it one the vehicle turns in
[rad/s]."""
MIN_INTERVALS = 10
"""The fewest frame intervals of motion the time unit check needs."""
MAX_AZIMUTH_RESIDUAL = 0.2
"""The largest median |measured − predicted azimuth| over a log's detections of map beacons
[rad] (11°: far above any camera's noise, far below a unit or sign mistake's)."""


@dataclass(frozen=True)
class Extent:
    """Where the truth may lie: (x_min, y_min, x_max, y_max) [m], margin included, and why."""

    box: tuple[float, float, float, float]
    what: str

    @classmethod
    def of_scenario(cls, bounds: tuple[float, float, float, float]) -> Extent:
        """A scenario's room bounds and :data:`SCENARIO_MARGIN`."""
        x0, y0, x1, y1 = bounds
        m = SCENARIO_MARGIN
        return cls((x0 - m, y0 - m, x1 + m, y1 + m), f"the scenario's bounds and {m:g} m")

    def outside(self, x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Which values of ``x`` and of ``y`` lie outside the box: two boolean masks."""
        x0, y0, x1, y1 = self.box
        return (x < x0) | (x > x1), (y < y0) | (y > y1)

    @classmethod
    def of_beacons(cls, beacons: BeaconMap) -> Extent:
        """The beacons' bounding box and :data:`BEACONS_MARGIN`."""
        x0, y0, x1, y1 = beacons.bounds()
        m = BEACONS_MARGIN
        return cls((x0 - m, y0 - m, x1 + m, y1 + m), f"the beacons' extent and {m:g} m")


def check_plausible(tables: dict[str, Table | None], columns: dict[str, Columns | None],
                    beacons: BeaconMap | None, extent: Extent | None,
                    rate_hz: float | None, problems: Problems) -> None:
    """Report the unit and clock mistakes (module docstring) of each table's columns."""
    for (name, column), (bound, hint) in BOUNDS.items():
        table, values = tables.get(name), columns.get(name)
        if table is not None and values is not None and column in values.values:
            for k in np.flatnonzero(np.abs(values[column]) > bound):
                table.report(problems, f"{float(values[column][k])!r} is outside "
                                       f"[-{bound:.4g}, {bound:.4g}] ({hint})", int(k), column)
    frames, table = columns.get("frames"), tables.get("frames")
    if frames is None or table is None:
        return
    _frame_rate(table, frames["time"], rate_hz, problems)
    if "x" in frames.values:
        _time_unit(table, frames, columns, problems)
    if "x" in frames.values and extent is not None:
        _truth_in_extent(table, frames, extent, problems)
    detections = columns.get("detections")
    if "x" in frames.values and beacons is not None and detections is not None:
        _azimuths_agree(tables["detections"], detections, frames, beacons, problems)


def _frame_rate(table: Table, time: np.ndarray, rate_hz: float | None,
                problems: Problems) -> None:
    """The median frame interval agrees with ``camera.rate_hz`` within :data:`RATE_FACTOR`."""
    steps = np.diff(time)
    steps = steps[np.isfinite(steps) & (steps > 0)]
    if rate_hz is None or not steps.size:
        return
    median, expected = float(np.median(steps)), 1.0 / rate_hz
    if not 1 / RATE_FACTOR <= median / expected <= RATE_FACTOR:
        problems.add(table.file, f"the median frame interval is {median:.6g} s, but "
                                 f"camera.rate_hz = {rate_hz:g} says {expected:.6g} s (times in "
                                 "seconds? the right rate?)", column="time")


def _time_unit(table: Table, frames: Columns, columns: dict[str, Columns | None],
               problems: Problems) -> None:
    """The odometry's speed and the IMU's yaw rate move as far as the truth over the same times.

    Each is compared over the frame intervals of one sequence in which it says the vehicle
    moves (module docstring); the factor between the two is the time unit's mistake.
    """
    time = frames["time"]
    same = np.asarray(frames["sequence"][1:]) == np.asarray(frames["sequence"][:-1])
    truth = {"speed": np.hypot(np.diff(frames["x"]), np.diff(frames["y"]))}
    if "heading" in frames.values:
        truth["yaw_rate"] = np.abs(wrap_angle(np.diff(frames["heading"])))
    for name, column, least, what in (("odometry", "speed", MIN_SPEED, ("distance", "m")),
                                      ("imu", "yaw_rate", MIN_YAW_RATE, ("turn", "rad"))):
        stream = columns.get(name)
        if stream is None or column not in truth or column not in stream.values:
            continue
        moved = _integrated(stream["time"], stream[column], time)
        steps = np.diff(time)
        used = same & (steps > 0) & np.isfinite(moved) & np.isfinite(truth[column]) \
            & (moved >= least * steps)
        if used.sum() < MIN_INTERVALS:
            continue
        read, true = float(moved[used].sum()), float(truth[column][used].sum())
        if true * TIME_FACTOR >= read >= true / TIME_FACTOR:
            continue
        factor = f"{read / true:.4g} times" if true > 0 else "infinitely more than"
        problems.add(table.file, f"{name}.csv's {column}, integrated over the tables' times, "
                                 f"gives {factor} the {what[0]} the truth covers over the same "
                                 f"{used.sum()} frame intervals ({read:.4g} {what[1]} against "
                                 f"{true:.4g} {what[1]}; more than {TIME_FACTOR:g} times either "
                                 "way is refused): are the times in seconds (not milliseconds "
                                 f"or minutes), the truth and {column} in SI units?",
                     column="time")


def _integrated(sample_time: np.ndarray, rate: np.ndarray, time: np.ndarray) -> np.ndarray:
    """|∫ rate dt| over each interval between ``time``'s (NaN where the samples do not span it).

    Each sample's rate holds until the next sample (the last one's until its own time).
    """
    ok = np.isfinite(sample_time) & np.isfinite(rate)
    sample_time, rate = sample_time[ok], rate[ok]
    if sample_time.size < 2 or np.any(np.diff(sample_time) < 0):  # a decrease: reported
        return np.full(max(time.size - 1, 0), np.nan)
    total = np.concatenate([[0.0], np.cumsum(rate[:-1] * np.diff(sample_time))])
    at = np.interp(time, sample_time, total)
    inside = (time >= sample_time[0]) & (time <= sample_time[-1])
    return np.where(inside[1:] & inside[:-1], np.abs(np.diff(at)), np.nan)


def _truth_in_extent(table: Table, frames: Columns, extent: Extent, problems: Problems) -> None:
    """Each true x, y within the map's extent (a truth in millimetres is far outside)."""
    x0, y0, x1, y1 = extent.box
    masks = extent.outside(frames["x"], frames["y"])
    for (column, lo, hi), outside in zip((("x", x0, x1), ("y", y0, y1)), masks, strict=True):
        values = frames[column]
        for k in np.flatnonzero(outside):
            table.report(problems, f"{float(values[k])!r} is outside the map's extent "
                                   f"[{lo:.6g}, {hi:.6g}] m ({extent.what}; millimetres?)",
                         int(k), column)


def _azimuths_agree(table: Table | None, detections: Columns, frames: Columns,
                    beacons: BeaconMap, problems: Problems) -> None:
    """The median |azimuth − the truth's prediction| over detections of map beacons is small."""
    rows = detections["frame"]
    index = beacons.index_of(detections["id"])
    used = np.flatnonzero((rows >= 0) & (index >= 0))
    if table is None or not used.size:
        return
    x, y = (frames[key][rows[used]] for key in ("x", "y"))
    xy = beacons.xy[index[used]]
    bearing = np.arctan2(xy[:, 1] - y, xy[:, 0] - x)
    measured = detections["azimuth"][used]
    if "heading" in frames.values:
        heading = frames["heading"][rows[used]]
    else:  # position-only truth: each frame's best-fitting heading, from two detections on
        heading = _fitted_headings(rows[used], bearing - measured)
        used, bearing, measured, heading = (values[np.isfinite(heading)] for values in
                                            (used, bearing, measured, heading))
        if not used.size:
            return
    predicted = bearing - heading
    residual = np.abs(wrap_angle(measured - predicted))
    if not np.isfinite(residual).any():  # every cell bad: each reported already
        return
    median = float(np.nanmedian(residual))
    if not median > MAX_AZIMUTH_RESIDUAL:
        return
    if "heading" not in frames.values:
        hint = "measured clockwise, in degrees, or scaled?"
    elif float(np.nanmedian(np.abs(wrap_angle(measured + predicted)))) <= MAX_AZIMUTH_RESIDUAL:
        hint = "they match the predictions negated: measured clockwise?"
    else:
        offset = float(np.nanmedian(wrap_angle(measured - predicted)))
        spread = float(np.nanmedian(np.abs(wrap_angle(measured - predicted - offset))))
        hint = (f"they match the predictions turned by {offset:.3g} rad: a heading or camera "
                "zero offset?" if spread <= MAX_AZIMUTH_RESIDUAL else
                "in degrees, or scaled?")
    problems.add(table.file, f"the azimuths disagree with the truth: the median |azimuth − "
                             f"the azimuth the true pose predicts| over {used.size} detections "
                             f"of map beacons is {median:.3g} rad, at most "
                             f"{MAX_AZIMUTH_RESIDUAL:g} is plausible ({hint})", column="azimuth")


def _fitted_headings(frame: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """The heading that fits each detection's frame best (NaN: fewer than two in the frame).

    It is the circular mean of the frame's detections' bearing − azimuth.
    """
    count = np.bincount(frame)
    mean = np.arctan2(np.bincount(frame, np.sin(offset)), np.bincount(frame, np.cos(offset)))
    return np.where(count[frame] >= 2, mean[frame], np.nan)
