"""Convert the Triangulation Toolbox's real bearing datasets into the logs azgym ships.

Roh's angulation set becomes the log ``roh`` and each of the nine MRCLAM snapshot sets a log
``mrclam-K`` (docs/datasets.md says what they are, where they come from and how they were
converted). Every file of a log folder is written here, the licence and README included, floats
by ``repr``, so the same toolbox files give the same bytes::

    python baselines/real_datasets.py SOURCE [--out envs/logs] [--only NAME ...] [--overwrite]
    python baselines/real_datasets.py --fit NAME [NAME ...]

``SOURCE`` is the toolbox's dataset folder (``roh/``, ``mrclam/``, ``LICENSE``). An existing log
folder is refused unless ``--overwrite`` is given. Each manifest's ``[sensor]`` section is
``azgym calibrate``'s azimuth fit on the log (:func:`sensor_of`); ``--fit`` reads shipped logs
(or log folders), fits them again and prints the fits and whether each manifest states them.
"""

from __future__ import annotations

import argparse
import csv
import io
import math
import re
import sys
import tempfile
from collections.abc import Iterable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from azgym.core import BeaconMap, wrap_angle, wrap_scalar
from azgym.errors import AzgymError, InvalidInputError
from azgym.files import prepare_folder, write_file
from azgym.logs import Log, read_log
from azgym.logs.calibrate import Calibration, calibrate
from azgym.logs.export import csv_text
from azgym.logs.manifest import MANIFEST
from azgym.profile import Profile, SensorProfile, VehicleProfile, profile_toml
from azgym.site.toml_writer import to_toml

ROOT = Path(__file__).resolve().parent.parent
MRCLAM_SETS = tuple(range(1, 10))
"""The MRCLAM sets the toolbox converted."""
NAMES = ("roh", *(f"mrclam-{k}" for k in MRCLAM_SETS))
"""The logs this script writes, in order."""
LOG_FORMAT = 2
"""The log format written: the first with a ``[sensor]`` section."""
FILES = ("LICENSE", "README.md", MANIFEST, "beacons.csv", "frames.csv", "detections.csv")
"""The files of each log folder, all written here."""
ROH_HEADING = math.pi / 2
"""The detector's heading at every Roh position: its zero along world +y (the toolbox's README;
the data agree: the median residual is under 1°)."""
DIGITS = 5
"""The calibrated Δα_d is written with this many decimals [rad]."""
CITATION_TOOLBOX = ("S. Choi, Triangulation Toolbox (landmark-based localization algorithms, "
                    "datasets and benchmarks), https://github.com/SunglokChoi/Triangulation-Toolbox")
CITATION_ROH = ("H. C. Roh, Y. G. Ryu, M. J. Chung, Mobile Robot Localization based on Active "
                "Beacon System using Infrared Sensors in Indoor Environment, Korea Robotics "
                "Society Annual Conference (KRoC), 2010; and H. C. Roh's Master's thesis of the "
                "same title, KAIST, 2010")
CITATION_MRCLAM = ("K. Y. K. Leung, Y. Halpern, T. D. Barfoot, H. H. T. Liu, The UTIAS "
                   "Multi-Robot Cooperative Localization and Mapping Dataset, The International "
                   "Journal of Robotics Research 30(8), 2011, "
                   "http://asrl.utias.utoronto.ca/datasets/mrclam/")


@dataclass(frozen=True)
class Converted:
    """One dataset as the log's tables hold it, with the words of its manifest and README.

    Attributes:
        name: The log's name (its folder's).
        description: The manifest's one line.
        camera: The camera, in words.
        truth: Where the truth comes from, in words.
        sequence: The manifest's ``sequence`` (None: ``frames.csv`` names each frame's).
        vehicle: What is known of the vehicle.
        readme: The README's text.
        beacons: The map.
        frame: Each frame's number, and its time [s]: the sources keep no clock.
        truth_pose: Each frame's true pose (x, y, heading) [m, m, rad], (N, 3).
        frame_sequence: Each frame's sequence, or None (one sequence, the manifest's).
        row: Each detection's frame row.
        ids: Each detection's beacon id.
        azimuth: Each detection's azimuth [rad].
    """

    name: str
    description: str
    camera: str
    truth: str
    sequence: str | None
    vehicle: VehicleProfile
    readme: str
    beacons: BeaconMap
    frame: np.ndarray
    truth_pose: np.ndarray
    frame_sequence: list[str] | None
    row: np.ndarray
    ids: np.ndarray
    azimuth: np.ndarray


def sensor_of(calibration: Calibration) -> SensorProfile:
    """The ``[sensor]`` section a log gets: ``azgym calibrate``'s azimuth fits on it.

    Δα_d is rounded to :data:`DIGITS` decimals (far inside its interval), so that the last bits
    of a numerical solution cannot change the shipped bytes.
    """
    sensor = calibration.profile().sensor
    assert sensor.delta_alpha_d is not None
    return replace(sensor, delta_alpha_d=round(sensor.delta_alpha_d, DIGITS))


def fit_report(log: Log) -> tuple[SensorProfile, str]:
    """The log's sensor section as :func:`sensor_of` fits it, and lines that say how."""
    calibration = calibrate(log)
    sensor, stated = sensor_of(calibration), log.manifest.profile.sensor
    _, residual, inlier = calibration.residuals["azimuth"]
    lines = [f"{log.manifest.name}: {len(log.frames['frame'])} frames, "
             f"{len(log.detections['id'])} detections, {int(inlier.sum())} inliers; residuals: "
             f"median {math.degrees(float(np.median(residual))):.3f}°, √3·std of the inliers "
             f"{math.degrees(math.sqrt(3) * float(np.std(residual[inlier]))):.3f}°"]
    lines += [f"  {fit.name} = {fit.value!r} (95 % {fit.interval}; {fit.method})"
              for fit in calibration.fits if fit.name.startswith("sensor.")]
    lines.append(f"  log.toml {'states the same' if stated == sensor else f'says {stated}'}")
    return sensor, "\n".join(lines)


def roh(source: Path) -> Converted:
    """Roh's angulation set: 9 static positions, 200 readings of the 4 beacons' bearings each.

    Each reading (a CSV row: the bearings of beacons 1-4 in degrees, counter-clockwise from the
    detector's zero, which points along world +y) is one frame, in the order of the positions
    (x, then y) and of the rows; its detections are the four bearings in radians, wrapped to
    (−π, π]. Each position is a sequence; a frame's time is its number (the source keeps no
    clock).
    """
    folder = source / "roh"
    landmarks = _numbers(folder / "landmark.csv", 2)
    beacons = BeaconMap(np.arange(1, len(landmarks) + 1), np.column_stack(
        [landmarks, np.zeros(len(landmarks))]))
    positions = []
    for path in folder.glob("(X*,Y*).csv"):
        match = re.fullmatch(r"\(X(\d+\.\d+),Y(\d+\.\d+)\)\.csv", path.name)
        if match is None:
            raise InvalidInputError(f"{path}: not a Roh position file (X#.#,Y#.#).csv")
        positions.append((float(match[1]), float(match[2]), path))
    if len(positions) != 9:
        raise InvalidInputError(f"{folder}: {len(positions)} position files, Roh's set has 9")
    truth, sequences, bearings = [], [], []
    for x, y, path in sorted(positions):
        readings = _numbers(path, len(beacons))
        truth += [(x, y, ROH_HEADING)] * len(readings)
        sequences += [f"x{x:.1f}-y{y:.1f}"] * len(readings)
        bearings.append(readings)
    degrees = np.concatenate(bearings)
    frames = np.arange(1, len(degrees) + 1)
    return Converted(
        name="roh",
        description=("Roh's angulation set (real): a rotating infrared detector measures the "
                     "bearings of 4 infrared LED beacons at the corners of a 6 m square, from 9 "
                     "known static positions, 200 readings each"),
        camera=("a rotating infrared detector seeing all round; its zero along world +y (heading "
                "90°); bearings of the beacons' centres"),
        truth="each position's x, y as the dataset gives it; the heading 90°, as the setup had it",
        sequence=None, vehicle=VehicleProfile(), readme=_roh_readme(),
        beacons=beacons, frame=frames,
        truth_pose=np.array(truth, dtype=float), frame_sequence=sequences,
        row=np.repeat(np.arange(len(degrees)), len(beacons)),
        ids=np.tile(beacons.ids, len(degrees)),
        azimuth=np.array([wrap_scalar(math.radians(float(d))) for d in degrees.ravel()]))


def mrclam(source: Path, k: int) -> Converted:
    """MRCLAM set ``k`` as the toolbox's snapshots: one frame per experiment id.

    A snapshot's detections are its measurements' landmark ids and bearings (radians,
    counter-clockwise from the robot's heading), in the file's order; the ranges are left out
    (azgym scores azimuths). Its truth is the snapshot's robot pose; its time is its number
    (the toolbox keeps no clock). Measured ids not in the map would be kept (the toolbox's files
    hold none).
    """
    from scipy.io import loadmat

    path = source / "mrclam" / f"mrclam{k}.mat"
    if not path.is_file():
        raise InvalidInputError(f"{path}: no such file (the toolbox's MRCLAM set {k})")
    data = loadmat(path)
    landmark, truth, measurement = (np.asarray(data[key], dtype=float)
                                    for key in ("landmark", "groundtruth", "measurement"))
    frames = truth[:, 0].astype(np.int64)
    if not np.array_equal(frames, np.arange(1, len(frames) + 1)):
        raise InvalidInputError(f"{path}: groundtruth: experiment ids are not 1, 2, …")
    experiment = measurement[:, 0].astype(np.int64)
    if np.any(np.diff(experiment) < 0) or not set(experiment) <= set(frames.tolist()):
        raise InvalidInputError(f"{path}: measurement: experiment ids out of order or unknown")
    beacons = BeaconMap(landmark[:, 0].astype(np.int64), np.column_stack(
        [landmark[:, 1:3], np.zeros(len(landmark))]))
    return Converted(
        name=f"mrclam-{k}",
        description=(f"MRCLAM set {k} as instantaneous snapshots (real): a small "
                     "differential-drive robot's forward camera measures the bearings of "
                     "landmark cylinders; the Triangulation Toolbox's extraction, 3 or more "
                     "landmarks per snapshot"),
        camera=("a forward-looking monocular camera on an iRobot Create, about 68° wide; "
                "bearings relative to the robot's heading"),
        truth=("the motion-capture system's robot pose (x, y, heading), as the toolbox "
               "gives it per snapshot; the bearings are relative to it"),
        sequence=f"mrclam-{k}", vehicle=VehicleProfile(kind="differential-drive"),
        readme=_mrclam_readme(k, len(beacons)), beacons=beacons, frame=frames,
        truth_pose=np.column_stack(
            [truth[:, 1:3], wrap_angle(truth[:, 3])]), frame_sequence=None,
        row=experiment - 1, ids=measurement[:, 1].astype(np.int64), azimuth=measurement[:, 3])


def convert(source: Path, name: str) -> Converted:
    """The dataset ``name`` (one of :data:`NAMES`) read from the toolbox folder ``source``."""
    if name == "roh":
        return roh(source)
    return mrclam(source, int(name.removeprefix("mrclam-")))


def log_files(data: Converted, licence: str) -> dict[str, str]:
    """Every file of the log folder, by name (:data:`FILES`), as text.

    The manifest's ``[sensor]`` section is ``azgym calibrate``'s fit (:func:`sensor_of`) on the
    log written without it, in a scratch folder.
    """
    files = {"LICENSE": licence, "README.md": data.readme, **_tables(data)}
    with tempfile.TemporaryDirectory() as scratch:
        draft = write_log(files | {MANIFEST: _manifest(data, SensorProfile())},
                          Path(scratch) / data.name, overwrite=False)
        sensor = sensor_of(calibrate(read_log(draft)))
    return files | {MANIFEST: _manifest(data, sensor)}


def _manifest(data: Converted, sensor: SensorProfile) -> str:
    """``log.toml``: what the log is, its map, its truth, and its vehicle and sensor."""
    manifest = {"format": LOG_FORMAT, "name": data.name, "description": data.description,
                "simulated": False, **({"sequence": data.sequence} if data.sequence else {}),
                "camera": {"description": data.camera}, "map": {"beacons": "beacons.csv"},
                "truth": {"source": data.truth},
                **profile_toml(Profile(vehicle=data.vehicle, sensor=sensor))}
    return to_toml(manifest, "An azgym log (docs/logs.md) of real data, converted by "
                             "baselines/real_datasets.py (docs/datasets.md).\n"
                             "Source: the Triangulation Toolbox (Sunglok Choi), which "
                             "redistributes it under its BSD licence:\nLICENSE here. README.md "
                             "says what the data are and what to cite.")


def _tables(data: Converted) -> dict[str, str]:
    """The log's CSV tables: the map, the frames and their truth, the detections."""
    x, y, heading = data.truth_pose.T
    frame_columns: list[Iterable[object]] = [data.frame, data.frame, x, y, heading]
    frame_header = ["frame", "time", "x", "y", "heading"]
    if data.frame_sequence is not None:
        frame_columns.append(data.frame_sequence)
        frame_header.append("sequence")
    return {
        "beacons.csv": csv_text(["id", "x", "y"], zip(data.beacons.ids, *data.beacons.xy.T,
                                                  strict=True)),
        "frames.csv": csv_text(frame_header, zip(*frame_columns, strict=True)),
        "detections.csv": csv_text(["frame", "id", "azimuth"], zip(
            data.frame[data.row], data.ids, data.azimuth, strict=True)),
    }


def write_log(files: dict[str, str], folder: Path, overwrite: bool) -> Path:
    """Write a log's files into ``folder``; an existing folder only with ``overwrite``.

    Raises:
        InvalidInputError: The folder exists and ``overwrite`` is false.
    """
    if folder.exists() and not overwrite:
        raise InvalidInputError(f"{folder}: exists; pass --overwrite to write the log again")
    prepare_folder(folder)
    for name, text in files.items():
        write_file(folder / name, text)
    return folder


def _numbers(path: Path, columns: int) -> np.ndarray:
    """A headerless CSV of numbers with ``columns`` columns, as floats."""
    if not path.is_file():
        raise InvalidInputError(f"{path}: no such file")
    rows = [row for row in csv.reader(io.StringIO(path.read_text(encoding="utf-8"))) if row]
    try:
        values = np.array([[float(cell) for cell in row] for row in rows])
    except ValueError as exc:
        raise InvalidInputError(f"{path}: not a table of numbers: {exc}") from None
    if values.ndim != 2 or values.shape[1] != columns:
        raise InvalidInputError(f"{path}: expected {columns} columns of numbers")
    return values


_FILES_FIT = """\
- `log.toml`: the manifest. Its `[sensor]` section is what `azgym calibrate` fits on the data:
  eq. 1-3's azimuth noise (`delta_alpha_d`, `coverage`) from the residuals of the azimuths
  against the truth, gross outliers trimmed, and the field of view ({view}). docs/datasets.md
  in azgym's repository says more."""
_FORWARD_VIEW = "the forward camera's, from its widest azimuths"
_SOURCE = """\
Converted for azgym by `baselines/real_datasets.py` from the Triangulation Toolbox's `dataset/`
folder (Sunglok Choi), which redistributes the data under its BSD licence: `LICENSE` here.
Cite the toolbox and the dataset's own papers when you use it:"""


def _roh_readme() -> str:
    return f"""# roh: Roh's angulation set (real data)

A rotating infrared detector measured the bearings of four infrared LED beacons placed at the
corners of a 6 m × 6 m square (beacons 1-4 at (0, 0), (6, 0), (6, 6), (0, 6) m) from nine
known static positions on a 1.5 m grid, x and y in 1.5, 3.0 and 4.5 m, 200 readings at each.
The detector's zero pointed along world +y at every position (heading 90°).

- `frames.csv`: one frame per reading (1800); `time` is the frame's number, not a clock (the
  source keeps none); the truth is the position's survey and heading 90°; `sequence` names the
  position (`x1.5-y3.0`).
- `detections.csv`: four bearings per frame, converted from degrees to radians (wrapped to
  (−π, π]), counter-clockwise from the detector's zero.
- `beacons.csv`: the four beacons.
{_FILES_FIT.format(view="all round: the detector turns")}

{_SOURCE}

- {CITATION_TOOLBOX}
- {CITATION_ROH}
"""


def _mrclam_readme(k: int, landmarks: int) -> str:
    return f"""# mrclam-{k}: MRCLAM set {k} as snapshots (real data)

The UTIAS Multi-Robot Cooperative Localization and Mapping dataset recorded five small
differential-drive robots (iRobot Create) driving among landmark cylinders ({landmarks} in the
map of set {k}) in a motion-capture arena; each robot's forward camera measured the range
and bearing of the landmarks it saw. The Triangulation Toolbox cut set {k} into instantaneous
snapshots: the measurements taken while a robot moved less than 1 cm and 0.01 rad within at
most 1 s, with three landmarks or more, outliers removed; a snapshot's truth is the robot's
pose. Consecutive snapshots often repeat the same measurements with a slightly different truth.

- `frames.csv`: one frame per snapshot, numbered by the toolbox's experiment id; `time` is that
  number, not a clock (the toolbox keeps none); the truth is the robot's pose (x, y, heading).
- `detections.csv`: the snapshot's landmark ids and bearings [rad], counter-clockwise from the
  robot's heading, in the toolbox's order; the ranges are left out (azgym scores azimuths).
- `beacons.csv`: the set's landmark map (ids renumbered from 1 by the toolbox).
{_FILES_FIT.format(view=_FORWARD_VIEW)}

{_SOURCE}

- {CITATION_TOOLBOX}
- {CITATION_MRCLAM}
"""


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("source", nargs="?", type=Path,
                        help="the Triangulation Toolbox's dataset folder (roh/, mrclam/, LICENSE)")
    parser.add_argument("--out", type=Path, default=ROOT / "envs" / "logs",
                        help="where the log folders go (default: envs/logs)")
    parser.add_argument("--only", action="append", choices=NAMES, metavar="NAME",
                        help=f"convert only these ({', '.join(NAMES)})")
    parser.add_argument("--overwrite", action="store_true", help="write over existing logs")
    parser.add_argument("--fit", nargs="+", metavar="LOG",
                        help="print the sensor fit of these logs beside their manifests'")
    args = parser.parse_args(argv)
    try:
        if args.fit:
            for name in args.fit:
                print(fit_report(read_log(name))[1])
            return 0
        if args.source is None:
            parser.error("give the toolbox's dataset folder (or --fit LOG)")
        licence = (args.source / "LICENSE").read_text(encoding="utf-8")
        for name in args.only or NAMES:
            folder = write_log(log_files(convert(args.source, name), licence), args.out / name,
                               args.overwrite)
            print(f"wrote {folder}")
    except (AzgymError, OSError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
