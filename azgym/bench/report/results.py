"""A run's results: each contender's per-case outcome, the summary, and the files they are kept in.

``results.json`` holds the summary (overall, by cause, by group, runtimes, tracks, drift, and
per sequence what its TUM files hold); ``frames.csv`` every case's outcome, in the columns of
:data:`FRAME_COLUMNS`, which the leaderboard's per-frame files share; ``trajectories/`` the TUM
files of a run with sequences (:mod:`azgym.bench.report.trajectories`). A frame is numbered as
its recording numbers it (a log's ``frame`` column, ``Case.frame``), else by its place among
the cases (0, 1, …). A heading error is NaN where the truth has no heading (position-only
truth); the estimate's columns are NaN where there is no estimate.
"""

from __future__ import annotations

import csv
import hashlib
import importlib.util
import io
import json
import math
import sys
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TypedDict

import numpy as np

from azgym._version import __version__
from azgym.bench.leaderboard.plugin_files import plugin_record
from azgym.bench.report.summary import ContenderMetrics, ContenderRow, DatasetSummary, Summary
from azgym.bench.report.tracking import drift_metrics, tracking_metrics
from azgym.bench.report.trajectories import (
    sequence_records,
    trajectory_files,
    write_trajectories,
)
from azgym.bench.run.contenders import Contender
from azgym.bench.run.outcome import Outcome, RunOutcome
from azgym.bench.suites import CAUSES, Case, Suite
from azgym.core import BeaconMap
from azgym.files import prepare_folder, write_file
from azgym.metrics import bootstrap_blocks, confidence_intervals
from azgym.profile import Profile, profile_toml

__all__ = ["ESTIMATE_COLUMNS", "FRAME_COLUMNS", "OUTCOME_COLUMNS", "BenchResult", "cases_digest",
           "contender_metrics", "frame_number", "frame_rows", "summarize"]

OUTCOME_COLUMNS = ["localizer", "frame", "scenario", "group", "cause", "ok", "position_error_m",
                   "heading_error_rad", "micros", "error"]
"""A frame's outcome: the columns of a per-frame results file without the estimate (all of
them before the estimate was added: such a leaderboard entry's file still reads)."""
ESTIMATE_COLUMNS = ["estimate_x_m", "estimate_y_m", "estimate_heading_rad"]
"""The estimated pose (NaN without one), from which the drift figures are computed."""
FRAME_COLUMNS = OUTCOME_COLUMNS + ESTIMATE_COLUMNS
"""The columns of a per-frame results file (``frames.csv``, and a leaderboard entry's)."""


class _DatasetField(TypedDict, total=False):
    """A run on a log's ``dataset`` (and nothing for a suite's run)."""

    dataset: DatasetSummary


def summarize(suite: Suite, split: str, seed: int, quick: bool,
              contenders: Sequence[Contender], cases: Sequence[Case],
              outcomes: Mapping[str, RunOutcome], reference: str, *, profile: Profile | None,
              given: Profile | None, dataset: DatasetSummary | None = None) -> Summary:
    """Every contender's figures and records of sequences, and where the run's TUM files go.

    A contender's row holds its metrics (:func:`contender_metrics`: overall, by cause, by
    group, runtimes, tracks, drift) and its record of each sequence
    (:func:`~azgym.bench.report.trajectories.sequence_records`).

    Args:
        suite: The suite run.
        split: "dev" or "test".
        seed: The seed the cases were drawn from.
        quick: Whether the suite's small version was run.
        contenders: Who ran.
        cases: The cases.
        outcomes: Each contender's outcome, by label.
        reference: The label whose median runtime the others are compared with.
        profile: The profile applied (None: none).
        given: The profile given for the run (None: none).
        dataset: The log a run on a log scored (None: a suite's run).
    """
    reference_us = float(np.nanmedian(outcomes[reference].micros))
    trajectories = trajectory_files([contender.label for contender in contenders], cases)
    results: dict[str, ContenderRow] = {}
    for contender in contenders:
        outcome = outcomes[contender.label]
        results[contender.label] = {
            "spec": contender.spec, "params": contender.params,
            **plugin_record(contender.spec, contender.params),
            **contender_metrics(outcome, cases, reference_us),
            "crashes": sum(1 for e in outcome.errors if e),
            "first_error": next((e for e in outcome.errors if e), ""),
            "sequences": sequence_records(cases, outcome),
        }
    run_on: _DatasetField = {} if dataset is None else {"dataset": dataset}
    return {"suite": suite.name, "suite_version": suite.version, "split": split, "seed": seed,
            "quick": quick, "n_frames": len(cases), "cases_sha256": cases_digest(cases),
            "azgym_version": __version__, "python": sys.version.split()[0],
            "localizers": results, **run_on, "profile": profile_toml(profile or Profile()),
            "profile_given": profile_toml(given or Profile()), "trajectories": trajectories}


def contender_metrics(outcome: Outcome, cases: Sequence[Case], reference_us: float
                      ) -> ContenderMetrics[float]:
    """One contender's figures: overall, 95 % intervals, by cause, by group, runtimes, tracks.

    The intervals resample a route's frames in blocks of a few seconds, frames on their own
    one by one (:func:`~azgym.metrics.bootstrap_blocks`).

    The one rule for them: the runner's summary and a leaderboard entry's check (which
    recomputes them from the entry's per-frame results and the suite's cases, drawn again) both
    call this. ``tracking`` is :func:`~azgym.bench.report.tracking.tracking_metrics` (None for cases
    without driven sequences); ``drift`` is
    :func:`~azgym.bench.report.tracking.drift_metrics`, there only when the outcome holds the
    estimates (a :class:`RunOutcome`: a per-frame file written before the estimate was added
    has none).

    Args:
        outcome: Its outcome on each case.
        cases: The cases (their causes and groups; their sequences, times and events).
        reference_us: The reference localizer's median runtime in the same run [µs].
    """
    groups = [case.group for case in cases]
    cause_of = np.array([case.cause for case in cases], dtype=object)
    group_of = np.array(groups, dtype=object)
    timed = outcome.micros[np.isfinite(outcome.micros)]
    median_us = float(np.median(timed)) if timed.size else math.nan
    metrics: ContenderMetrics[float] = {
        "all": outcome.stats(),
        "ci95": confidence_intervals(outcome.position, outcome.ok, bootstrap_blocks(
            [case.sequence for case in cases], [case.time for case in cases])),
        "by_cause": {c: outcome.select(cause_of == c).stats() for c in CAUSES
                     if (cause_of == c).any()},
        "by_group": {g: outcome.select(group_of == g).stats() for g in dict.fromkeys(groups)},
        "runtime_us": {"median": median_us,
                       "p99": float(np.percentile(timed, 99)) if timed.size else math.nan,
                       "ratio_to_ransac": median_us / reference_us,
                       "reference_us": reference_us},
        "tracking": tracking_metrics(cases, outcome),
    }
    if isinstance(outcome, RunOutcome):
        metrics["drift"] = drift_metrics(cases, outcome)
    return metrics


def cases_digest(cases: Sequence[Case]) -> str:
    """SHA-256 of the cases a run drew: scenario, group, cause, true pose and measurements.

    A leaderboard entry stores it, and its check redraws the suite and compares, so an entry's
    per-frame results are known to cover exactly the suite's frames. Numbers are rounded to
    1e-9 (m, rad) first, so that the last bit of a float, which may differ between machines,
    does not change the digest.
    """
    digest = hashlib.sha256()
    for case in cases:
        m = case.measurements
        digest.update("\0".join((case.scenario, case.group, case.cause, "")).encode())
        for values in (case.pose, m.azimuth, () if m.quality is None else m.quality):
            array = np.round(np.asarray(values, dtype=float), 9) + 0.0  # + 0.0: no -0.0
            digest.update(repr(array.shape).encode() + array.tobytes())
        digest.update(np.asarray(m.ids, dtype=np.int64).tobytes())
    return digest.hexdigest()


def frame_number(case: Case, place: int) -> int:
    """A case's frame number in results: the recording's (``Case.frame``), else its place."""
    return place if case.frame is None else case.frame


def frame_rows(label: str, cases: Sequence[Case], outcome: RunOutcome) -> list[list[str]]:
    """One contender's rows of a per-frame results file (:data:`FRAME_COLUMNS`)."""
    return [[label, str(frame_number(case, k)), case.scenario, case.group, case.cause,
             str(int(outcome.ok[k])),
             f"{outcome.position[k]:.17g}", f"{outcome.heading[k]:.17g}",
             f"{outcome.micros[k]:.3f}", outcome.errors[k],
             *(f"{value:.17g}" for value in outcome.estimate[k].tolist())]
            for k, case in enumerate(cases)]


@dataclass
class BenchResult:
    """A benchmark run: the summary (results.json) and every case's outcome (frames.csv).

    ``maps`` holds, by scenario name, the beacon maps that are no shipped scenario (a log's
    ``beacons.csv``): the figures draw them from their beacons.
    """

    summary: Summary
    cases: list[Case]
    outcomes: dict[str, RunOutcome]
    maps: dict[str, BeaconMap] = field(default_factory=dict)

    def write(self, out: Path, figures: bool = True) -> list[Path]:
        """Write results.json, frames.csv, the TUM files and, with matplotlib, the figures.

        Args:
            out: The folder.
            figures: Draw the figures too (when matplotlib is installed).

        Returns:
            The files written, and the folder of the TUM files (when there are sequences).
        """
        prepare_folder(out)
        summary_path = write_file(out / "results.json", json.dumps(self.summary, indent=1) + "\n")
        table = io.StringIO(newline="")
        writer = csv.writer(table)
        writer.writerow(FRAME_COLUMNS)
        for label, outcome in self.outcomes.items():
            writer.writerows(frame_rows(label, self.cases, outcome))
        written = [summary_path, write_file(out / "frames.csv", table.getvalue())]
        if (trajectories := self.summary["trajectories"]) is not None:
            written.append(write_trajectories(out, trajectories, self.cases, self.outcomes))
        if figures and importlib.util.find_spec("matplotlib") is not None:
            from azgym.bench.report.plots import write_figures

            written += write_figures(self.summary, self.cases, self.outcomes, out, self.maps)
        return written
