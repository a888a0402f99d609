"""The per-frame results' fast path: a file read at once is read as row by row, and no file the
row-by-row reading refuses gets through it."""

from __future__ import annotations

import csv
import gzip
import io
import itertools
import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from azgym.bench.leaderboard import entry_files
from azgym.bench.leaderboard.entry_files import FrameTable, LeaderboardError, parse_frames
from azgym.bench.leaderboard.frame_screen import screened_columns
from azgym.bench.report.results import FRAME_COLUMNS, OUTCOME_COLUMNS

ENTRIES = Path(__file__).parents[2] / "leaderboard" / "entries"


def row_by_row(text: str, cases=None) -> FrameTable:
    """``parse_frames`` without its fast path."""
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(entry_files, "screened_columns", lambda rows, width, cases: None)
        return parse_frames(text, "file", cases)


def assert_same(fast: FrameTable, slow: FrameTable) -> None:
    assert (fast.label, fast.scenario, fast.group, fast.cause) == \
        (slow.label, slow.scenario, slow.group, slow.cause)
    assert type(fast.outcome) is type(slow.outcome)
    for name, value in vars(slow.outcome).items():
        mine = getattr(fast.outcome, name)
        if isinstance(value, np.ndarray):
            assert mine.dtype == value.dtype and mine.shape == value.shape, name
            assert mine.tobytes() == value.tobytes(), name  # bit for bit, NaN included
        else:
            assert mine == value, name


@pytest.mark.parametrize("name", ["lsq-stress", "gated-ekf-route-events",
                                  "ransac-data-warehouse-small-simulated"])
def test_a_committed_entry_s_results_read_at_once_as_row_by_row(name):
    text = gzip.decompress((ENTRIES / f"{name}.frames.csv.gz").read_bytes()).decode()
    rows = list(csv.reader(io.StringIO(text)))
    assert screened_columns(rows[1:], len(rows[0]), None) is not None  # the fast path is taken
    assert_same(parse_frames(text, "file"), row_by_row(text))


# A small file with both kinds of truth (with and without a heading), every kind of row, and
# then one cell replaced by a hostile value.
CASES = [SimpleNamespace(frame=None, pose=(0.0, 0.0, heading))
         for heading in (0.5, math.nan, 0.5, math.nan, 0.5)]
SOUND = [["m", "0", "s", "g", "c", "1", "0.25", "0.125", "12.5", "", "1", "2", "0.5"],
         ["m", "1", "s", "g", "c", "1", "0", "nan", "0", "", "1", "2", "0"],
         ["m", "2", "s", "g", "c", "0", "nan", "nan", "3", "", "nan", "nan", "nan"],
         ["m", "3", "s", "g", "c", "0", "nan", "nan", "nan", "ValueError: x", "nan", "nan",
          "nan"],
         ["m", "4", "s", "g", "c", "1", "1e3", "3.1415926535", "7", "", "-1", "0", "3"]]
HOSTILE = ["", "0", "1", "2", "-1", "-0.0", "nan", "NaN", "inf", "-inf", "1e400", "3.1415926536",
           "3.2", " 1", "1_0", "abc", "m", "x", "4", "ValueError: x"]


def text_of(rows: list[list[str]], header: list[str]) -> str:
    out = io.StringIO()
    csv.writer(out, lineterminator="\n").writerows([header, *rows])
    return out.getvalue()


def test_a_file_read_at_once_is_one_the_row_by_row_reading_accepts_alike():
    """Every cell of the small file replaced by every hostile value, in turn (5 200 files)."""
    taken = 0
    for row, column, value, cases, header in itertools.product(
            range(len(SOUND)), range(len(FRAME_COLUMNS)), HOSTILE, (CASES, None),
            (FRAME_COLUMNS, OUTCOME_COLUMNS)):
        rows = [list(cells[:len(header)]) for cells in SOUND]
        if column >= len(header):
            continue
        rows[row][column] = value
        if screened_columns(rows, len(header), cases) is None:
            continue  # the row-by-row reading decides, as parse_frames does
        text = text_of(rows, header)
        assert_same(parse_frames(text, "file", cases), row_by_row(text, cases))
        taken += 1
    assert taken > 200  # the fast path was tried on many files, not only refused them


def test_the_sound_file_and_the_screens_own_refusals():
    """Each check of the screen, caught by it (the row-by-row reading then names the row)."""
    assert screened_columns(SOUND, len(FRAME_COLUMNS), CASES) is not None
    refused = {(1, 7, "0.5"),  # a heading error where the truth has none
               (2, 6, "0.5"),  # an error without an estimate
               (0, 7, "3.2"),  # a heading error past π
               (0, 6, "-1"),  # a negative position error
               (0, 8, "nan"),  # no runtime, yet the call did not raise
               (0, 8, "-1"),  # a negative runtime
               (3, 5, "1"),  # an estimate from a call that raised
               (0, 10, "nan"),  # an estimate without a pose
               (2, 10, "0"),  # a pose without an estimate
               (0, 1, "1"),  # a frame out of order
               (1, 0, "other"),  # a second localizer
               (0, 5, "2")}  # ok neither 0 nor 1
    for row, column, value in refused:
        rows = [list(cells) for cells in SOUND]
        rows[row][column] = value
        assert screened_columns(rows, len(FRAME_COLUMNS), CASES) is None, (row, column, value)
        with pytest.raises(LeaderboardError, match=f"line {row + 2}"):
            parse_frames(text_of(rows, FRAME_COLUMNS), "file", CASES)
