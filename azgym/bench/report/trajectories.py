"""A run's trajectories as TUM files that evo reads: the truth and each contender's estimates.

For a run with sequences (a route suite, a log), :meth:`~azgym.bench.report.results.BenchResult.
write` writes, per sequence, ``OUT/trajectories/truth/SEQ.tum`` and
``OUT/trajectories/CONTENDER/SEQ.tum`` (:func:`~azgym.logs.tum.tum_text`: ``timestamp tx ty tz
qx qy qz qw``, floats by ``repr``, tz = 0, the heading as a yaw quaternion). A frame's time
stamp is its time (a simulated route's time, a log's settled time). The truth file holds every
frame; a contender's holds the frames it answered, a refused frame left out and counted
(:func:`sequence_records`, in ``results.json`` and the printed summary). Position-only truth
has no orientation: its file carries the identity quaternion, says so in a comment, and the
summary records ``truth_heading: false`` (a position error needs no orientation: ``evo_ape``'s
translation part reproduces it all the same; drift is not defined). Frames on their own (no
sequence) write no trajectory.

**File names** (:func:`file_stem`): a sequence's or a contender's name with every character
but an ASCII letter, a digit, ``-`` and ``_`` turned into ``_`` (``warehouse-small/aisle-loop``
→ ``warehouse-small_aisle-loop``, ``ransac:max_iter=20`` → ``ransac_max_iter_20``), and a name
longer than :data:`MAX_STEM` cut, with 8 hexadecimal digits of its SHA-256 after the cut. Two
names that would share a file, ignoring case, are refused (:func:`trajectory_files`), as is a
contender named like the truth's folder.
"""

from __future__ import annotations

import hashlib
import math
import re
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Generic, TypedDict

import numpy as np

from azgym.bench.report.tracking import drift_figures, driven, pair_errors, sequences
from azgym.bench.run.outcome import RunOutcome
from azgym.bench.suites import Case
from azgym.errors import InvalidInputError
from azgym.files import prepare_folder, write_file
from azgym.logs.tum import tum_text
from azgym.metrics import Drift, Figure

__all__ = ["FOLDER", "MAX_STEM", "TRAJECTORY_FILES", "TRUTH", "SequenceRecord",
           "TrajectoryFiles", "file_stem", "sequence_records", "trajectory_files",
           "write_trajectories"]

FOLDER = "trajectories"
"""The folder of a run's output that holds its TUM files."""
TRUTH = "truth"
"""The truth's folder in it."""
TRAJECTORY_FILES = f"{FOLDER}/*/*.tum"
"""The TUM files a run writes into its output folder, as a pattern (claimed like its others)."""
MAX_STEM = 100
"""The longest file name stem written; a longer name is cut and marked (:func:`file_stem`)."""
_UNSAFE = re.compile(r"[^A-Za-z0-9_-]")


class SequenceRecord(TypedDict, Generic[Figure]):
    """One contender on one sequence: what its TUM file holds and its figures there.

    Attributes:
        frames: The sequence's frames.
        written: The frames answered: the lines of its TUM file.
        refused: The frames left out (no estimate).
        rmse_cm: The position RMSE over the answered frames [cm] (``evo_ape``'s rmse, in m,
            times 100).
        drift: Its drift per distance (:func:`~azgym.bench.report.tracking.drift_metrics`);
            None on a sequence that is not driven.
    """

    frames: int
    written: int
    refused: int
    rmse_cm: Figure
    drift: list[Drift[Figure]] | None


class TrajectoryFiles(TypedDict):
    """Where a run's TUM files are, relative to its output folder (module docstring).

    Attributes:
        folder: :data:`FOLDER`.
        truth_heading: Whether the truth files carry the true heading (False: position-only
            truth, the identity quaternion written).
        folders: The folder of :data:`TRUTH` and of each contender, by its label.
        files: Each sequence's file name in every folder.
    """

    folder: str
    truth_heading: bool
    folders: dict[str, str]
    files: dict[str, str]


def file_stem(name: str) -> str:
    """A name as a file name's stem: the rule of the module docstring."""
    stem = _UNSAFE.sub("_", name)
    if len(stem) <= MAX_STEM:
        return stem
    return f"{stem[:MAX_STEM - 9]}-{hashlib.sha256(name.encode()).hexdigest()[:8]}"


def trajectory_files(labels: Sequence[str], cases: Sequence[Case]) -> TrajectoryFiles | None:
    """The TUM files of a run's contenders on its cases; None without sequences.

    Raises:
        InvalidInputError: Two contenders (or a contender and the truth), or two sequences,
            would share a file name (ignoring case).
    """
    found = sequences(cases)
    if not found:
        return None
    folders = [(TRUTH, TRUTH, "the truth")] + [(label, file_stem(label), f"the contender "
                                                 f"{label!r}") for label in labels]
    files = [(name, f"{file_stem(name)}.tum", f"the sequence {name!r}") for name in found]
    truth_heading = not any(math.isnan(cases[k].pose[2]) for frames in found.values()
                            for k in frames)
    return {"folder": FOLDER, "truth_heading": truth_heading, "folders": _unique(folders),
            "files": _unique(files)}


def _unique(names: list[tuple[str, str, str]]) -> dict[str, str]:
    """Each name's file, from (name, file, what it is) triples.

    Raises:
        InvalidInputError: Two files are the same, or differ only in case.
    """
    seen: dict[str, str] = {}
    for _name, file, what in names:
        if file.lower() in seen:
            raise InvalidInputError(
                f"trajectories: {seen[file.lower()]} and {what} would both be written as "
                f"{file!r} (in a file name, every character but an ASCII letter, a digit, '-' "
                "and '_' becomes '_', and case is ignored); rename one")
        seen[file.lower()] = what
    return {name: file for name, file, _what in names}


def sequence_records(cases: Sequence[Case], outcome: RunOutcome
                     ) -> dict[str, SequenceRecord[float]]:
    """One contender's record of each sequence: frames written and refused, RMSE, drift."""
    records: dict[str, SequenceRecord[float]] = {}
    is_driven = driven(cases)
    for name, frames in sequences(cases).items():
        written = int(np.count_nonzero(outcome.ok[frames]))
        records[name] = {
            "frames": len(frames), "written": written, "refused": len(frames) - written,
            "rmse_cm": outcome.select(np.array(frames)).stats()["rmse_cm"],
            "drift": drift_figures(pair_errors(cases, outcome, frames)) if is_driven else None}
    return records


def write_trajectories(out: Path, files: TrajectoryFiles, cases: Sequence[Case],
                       outcomes: Mapping[str, RunOutcome]) -> Path:
    """Write the truth's and every contender's TUM files into ``out/trajectories``.

    Returns:
        The folder written.
    """
    root = prepare_folder(out / files["folder"])
    found = sequences(cases)
    note = "" if files["truth_heading"] else \
        "orientation: the identity (the truth has no heading: not a measurement)"
    truth = prepare_folder(root / files["folders"][TRUTH])
    for name, frames in found.items():
        poses = np.array([cases[k].pose for k in frames], dtype=float).reshape(-1, 3)
        write_file(truth / files["files"][name], tum_text(
            [cases[k].time for k in frames], poses[:, 0], poses[:, 1],
            poses[:, 2] if files["truth_heading"] else None, note))
    for label, outcome in outcomes.items():
        folder = prepare_folder(root / files["folders"][label])
        for name, frames in found.items():
            answered = [k for k in frames if outcome.ok[k]]
            estimate = outcome.estimate[answered]
            write_file(folder / files["files"][name], tum_text(
                [cases[k].time for k in answered], estimate[:, 0], estimate[:, 1],
                estimate[:, 2], f"{label} on {name}: {len(frames) - len(answered)} refused "
                                "frame(s) left out"))
    return root
