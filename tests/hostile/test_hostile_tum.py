"""Hostile truth files: a log's TUM truth (``[truth] file``) refused by name, file and line.

The mini log of format 2 (frames 10, 12 and 13 at 0.0, 0.1 and 0.2 s) with its truth moved from
``frames.csv`` to ``truth.tum``; each attack breaks one thing, and the log is refused with a
message naming the file, the line (and column) or the manifest's field, never a traceback of
numpy's, a hang or a file read past its caps.
"""

from __future__ import annotations

import math
import re

import pytest
from logs.mini_log import POSES, mini_files_2, write_log

from azgym.logs import read_log
from azgym.logs import tum as tum_module
from azgym.logs.problems import LogError

MANIFEST_TRUTH = '\n[truth]\nfile = "truth.tum"\nheading = true\n'
"""The manifest's truth section of the sound log."""


def tum_line(time, x, y, heading, tz=0.0):
    return f"{time!r} {x!r} {y!r} {tz!r} 0.0 0.0 {math.sin(heading / 2)!r} " \
           f"{math.cos(heading / 2)!r}"


def sound_files() -> dict[str, str | bytes]:
    files = mini_files_2()
    files["frames.csv"] = "frame,time\n10,0.0\n12,0.1\n13,0.2\n"
    files["log.toml"] += MANIFEST_TRUTH
    files["truth.tum"] = "# timestamp tx ty tz qx qy qz qw\n" + "\n".join(
        tum_line(0.1 * k, *pose) for k, pose in enumerate(POSES)) + "\n"
    return files


def changed(name: str, old: str, new: str):
    def change(files):
        assert old in files[name]
        files[name] = files[name].replace(old, new)
    return change


def both(*changes):
    def change(files):
        for each in changes:
            each(files)
    return change


def line(k: int, text: str):
    """Replace the truth file's pose line k (its file line is k + 2)."""
    def change(files):
        lines = files["truth.tum"].splitlines()
        lines[k + 1] = text
        files["truth.tum"] = "\n".join(lines) + "\n"
    return change


ATTACKS = {
    "seven values": (line(1, "0.1 5.1 5.0 0.0 0.0 0.0 1.0"),
                     "truth.tum, line 3: 7 values, a TUM line has 8 (timestamp tx ty tz qx qy "
                     "qz qw)"),
    "nine values": (line(0, tum_line(0.0, 5.0, 5.0, 0.0) + " 1.0"), "line 2: 9 values"),
    "a NaN": (line(1, tum_line(0.1, math.nan, 5.0, 0.1)),
              "truth.tum, line 3, column tx: 'nan' is not finite"),
    "an infinity": (line(2, tum_line(0.2, 5.2, math.inf, 0.2)),
                    "truth.tum, line 4, column ty: 'inf' is not finite"),
    "not a number": (line(1, "0.1 5.1 five 0.0 0.0 0.0 0.0 1.0"),
                     "truth.tum, line 3, column ty: 'five' is not a number"),
    "time running back": (line(2, tum_line(0.05, 5.2, 5.0, 0.2)),
                          "truth.tum, line 4, column timestamp: time stamps must increase: "
                          "0.05 s after 0.1 s"),
    "a repeated time": (line(2, tum_line(0.1, 5.2, 5.0, 0.2)),
                        "column timestamp: time stamps must increase: 0.1 s after 0.1 s"),
    "not a unit quaternion": (line(1, "0.1 5.1 5.0 0.0 0.0 0.0 0.0 2.0"),
                              "truth.tum, line 3, column qw: the quaternion's norm is 2.0, not "
                              "1"),
    "far outside the map": (line(1, tum_line(0.1, 5100.0, 5.0, 0.1)),
                            "truth.tum, line 3, column tx: (5100.0, 5.0) is outside the map's "
                            "extent"),
    "a frame after the last pose": (line(2, "# the last pose dropped"),
                                    "truth.tum: frame 13 (time 0.2 s) lies outside the truth "
                                    "samples' span (0.0 s to 0.1 s); 1 frame(s) do"),
    "a gap": (both(line(1, "# the middle pose dropped"),
                   changed("log.toml", "heading = true", "heading = true\nmax_gap = 0.15")),
              "truth.tum: frame 12 (time 0.1 s) lies in a 0.200 s gap between truth samples 0"
              " and 1 (at most 0.15 s is interpolated across)"),
    "no pose": (lambda files: files.update({"truth.tum": "# nothing\n\n"}),
                "truth.tum: no pose: a TUM file holds one pose a line"),
    "not UTF-8": (lambda files: files.update({"truth.tum": b"0.0 \xff\n"}),
                  "truth.tum: not UTF-8 text: byte 0xff at offset 4"),
    "truth given twice": (lambda files: files.update({"frames.csv": mini_files_2()[
        "frames.csv"]}), "log.toml: truth.file: 'truth.tum', but frames.csv has truth columns "
                         "too (x, y, heading): give the truth once"),
    "no heading said": (changed("log.toml", "heading = true\n", ""),
                        "log.toml: truth.heading: must be true or false, and is required"),
    "a heading without a file": (changed("log.toml", 'file = "truth.tum"\n', ""),
                                 "log.toml: truth.heading: only with truth.file"),
    "a table as the truth file": (changed("log.toml", '"truth.tum"', '"frames.csv"'),
                                  "log.toml: truth.file: 'frames.csv' must end with .tum or "
                                  ".txt"),
    "a file elsewhere": (changed("log.toml", '"truth.tum"', '"../truth.tum"'),
                         "log.toml: truth.file: '../truth.tum' is not a file in the log's "
                         "folder"),
    "a missing file": (lambda files: files.pop("truth.tum"),
                       "log.toml: truth.file: 'truth.tum' is not a file in the log's folder"),
    "a bad gap": (changed("log.toml", "heading = true", "heading = true\nmax_gap = -1"),
                  "log.toml: truth.max_gap: must be in (0, 60] s, got -1"),
    "format 1": (changed("log.toml", "format = 2", "format = 1"),
                 "log.toml: truth: unknown key 'file'"),
}


@pytest.mark.parametrize("name", sorted(ATTACKS))
def test_a_hostile_truth_file_is_refused_by_file_and_line(tmp_path, name):
    files = sound_files()
    read_log(write_log(tmp_path / "sound", dict(files)))  # the sound log reads
    change, message = ATTACKS[name]
    change(files)
    with pytest.raises(LogError, match=re.escape(message)):
        read_log(write_log(tmp_path / "log", files))


def test_a_linked_truth_file_is_refused(tmp_path):
    files = sound_files()
    outside = tmp_path / "outside.tum"
    outside.write_text(files.pop("truth.tum"))
    folder = write_log(tmp_path / "log", files)
    (folder / "truth.tum").symlink_to(outside)
    with pytest.raises(LogError, match=re.escape("log.toml: 'truth.tum' is not a file in the "
                                                 "log's folder (a symlink")):
        read_log(folder)


def test_a_huge_truth_file_is_refused_at_the_byte_cap_unread(tmp_path):
    files = sound_files()
    folder = write_log(tmp_path / "log", files)
    with (folder / "truth.tum").open("r+b") as handle:
        handle.truncate(65 * 2**20)  # sparse: 65 MiB on paper, nothing on disk
    with pytest.raises(LogError, match=r"truth.tum: too large: 68157440 bytes"):
        read_log(folder)


def test_a_truth_file_of_too_many_values_stops_at_the_cell_cap(tmp_path, monkeypatch):
    monkeypatch.setattr(tum_module, "MAX_TABLE_CELLS", 20)
    files = sound_files()
    with pytest.raises(LogError, match=re.escape("truth.tum, line 4: too many values: more "
                                                 "than 20 by this line")):
        read_log(write_log(tmp_path / "log", files))
