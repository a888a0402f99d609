"""The shapes of a run's results: the summary (``results.json``) and a contender's row in it.

:mod:`azgym.bench.report.results` builds them; a leaderboard entry keeps a row's figures
(:class:`ContenderMetrics`) and a run on a log's :class:`Dataset`. A figure is a float as
computed, or float or None as an entry stores it (:class:`~azgym.metrics.Figure`).
"""

from __future__ import annotations

from typing import Any, Generic, NotRequired, TypedDict

from azgym.bench.report.tracking import TrackFigures
from azgym.bench.report.trajectories import SequenceRecord, TrajectoryFiles
from azgym.metrics import Drift, ErrorStats, Figure, Intervals

__all__ = ["ContenderMetrics", "ContenderRow", "Dataset", "DatasetSummary", "RunIdentity",
           "Runtimes", "Summary"]


class Runtimes(TypedDict, Generic[Figure]):
    """A contender's runtime per frame [µs]: median, p99, median over the reference's median."""

    median: Figure
    p99: Figure
    ratio_to_ransac: Figure
    reference_us: float


class ContenderMetrics(TypedDict, Generic[Figure]):
    """A contender's figures, as results.json and an entry keep them.

    :func:`~azgym.bench.report.results.contender_metrics` computes them; see
    :class:`~azgym.metrics.Figure` for the type of a figure. ``drift`` (None without driven
    sequences) is absent from an entry whose per-frame file holds no estimates (one made
    before they were written).
    """

    all: ErrorStats[Figure]
    ci95: Intervals[Figure]
    by_cause: dict[str, ErrorStats[Figure]]
    by_group: dict[str, ErrorStats[Figure]]
    runtime_us: Runtimes[Figure]
    tracking: TrackFigures[Figure] | None
    drift: NotRequired[list[Drift[Figure]] | None]


class ContenderRow(ContenderMetrics[float]):
    """A contender's row of a run's summary: who it is, its figures and its failures.

    Attributes:
        spec: Its spec.
        params: Its hyperparameters.
        file: A plug-in's file (absolute; absent for a built-in or a missing file).
        file_sha256: The SHA-256 of that file.
        weights_file: The weight file its ``weights`` hyperparameter names (absolute; absent
            for the shipped weights or a file that cannot be read).
        weights_sha256: The SHA-256 of that file.
        crashes: The frames on which it raised.
        first_error: The first exception it raised ("" for none).
        sequences: Its record of each sequence (its TUM file's frames and refusals, RMSE,
            drift: :func:`~azgym.bench.report.trajectories.sequence_records`).
    """

    spec: str
    params: dict[str, Any]
    file: NotRequired[str]
    file_sha256: NotRequired[str]
    weights_file: NotRequired[str]
    weights_sha256: NotRequired[str]
    crashes: int
    first_error: str
    sequences: dict[str, SequenceRecord[float]]


class Dataset(TypedDict):
    """The log a run on a log scored (``azgym bench --data``), as a leaderboard entry keeps it."""

    name: str
    sha256: str
    format: int
    simulated: bool


class DatasetSummary(Dataset):
    """The log as a run's summary keeps it: with its description."""

    description: str


class RunIdentity(TypedDict):
    """What a run drew, which a run's summary and a leaderboard entry both carry.

    The suite (or log), its version, split, seed and size, the cases' digest, and the azgym
    that ran them.
    """

    suite: str
    suite_version: int
    split: str
    seed: int
    quick: bool
    n_frames: int
    cases_sha256: str
    azgym_version: str


class Summary(RunIdentity):
    """A run's summary (``results.json``): the run, and each contender's row by its label.

    ``dataset`` is a run on a log's; ``profile`` the profile applied (the contenders'
    defaults, and the simulator's noise), ``profile_given`` the one given for the run
    (:func:`~azgym.profile.profile_toml`; empty: none); ``trajectories`` where the run's TUM
    files are (None: no sequences, none written).
    """

    python: str
    localizers: dict[str, ContenderRow]
    dataset: NotRequired[DatasetSummary]
    profile: dict[str, dict[str, Any]]
    profile_given: dict[str, dict[str, Any]]
    trajectories: TrajectoryFiles | None
