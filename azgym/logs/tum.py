"""Trajectories in the TUM format, written and read with numpy alone.

A TUM file (the TUM RGB-D benchmark's, which evo reads as ``evo_ape tum TRUTH EST``) holds one
pose a line, ``timestamp tx ty tz qx qy qz qw``, separated by spaces; a line starting with
``#`` is a comment. azgym's poses are 2-D: it writes ``tz`` = 0 and the heading φ as the yaw
quaternion (0, 0, sin φ/2, cos φ/2), every number by ``repr`` so that it reads back as the very
float written (:func:`tum_text`).

:func:`parse_tum` reads one as a log's truth (docs/logs.md): ``tz`` is ignored (the floor plan
is 2-D) and the heading is the quaternion's yaw when it is taken. A file comes from someone
else, so every problem names the file and line (and column: ``timestamp``, ``tx``, …): a line
of other than 8 values, a number that is not a plain finite decimal (``nan``, ``inf``), time
stamps that do not increase, a quaternion that is not a unit one; the file is read with the
byte and cell limits of a log's tables (:mod:`azgym.logs.files`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from azgym.logs.files import MAX_TABLE_CELLS
from azgym.logs.problems import Problems, places, seconds
from azgym.logs.tables import Table, floats

__all__ = ["TUM_COLUMNS", "UNIT_TOLERANCE", "TumTrajectory", "not_unit", "parse_tum",
           "quaternion_yaw", "tum_text"]

TUM_COLUMNS = ("timestamp", "tx", "ty", "tz", "qx", "qy", "qz", "qw")
"""A TUM line's values, in order."""
UNIT_TOLERANCE = 1e-3
"""How far a quaternion's norm may be from 1 (a file written with a few decimals is that close)."""


@dataclass(frozen=True, eq=False)
class TumTrajectory:
    """A TUM file's poses on the floor plan.

    Attributes:
        time: Each pose's time stamp [s], increasing.
        x: Its x [m].
        y: Its y [m].
        heading: Its heading, the quaternion's yaw [rad, in (−π, π]]; None when not taken.
        lines: Its line in the file, for messages.
    """

    time: np.ndarray
    x: np.ndarray
    y: np.ndarray
    heading: np.ndarray | None
    lines: tuple[int, ...]


def tum_text(time: ArrayLike, x: ArrayLike, y: ArrayLike, heading: ArrayLike | None = None,
             note: str = "") -> str:
    """Poses as a TUM file's text: a comment line naming the columns, then one pose a line.

    Args:
        time: Each pose's time stamp [s].
        x: Its x [m].
        y: Its y [m].
        heading: Its heading [rad], written as the yaw quaternion; None: the identity
            quaternion on every line (no orientation is known).
        note: A comment written on the line before the columns' (none if empty; its line
            breaks become spaces).
    """
    times, xs, ys = (np.asarray(values, dtype=float).reshape(-1) for values in (time, x, y))
    half = np.zeros(times.size) if heading is None else \
        np.asarray(heading, dtype=float).reshape(-1) / 2.0
    lines = [f"# {' '.join(note.splitlines())}"] if note else []
    lines.append("# " + " ".join(TUM_COLUMNS))
    lines += [f"{t!r} {px!r} {py!r} 0.0 0.0 0.0 {qz!r} {qw!r}" for t, px, py, qz, qw in zip(
        times.tolist(), xs.tolist(), ys.tolist(), np.sin(half).tolist(), np.cos(half).tolist(),
        strict=True)]
    return "\n".join(lines) + "\n"


def quaternion_yaw(qx: np.ndarray, qy: np.ndarray, qz: np.ndarray, qw: np.ndarray
                   ) -> np.ndarray:
    """The yaw of quaternions [rad]: the heading of the rotated x-axis projected on the floor.

    ``atan2(2 (w z + x y), w² + x² − y² − z²)``, the heading itself for a pure yaw; a
    quaternion's length scales both arguments alike, so one a little off unit length (a file's
    few decimals) gives its rotation's yaw all the same. The one rule of TUM files and ROS
    messages (:mod:`azgym.logs.ros.messages`).
    """
    with np.errstate(invalid="ignore"):
        yaw: np.ndarray = np.arctan2(2.0 * (qw * qz + qx * qy),
                                     qw * qw + qx * qx - qy * qy - qz * qz)
    return yaw


def not_unit(qx: np.ndarray, qy: np.ndarray, qz: np.ndarray, qw: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray]:
    """Each quaternion's norm, and the rows of those that are no rotation.

    A rotation's quaternion has norm 1; one further than :data:`UNIT_TOLERANCE` from it is not
    an orientation (Euler angles written into its fields, say), whatever its yaw would be.
    """
    norm = np.sqrt(qx * qx + qy * qy + qz * qz + qw * qw)
    return norm, np.flatnonzero(~(np.abs(norm - 1.0) <= UNIT_TOLERANCE))


def parse_tum(file: str, data: bytes, problems: Problems, heading: bool) -> TumTrajectory | None:
    """A TUM file's poses, or None with every problem recorded (module docstring).

    Args:
        file: The file's name, for messages.
        data: Its bytes (read within the byte limit by the caller).
        problems: Where problems go.
        heading: Take the heading from the quaternions (else they are only checked to be
            numbers).
    """
    table = _table(file, data, problems)
    if table is None:
        return None
    if not table.rows:
        problems.add(file, "no pose: a TUM file holds one pose a line (timestamp tx ty tz qx "
                           "qy qz qw)")
        return None
    before = problems.total
    values = {column: floats(table, column, problems) for column in TUM_COLUMNS}
    if problems.total > before:
        return None
    time = values["timestamp"]
    back = np.flatnonzero(np.diff(time) <= 0) + 1
    if back.size:
        k = int(back[0])
        problems.add(file, f"time stamps must increase: {seconds(time[k])} after "
                           f"{seconds(time[k - 1])} ({back.size} such line(s): "
                           f"{places([table.lines[j] for j in back.tolist()])})",
                     table.lines[k], "timestamp")
        return None
    yaw = _yaw(table, values, problems) if heading else None
    if heading and yaw is None:
        return None
    return TumTrajectory(time, values["tx"], values["ty"], yaw, tuple(table.lines))


def _table(file: str, data: bytes, problems: Problems) -> Table | None:
    """The file's pose lines as a table of :data:`TUM_COLUMNS` (comments and blanks skipped)."""
    try:
        text = data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        problems.add(file, f"not UTF-8 text: byte 0x{data[exc.start]:02x} at offset "
                           f"{exc.start}")
        return None
    rows: list[list[str]] = []
    lines: list[int] = []
    cells = 0
    for number, line in enumerate(text.splitlines(), 1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        row = line.split()
        cells += len(row)
        if cells > MAX_TABLE_CELLS:
            problems.add(file, f"too many values: more than {MAX_TABLE_CELLS} by this line "
                               "(split the recording into several logs)", number)
            return None
        if len(row) != len(TUM_COLUMNS):
            problems.add(file, f"{len(row)} values, a TUM line has {len(TUM_COLUMNS)} "
                               f"({' '.join(TUM_COLUMNS)})", number)
            continue
        rows.append(row)
        lines.append(number)
    return Table(file, list(TUM_COLUMNS), rows, lines)


def _yaw(table: Table, values: dict[str, np.ndarray], problems: Problems) -> np.ndarray | None:
    """The quaternions' yaw [rad], or None when one is not a unit quaternion (recorded)."""
    quaternion = [values[column] for column in TUM_COLUMNS[4:]]
    norm, off = not_unit(*quaternion)
    if off.size:
        k = int(off[0])
        problems.add(table.file, f"the quaternion's norm is {float(norm[k])!r}, not 1 (within "
                                 f"{UNIT_TOLERANCE:g}): not an orientation ({off.size} such "
                                 f"line(s))", table.lines[k], "qw")
        return None
    yaw = quaternion_yaw(*quaternion)
    return np.where(yaw == -math.pi, math.pi, yaw)
