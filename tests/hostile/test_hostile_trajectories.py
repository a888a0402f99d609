"""Hostile inputs to the TUM files and drift figures: each refused by name, nothing written astray.

A log's sequence names choose file names (so do plug-in specs): they must not escape the run's
``trajectories/`` folder, nor break a TUM file that evo reads. A planted link must not redirect
the writes, nor a contender take the truth's folder. On the leaderboard, the drift figures come
from the estimates a per-frame file holds: estimates that do not give the file's errors, drift
figures edited, dropped or claimed without estimates are each refused, the attacker having
redone the bookkeeping (SHA-256, figures) where the attack needs it.
"""

from __future__ import annotations

import csv
import gzip
import hashlib
import io
import json
import math
import re

import pytest
from logs.mini_log import mini_files, write_log

from azgym.bench.leaderboard import entries as L
from azgym.bench.leaderboard.checks import clean, suite_cases
from azgym.bench.leaderboard.entry_files import parse_frames
from azgym.bench.report.results import OUTCOME_COLUMNS, contender_metrics
from azgym.bench.run.runner import Contender, run_benchmark, run_log_benchmark
from azgym.bench.suites import get_suite
from azgym.errors import InvalidInputError
from azgym.logs import read_log

ESCAPES = ["../../../escaped", "/tmp/absolute", "a\nline break"]
"""Sequence names a log may hold that must not become paths, or lines, of their own."""


def test_a_log_s_sequence_names_never_leave_the_trajectories_folder(tmp_path):
    files = mini_files()
    lines = files["frames.csv"].splitlines()
    files["frames.csv"] = "\n".join([lines[0] + ",sequence"] + [
        f'{line},"{name}"' for line, name in zip(lines[1:], ESCAPES, strict=True)]) + "\n"
    log = read_log(write_log(tmp_path / "log", files))
    out = tmp_path / "deep" / "er" / "run"
    run_log_benchmark(log, [Contender("gated-ekf", "gated-ekf")]).write(out, figures=False)
    written = sorted(path.relative_to(tmp_path).as_posix() for path in tmp_path.rglob("*.tum"))
    assert written == sorted(f"deep/er/run/trajectories/{who}/{name}.tum"
                             for who in ("truth", "gated-ekf", "ransac")
                             for name in ("_________escaped", "_tmp_absolute", "a_line_break"))
    text = (out / "trajectories" / "gated-ekf" / "a_line_break.tum").read_text()
    assert text.splitlines()[0] == "# gated-ekf on a line break: 0 refused frame(s) left out"
    assert all(line.startswith("#") or len(line.split()) == 8 for line in text.splitlines())


def test_a_planted_link_in_place_of_the_trajectories_folder_is_refused(tmp_path):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    out = tmp_path / "run"
    out.mkdir()
    (out / "trajectories").symlink_to(elsewhere)
    result = run_benchmark(get_suite("warehouse-routes"), [Contender("lsq", "lsq")], quick=True)
    with pytest.raises(InvalidInputError, match="trajectories: is a symbolic link"):
        result.write(out, figures=False)
    assert list(elsewhere.iterdir()) == []


def test_a_contender_named_like_the_truth_s_folder_is_refused_before_any_file(tmp_path):
    with pytest.raises(InvalidInputError, match="the truth and the contender 'truth' would "
                                                "both be written as 'truth'"):
        run_benchmark(get_suite("warehouse-routes"), [Contender("truth", "lsq")], quick=True)


@pytest.fixture(scope="module")
def routes(tmp_path_factory):
    """lsq on warehouse-routes (quick), written: an entry with estimates and drift figures."""
    out = tmp_path_factory.mktemp("routes")
    run_benchmark(get_suite("warehouse-routes"), [Contender("lsq", "lsq")], quick=True).write(
        out, figures=False)
    return out


@pytest.fixture
def entry(routes, tmp_path):
    return L.submit(routes, "lsq", tmp_path / "entries", name="lsq-routes", version="1",
                    authors=["a"])


def forge(path, change_rows=None, change_entry=None, figures=False):
    """Edit an entry's rows and fields, redoing the SHA-256 (and the figures, if asked)."""
    frames = path.parent / f"{path.stem}.frames.csv.gz"
    header, *rows = list(csv.reader(io.StringIO(gzip.decompress(frames.read_bytes()).decode())))
    entry = json.loads(path.read_text())
    if change_rows is not None:
        header = change_rows(header, rows) or header
    text = L.frames_file_text(rows, header)
    frames.write_bytes(gzip.compress(text.encode()))
    entry["results_sha256"] = hashlib.sha256(text.encode()).hexdigest()
    if figures:
        _, cases = suite_cases(entry["suite"], entry["suite_version"], entry["seed"],
                               entry["quick"])
        entry["metrics"] = clean(contender_metrics(parse_frames(text, "forged").outcome, cases,
                                                   entry["metrics"]["runtime_us"][
                                                       "reference_us"]))
    if change_entry is not None:
        change_entry(entry)
    path.write_text(json.dumps(entry))


def smooth(header, rows):
    """A jittery tracker's attack: each heading replaced by the next answered frame's (a
    smoother track, a lower drift), the errors left as they were."""
    answered = [row for row in rows if row[5] == "1"]
    for row, later in zip(answered, answered[1:], strict=False):
        row[12] = later[12]


def drop_estimates(header, rows):
    rows[:] = [row[:len(OUTCOME_COLUMNS)] for row in rows]
    return OUTCOME_COLUMNS


ATTACKS = {
    "estimates-that-do-not-give-the-errors":
        (dict(change_rows=smooth, figures=True), "column heading_error_rad: "),
    "an-estimate-where-there-is-none":
        (dict(change_rows=lambda h, r: next(row for row in r if row[5] == "0").__setitem__(
            10, "1.5")), "column estimate_x_m: must be NaN where ok is 0 (no estimate), got 1.5"),
    "no-estimate-where-there-is-one":
        (dict(change_rows=lambda h, r: next(row for row in r if row[5] == "1").__setitem__(
            11, "nan")), "column estimate_y_m: must be finite where ok is 1, got nan"),
    "edited-drift":
        (dict(change_entry=lambda e: e["metrics"]["drift"][1].update(translation_pct=0.01)),
         "metrics/drift/1/translation_pct: the entry says 0.01, its per-frame results give"),
    "dropped-drift":
        (dict(change_entry=lambda e: e["metrics"].pop("drift")),
         "metrics: the entry has ['all', 'by_cause', 'by_group', 'ci95', 'runtime_us', "
         "'tracking'], its per-frame results give ['all', 'by_cause', 'by_group', 'ci95', "
         "'drift',"),
    "drift-without-estimates":
        (dict(change_rows=drop_estimates),
         "metrics: the entry has ['all', 'by_cause', 'by_group', 'ci95', 'drift', "
         "'runtime_us', 'tracking'], its per-frame results give ['all', 'by_cause', "
         "'by_group', 'ci95', 'runtime_us', 'tracking']"),
}


@pytest.mark.parametrize("name", sorted(ATTACKS))
def test_a_forged_estimate_or_drift_figure_is_refused(entry, name):
    attack, message = ATTACKS[name]
    forge(entry, **attack)
    with pytest.raises(L.LeaderboardError, match=re.escape(message)) as caught:
        L.load_entry(entry)
    assert "lsq-routes.json" in str(caught.value)


def test_the_sound_entry_carries_its_run_s_drift_and_an_old_one_without_estimates_reads(
        entry, routes):
    drift = L.load_entry(entry)["metrics"]["drift"]
    run = json.loads((routes / "results.json").read_text())["localizers"]["lsq"]["drift"]
    assert drift == clean(run) and [d["distance_m"] for d in drift] == [1.0, 5.0, 10.0]
    assert all(d["pairs"] > 0 and math.isfinite(d["translation_pct"]) for d in drift[1:])
    # A file of the columns before the estimates, figures without drift: sound as it was.
    forge(entry, change_rows=drop_estimates,
          change_entry=lambda e: e["metrics"].pop("drift"))
    assert "drift" not in L.load_entry(entry)["metrics"]
