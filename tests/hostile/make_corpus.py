"""Write the hostile leaderboard entries of ``tests/hostile/entries/``.

    PYTHONPATH=. python tests/hostile/make_corpus.py

Each entry is a sound one with one attack on it: ``sound`` (``lsq`` on the stress suite's quick
dev split) for most, ``sound-track`` (``lsq`` on route-events, whose entries carry the figures of
tracks) for the attacks on track figures. Where the attack needs it, the attacker's own
bookkeeping (the SHA-256 of the per-frame file, the figures recomputed from the forged rows) is
redone, so that the check under test is the one that must catch it. ``test_hostile_entries.py``
pins each to its message. Run this again when the entry format or the version of either suite
changes (a ``sound`` entry then fails its test).
"""

from __future__ import annotations

import copy
import csv
import dataclasses
import gzip
import hashlib
import io
import json
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from azgym.bench.leaderboard.checks import ENTRY_FORMAT, clean
from azgym.bench.leaderboard.entries import frames_file_text, make_entry
from azgym.bench.report.results import contender_metrics
from azgym.bench.run.outcome import Outcome
from azgym.bench.run.runner import Contender, run_benchmark
from azgym.bench.suites import Case, get_suite

CORPUS = Path(__file__).resolve().parent / "entries"
Rows = list[list[str]]
Attack = Callable[[dict[str, Any], Rows], Any]


STRESS_CASES: list[Case] = []
"""The stress suite's cases the sound entry was scored on (``main`` fills it)."""


def reseal(entry: dict[str, Any], rows: Rows, figures: bool = False) -> str:
    """The forged rows as a file, with the entry's SHA-256 (and figures) made to match.

    The figures are those of the stress cases the rows name (frame column), as the rows label
    them (group and cause columns).
    """
    text = frames_file_text(rows)
    entry["results_sha256"] = hashlib.sha256(text.encode()).hexdigest()
    if figures:
        outcome_rows = [(r[5] == "1", float(r[6]), float(r[7]), float(r[8]), r[9]) for r in rows]
        ok, position, heading, micros, errors = zip(*outcome_rows, strict=True)
        outcome = Outcome(np.array(ok), np.array(position), np.array(heading), np.array(micros),
                          list(errors))
        cases = [dataclasses.replace(STRESS_CASES[int(r[1])], group=r[3], cause=r[4])
                 for r in rows]
        reference = entry["metrics"]["runtime_us"]["reference_us"]
        entry["metrics"] = clean(contender_metrics(outcome, cases, reference))
        entry["n_frames"] = len(rows)
    return text


def set_cell(rows: Rows, row: int, column: int, value: str) -> Rows:
    rows = copy.deepcopy(rows)
    rows[row][column] = value
    return rows


def estimated(rows: Rows) -> int:
    """The first row with an estimate."""
    return next(k for k, row in enumerate(rows) if row[5] == "1")


def nested(depth: int) -> str:
    return "[" * depth + "]" * depth


ATTACKS: dict[str, Attack] = {
    "sound": lambda e, r: None,
    "five-frames": lambda e, r: reseal(e, r[:5], figures=True),
    "fake-cases-digest": lambda e, r: (reseal(e, r[:5], figures=True),
                                       e.update(cases_sha256="0" * 64))[0],
    "negative-error": lambda e, r: reseal(e, [[*x[:6], "-5", *x[7:]] if x[5] == "1" else x
                                              for x in r]),
    "infinite-error": lambda e, r: reseal(e, set_cell(r, estimated(r), 6, "inf")),
    "error-without-estimate": lambda e, r: reseal(e, set_cell(set_cell(r, estimated(r), 5, "0"),
                                                              estimated(r), 6, "0.01")),
    "negative-runtime": lambda e, r: reseal(e, set_cell(r, 0, 8, "-1.0")),
    "short-row": lambda e, r: reseal(e, [r[0], r[1][:3], *r[2:]]),
    "non-numeric": lambda e, r: reseal(e, set_cell(r, 2, 7, "abc")),
    "duplicate-frame": lambda e, r: reseal(e, [r[0], r[0], *r[2:]], figures=True),
    "relabelled-cause": lambda e, r: reseal(e, set_cell(r, 3, 4, "outlier" if r[3][4] != "outlier"
                                                        else "clean"), figures=True),
    "two-localizers": lambda e, r: reseal(e, set_cell(r, 1, 0, "ransac")),
    "edited-ci95": lambda e, r: e["metrics"]["ci95"]["p75_all_cm"].__setitem__(0, 0.01),
    "edited-runtime": lambda e, r: e["metrics"]["runtime_us"].update(median=0.5),
    "edited-ratio": lambda e, r: e["metrics"]["runtime_us"].update(ratio_to_ransac=0.01),
    "edited-by-cause": lambda e, r: next(iter(e["metrics"]["by_cause"].values())).update(
        p75_cm=0.0),
    "dropped-group": lambda e, r: (e["metrics"]["by_group"].popitem(), None)[1],
    "negative-p75": lambda e, r: e["metrics"]["all"].update(p75_cm=-500.0),
    "full-size-claimed": lambda e, r: e.update(quick=False),
    "test-split-on-dev-seed": lambda e, r: e.update(split="test"),
    "other-seed": lambda e, r: e.update(seed=14),
    "negative-seed": lambda e, r: e.update(seed=-1),
    "future-version": lambda e, r: e.update(azgym_version="99.9-from-the-future"),
    "newer-version": lambda e, r: e.update(azgym_version="99.9"),
    "not-a-date": lambda e, r: e.update(timestamp="not a date"),
    "no-time-zone": lambda e, r: e.update(timestamp="2026-01-01T00:00:00"),
    "future-date": lambda e, r: e.update(timestamp="2999-01-01T00:00:00+00:00"),
    "other-suite-version": lambda e, r: e.update(suite_version=99),
    "old-format": lambda e, r: e.update(format=2),
    "impostor": lambda e, r: e.update(name="sound"),
    "borrowed-results": lambda e, r: e.update(results_file="sound.frames.csv.gz"),
    "absolute-plugin": lambda e, r: e.update(localizer={"spec": "/tmp/evil.py:Evil",
                                                        "params": {}, "sha256": "0" * 64}),
    "plugin-without-hash": lambda e, r: e.update(localizer={"spec": "evil.py:Evil",
                                                            "params": {}}),
    "extra-figure": lambda e, r: e["metrics"]["all"].update(rank=1),
    "tracks-without-routes": lambda e, r: e["metrics"].update(tracking={
        "availability_after_first_fix": 1.0, "max_cm_outside_kidnaps": 5.0,
        "frames_over_1m_outside_kidnaps": 0, "events": []}),
}
"""Attacks on the entry (and its rows), by the name of the corpus entry."""

TRACK_ATTACKS: dict[str, Attack] = {
    "sound-track": lambda e, r: None,
    "edited-recovery": lambda e, r: e["metrics"]["tracking"]["events"][1].update(recovery_s=0.1),
    "edited-track-max": lambda e, r: e["metrics"]["tracking"].update(max_cm_outside_kidnaps=9.5),
    "dropped-tracking": lambda e, r: e["metrics"].update(tracking=None),
}
"""Attacks on the track figures of an entry on route-events (its second event: a kidnapping)."""

RAW: dict[str, Callable[[], tuple[str, bytes | None]]] = {
    "deep-json": lambda: (f'{{"format": {ENTRY_FORMAT}, "name": {nested(20)}}}', None),
    "recursion-json": lambda: (f'{{"format": {ENTRY_FORMAT}, "name": {nested(5000)}}}', None),
    "nan-json": lambda: (f'{{"format": {ENTRY_FORMAT}, "n_frames": NaN}}', None),
    "not-json": lambda: ("{not json", None),
}
"""Entries that are not even JSON objects one can read: their text (and frames bytes)."""


def frames_payloads() -> dict[str, bytes]:
    """Per-frame files that are no CSV one can read, for copies of the sound entry."""
    bomb = gzip.compress(b"0" * (64 * 2**20 + 1), compresslevel=9, mtime=0)
    huge = gzip.compress(frames_file_text([]).encode() + b'"' + b"x" * 200_000 + b'"\n', mtime=0)
    return {"gzip-bomb": bomb, "not-gzip": b"plain text, not gzip", "huge-field": huge}


def sound(suite: str) -> tuple[dict[str, Any], str, list[Case]]:
    """A sound entry of ``lsq`` on the suite's quick dev split, its per-frame text and cases."""
    with tempfile.TemporaryDirectory() as folder:
        result = run_benchmark(get_suite(suite), [Contender("lsq", "lsq")], quick=True)
        result.write(Path(folder), figures=False)
        base, text = make_entry(Path(folder), "lsq", CORPUS, name="sound", version="1.0",
                                authors=["A. Author"], link="")
    base.update(timestamp="2026-01-01T00:00:00+00:00",
                machine={"platform": "Linux", "processor": "x86_64", "cpus": 2,
                         "python": "3.11.7"})
    return base, text, result.cases


def main() -> None:
    stress, stress_text, cases = sound("stress")
    STRESS_CASES[:] = cases
    track, track_text, _ = sound("route-events")
    for old in CORPUS.glob("*"):
        old.unlink()
    CORPUS.mkdir(exist_ok=True)
    for base, text, attacks in ((stress, stress_text, ATTACKS),
                                (track, track_text, TRACK_ATTACKS)):
        rows = list(csv.reader(io.StringIO(text)))[1:]
        for name, attack in attacks.items():
            entry = copy.deepcopy(base) | {"name": name, "results_file": f"{name}.frames.csv.gz"}
            frames = attack(entry, rows)
            write(name, json.dumps(entry, indent=1, allow_nan=False),
                  gzip.compress((frames or text).encode(), mtime=0))
    for name, payload in frames_payloads().items():
        entry = copy.deepcopy(stress) | {"name": name, "results_file": f"{name}.frames.csv.gz"}
        if name == "huge-field":  # the attacker seals it: the CSV reader must catch it
            entry["results_sha256"] = hashlib.sha256(gzip.decompress(payload)).hexdigest()
        write(name, json.dumps(entry, indent=1), payload)
    for name, make in RAW.items():
        write(name, *make())


def write(name: str, entry_text: str, frames: bytes | None) -> None:
    (CORPUS / f"{name}.json").write_text(entry_text + "\n", encoding="utf-8")
    if frames is not None:
        (CORPUS / f"{name}.frames.csv.gz").write_bytes(frames)


if __name__ == "__main__":
    main()
