"""Write a simulated route as a log: the round trip that pins the log format to the simulator.

:func:`export_route` drives a route (:func:`azgym.world.drive.simulate`) and writes every frame
in azgym's log format (:data:`~azgym.logs.manifest.FORMAT_VERSION`) with its truth, the
detections' labels, and the odometry (its turn rate for a vehicle whose odometry reports one,
else its steering angle) and IMU samples; the manifest states the scenario's vehicle and
sensor (``Scenario.profile``).
Floats are written by ``repr``, which reads back to the same float, so that ``azgym bench
--data`` on the log scores exactly the frames that scoring the route directly would.
"""

from __future__ import annotations

import csv
import glob
import io
import math
from collections.abc import Collection, Iterable
from pathlib import Path

import numpy as np

from azgym import arguments
from azgym.errors import InvalidInputError, unknown_name
from azgym.files import claim_folder, prepare_folder, write_file
from azgym.logs.contents import QUALITY_PREFIX
from azgym.logs.manifest import FORMAT_VERSION, MANIFEST, MAX_NAME
from azgym.profile import profile_toml
from azgym.sensing.geometry.sensor import GeometrySensor
from azgym.sensing.labels import LABEL_NAMES
from azgym.site import list_scenarios, load_scenario
from azgym.site.elements import Route
from azgym.site.reader import name_problem
from azgym.site.scenario import Scenario
from azgym.site.toml_writer import to_toml
from azgym.world.drive import Frame, motion_models, simulate

__all__ = ["LOG_FILES", "claim_log", "csv_text", "export_route"]

LOG_FILES = (MANIFEST, "scenario.toml", "frames.*", "detections.*", "odometry.*", "imu.*")
"""The files of a log folder (glob patterns: a table may be CSV, gzipped or Parquet), which an
export refuses to replace without ``overwrite``: a real camera's recording cannot be made again."""


def export_route(scenario: Scenario | str, route: str | None, seed: int, out: Path, *,
                 name: str | None = None, motion_rate_hz: float | None = None,
                 overwrite: bool = False) -> Path:
    """Drive ``route`` of ``scenario`` with ``seed`` and write it as a log folder ``out``.

    Args:
        scenario: A shipped scenario's name, a scenario file, or a scenario loaded from one.
        route: The route's name (default: the scenario's first).
        seed: The seed of every draw (as for ``simulate``), in [0, 2**31).
        out: The folder to write (created if needed).
        name: The dataset's name (default: ``SCENARIO-ROUTE-sSEED-simulated``).
        motion_rate_hz: The odometry's and IMU's rate [Hz], a finite number > 0 (default: the
            vehicle's models', :func:`azgym.world.drive.motion_models`).
        overwrite: Whether a log already in ``out`` may be replaced (a file of it that this
            export would not write is still refused: the folder would mix two logs).

    Returns:
        The folder written.

    Raises:
        InvalidInputError: A seed, rate or name out of its range, or a log in ``out`` (without
            ``overwrite``), named, before anything is simulated or written.
    """
    seed = arguments.seed("seed", seed)
    if motion_rate_hz is not None:
        motion_rate_hz = arguments.positive_number("motion_rate_hz", motion_rate_hz, "Hz")
    scenario = load_scenario(scenario)
    chosen = _route(scenario, route)
    name = name or f"{scenario.name}-{chosen.name}-s{seed}-simulated"
    if problem := name_problem(name, MAX_NAME):
        raise InvalidInputError(f"name: {problem}")
    odometry, imu = motion_models(scenario, motion_rate_hz)
    claim_log(out, overwrite, [MANIFEST, "frames.csv", "detections.csv", "odometry.csv",
                               *(["imu.csv"] if imu is not None else []),
                               *(["scenario.toml"] if _map_file(scenario) else [])])
    sensor = GeometrySensor(scenario)
    frames = list(simulate(scenario, chosen, seed, sensor=sensor, odometry=odometry, imu=imu))
    prepare_folder(out)
    manifest = {
        "format": FORMAT_VERSION, "name": name,
        "description": _description(scenario, chosen, seed), "simulated": True,
        "sequence": f"{scenario.name}/{chosen.name}",
        "camera": {"rate_hz": float(sensor.frame_rate_hz),
                   "description": "azgym's geometry sensor (simulated)"},
        "map": {"scenario": _map(scenario, out)},
        "truth": {"source": "simulation: the camera's true pose"},
        **profile_toml(scenario.profile)}
    write_file(out / MANIFEST, to_toml(manifest, "An azgym log (docs/logs.md): SIMULATED."))
    write_file(out / "frames.csv", csv_text(["frame", "time", "x", "y", "heading"],
                                        ([f.index, f.time, *f.pose] for f in frames)))
    write_file(out / "detections.csv", _detections(frames, sensor.quality_names))
    write_file(out / "odometry.csv", _odometry(frames))
    if imu is not None:  # a vehicle without an IMU (a robot's) gets no imu.csv
        write_file(out / "imu.csv", _imu(frames))
    return out


def claim_log(out: Path, overwrite: bool, written: Collection[str] | None = None) -> None:
    """``out`` as a log folder to write: the one rule of ``export route`` and ``import bag``.

    Refuses a log there (any of :data:`LOG_FILES`, and any file of ``written``) unless
    ``overwrite``; then, once the files to write are known (``written``), any file of the log
    there that the new one would leave beside it: the folder would mix two logs.

    Raises:
        InvalidInputError: Either, naming the files, before anything is written.
    """
    claim_folder(out, [*LOG_FILES, *(glob.escape(name) for name in written or ())], overwrite,
                 "out")
    left = sorted(str(path) for pattern in LOG_FILES if out.is_dir() and written is not None
                  for path in out.glob(pattern) if path.name not in written)
    if left:
        raise InvalidInputError(f"out: {', '.join(left)} belong to the log there and would be "
                                "left beside the new one; move them away first (nothing was "
                                "written)")


def _map_file(scenario: Scenario) -> bool:
    """Whether the log's map is a copy of the scenario's file (else the shipped name)."""
    return not (scenario.source is None and scenario.name in list_scenarios())


def _route(scenario: Scenario, route: str | None) -> Route:
    """The route named (or the first), its name checked."""
    names = {r.name: r for r in scenario.routes}
    if route is None and scenario.routes:
        return scenario.routes[0]
    if route not in names:
        raise unknown_name("route", str(route), names)
    return names[route]


def _description(scenario: Scenario, route: Route, seed: int) -> str:
    return (f"SIMULATED, not a real camera's: route {route.name} of {scenario.name} driven by "
            f"azgym (azgym export route, seed {seed})")


def _map(scenario: Scenario, out: Path) -> str:
    """The manifest's map: a shipped scenario by name, a user's file copied beside the log."""
    if not _map_file(scenario):
        return scenario.name
    if scenario.source is None:
        raise InvalidInputError(f"scenario {scenario.name!r} is neither shipped nor read from a "
                                "file; export needs one of them for the log's map")
    write_file(out / "scenario.toml", scenario.source.read_bytes())
    return "scenario.toml"


def _cell(value: object) -> str:
    """A cell: a float by repr (it reads back exactly), NaN as empty, anything else as text."""
    if isinstance(value, (float, np.floating)):
        return "" if math.isnan(value) else repr(float(value))
    return str(value)


def csv_text(header: list[str], rows: Iterable[Iterable[object]]) -> str:
    """A log table as CSV text: floats by ``repr`` (they read back exactly), NaN as empty."""
    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    writer.writerow(header)
    writer.writerows([_cell(value) for value in row] for row in rows)
    return buffer.getvalue()


def _detections(frames: list[Frame], quality_names: tuple[str, ...]) -> str:
    """detections.csv: each frame's detections in the sensor's order, with their labels."""
    header = ["frame", "id", "azimuth", *(QUALITY_PREFIX + n for n in quality_names), "label"]
    rows = []
    for frame in frames:
        m = frame.measurements
        quality = np.zeros((len(m), 0)) if m.quality is None else \
            m.quality.reshape(len(m), len(quality_names))  # a frame may have no detection
        for k in range(len(m)):
            rows.append([frame.index, int(m.ids[k]), float(m.azimuth[k]),
                         *(float(q) for q in quality[k]), LABEL_NAMES[int(frame.truth.label[k])]])
    return csv_text(header, rows)


def _odometry(frames: list[Frame]) -> str:
    """odometry.csv: time, speed and the turn rate (if the odometry reports it) or steer."""
    turn = "yaw_rate" if any(f.odometry.reports_yaw_rate for f in frames) else "steer"
    return csv_text(["time", "speed", turn], (
        row for f in frames for row in zip(f.odometry.time, f.odometry.speed,
                                           getattr(f.odometry, turn), strict=True)))


def _imu(frames: list[Frame]) -> str:
    """imu.csv; the heading column only when some sample has one."""
    samples = [f.imu for f in frames]
    with_heading = any(np.isfinite(s.heading).any() for s in samples)
    header = ["time", "yaw_rate", "ax", "ay", *(["heading"] if with_heading else [])]
    return csv_text(header, (
        [s.time[k], s.yaw_rate[k], s.accel[k, 0], s.accel[k, 1],
         *([s.heading[k]] if with_heading else [])]
        for s in samples for k in range(s.time.size)))
