"""Hostile leaderboard entries: each is refused with a message naming what is wrong, never a crash.

The corpus (``tests/hostile/entries/``, written by ``make_corpus.py``) is two sound entries
(``sound`` on the stress suite, ``sound-track`` on route-events, whose entries carry the figures
of tracks) and copies of them with one attack each: figures forged (track figures too), frames
left out or relabelled, rows that no run writes, claims about the run edited, files that are
not what they say (deeply nested JSON, a gzip bomb). The attacker redoes the bookkeeping
(SHA-256, figures) where the attack needs it.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from azgym.bench.leaderboard import entries as L

CORPUS = Path(__file__).resolve().parent / "entries"
SOUND = {"sound", "sound-track"}
"""The sound entries the attacks are made on: stress, and route-events (track figures)."""

EXPECTED = {
    # Figures: every one is recomputed from the per-frame results.
    "edited-ci95": "metrics/ci95/p75_all_cm/0: the entry says 0.01, its per-frame results give",
    "edited-runtime": "metrics/runtime_us/median: the entry says 0.5, its per-frame results give",
    "edited-ratio": "metrics/runtime_us/ratio_to_ransac: the entry says 0.01",
    "edited-by-cause": "metrics/by_cause/clean/p75_cm: the entry says 0.0",
    "dropped-group": "metrics/by_group: the entry has [], its per-frame results give",
    "negative-p75": "metrics/all/p75_cm: -500.0 is less than the minimum of 0",
    "extra-figure": "metrics/all: Additional properties are not allowed ('rank' was unexpected)",
    # Track figures (a suite of driven routes): recomputed from the per-frame results and the
    # suite's cases; lsq recovered from the kidnapping (event 1) in 2.8 s.
    "edited-recovery": "metrics/tracking/events/1/recovery_s: the entry says 0.1, its per-frame "
                       "results give 2.7999",
    "edited-track-max": "metrics/tracking/max_cm_outside_kidnaps: the entry says 9.5, its "
                        "per-frame results give 1424.47",
    "dropped-tracking": "metrics/tracking: the entry has None, its per-frame results give "
                        "['availability_after_first_fix', 'events'",
    "tracks-without-routes": "metrics/tracking: the entry says {'availability_after_first_fix': "
                             "1.0, 'max_cm_outside_kidnaps': 5.0, 'frames_over_1m_outside_kidn",
    # Frames: exactly the suite's, in order, as the suite draws them.
    "five-frames": "per-frame results: 5 frames, but stress (seed 13, quick) has 60",
    "fake-cases-digest": "cases_sha256: the entry was scored on other frames than stress v1 "
                         "draws now (seed 13, quick",
    "full-size-claimed": "cases_sha256: the entry was scored on other frames than stress v1 "
                         "draws now (seed 13, full",
    "duplicate-frame": "line 3, column frame: expected 1 (frames in order, from 0), got '0'",
    "relabelled-cause": "per-frame results: line 5: frame 3 is warehouse-large/",
    "two-localizers": "line 3, column localizer: 'ransac', but the first row's is 'lsq'",
    # Rows no run writes.
    "negative-error": "line 2, column position_error_m: must be finite and >= 0, got -5.0",
    "infinite-error": "column position_error_m: must be finite and >= 0, got inf",
    "error-without-estimate": "column position_error_m: must be NaN where ok is 0",
    "negative-runtime": "line 2, column micros: must be NaN or finite and >= 0, got '-1.0'",
    "short-row": "per-frame results: line 3: 3 columns, expected 10 (localizer,frame,",
    "non-numeric": "line 4, column heading_error_rad: not a number: 'abc'",
    "huge-field": "per-frame results: line 2: not CSV: field larger than field limit",
    # Claims about the run.
    "other-seed": "seed: the dev split of stress is drawn from seed 13, the entry says 14",
    "negative-seed": "seed: -1 is less than the minimum of 0",
    "test-split-on-dev-seed": "seed: a test split is drawn from a fresh seed; 13 is the dev",
    "future-version": "azgym_version: '99.9-from-the-future' is not a version",
    "newer-version": "azgym_version: 99.9 is newer than the azgym checking it",
    "not-a-date": "timestamp: 'not a date' is not an ISO 8601 date and time with a time zone",
    "no-time-zone": "timestamp: '2026-01-01T00:00:00' is not an ISO 8601 date and time with a",
    "future-date": "timestamp: 2999-01-01T00:00:00+00:00 is in the future",
    "other-suite-version": "suite_version: stress is at version 1, the entry was scored on "
                           "version 99; rerun it",
    "old-format": "format: the entry is in format 2, this azgym reads format 4; make it again",
    # Identity: an entry is its file, and its results are its own.
    "impostor": "name: 'sound', but the file is impostor.json",
    "borrowed-results": "results_file: must be borrowed-results.frames.csv.gz, got "
                        "'sound.frames.csv.gz'",
    "absolute-plugin": "localizer/spec: '/tmp/evil.py:Evil' is an absolute path",
    "plugin-without-hash": "localizer/sha256: a plug-in file's SHA-256 is required",
    # Files that are not what they say.
    "deep-json": "not valid JSON: nested deeper than 16 levels",
    "recursion-json": "not valid JSON: nested deeper than 16 levels",
    "nan-json": "not valid JSON: NaN is not a JSON number",
    "not-json": "not valid JSON: Expecting property name",
    "gzip-bomb": "gzip-bomb.frames.csv.gz: decompresses to more than 64 MiB; refused",
    "not-gzip": "not-gzip.frames.csv.gz: not a gzip-compressed CSV",
}


def test_the_corpus_is_the_pinned_one_and_its_sound_entry_loads():
    # A failure here after a change of the stress suite: python tests/hostile/make_corpus.py
    assert {path.stem for path in CORPUS.glob("*.json")} == set(EXPECTED) | SOUND
    for name in SOUND:
        assert L.load_entry(CORPUS / f"{name}.json")["name"] == name


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_a_hostile_entry_is_refused_with_its_reason(name):
    path = CORPUS / f"{name}.json"
    with pytest.raises(L.LeaderboardError, match=re.escape(EXPECTED[name])) as caught:
        L.load_entry(path)
    assert f"{name}." in str(caught.value)  # the message names the file


def test_a_folder_holding_a_hostile_entry_builds_no_board(tmp_path):
    from azgym.bench.leaderboard import board

    with pytest.raises(L.LeaderboardError, match=r"absolute-plugin\.json: localizer/spec"):
        board.build(CORPUS, tmp_path / "board")
    assert not (tmp_path / "board").exists()
