"""``azgym layout analyze --survey``: a bad survey table is refused by name, before any work."""

from __future__ import annotations

import pytest

from azgym import cli
from azgym.mapping import survey_file

HEADER = "id,x,y,sxx,sxy,syy,observable,anchor,moved,rays,outliers,reason"


@pytest.mark.parametrize(("rows", "message"), [
    ([HEADER, "99,1,2,0.01,0,0.01,1,0,0,9,0,\"\""],
     "ids [99] are not beacons of 'paper-room'"),
    ([HEADER, "1,1,2,0.01,0.5,0.01,1,0,0,9,0,\"\""],
     "line 2: the covariance of id 1 (sxx 0.01, sxy 0.5, syy 0.01) is not positive"),
    ([HEADER, "1,1,2,-0.01,0,0.01,1,0,0,9,0,\"\""], "is not positive semidefinite"),
    ([HEADER, "1,nan,2,0.01,0,0.01,1,0,0,9,0,\"\""], "line 2, x must be finite, got 'nan'"),
    ([HEADER, "1,,2,0.01,0,0.01,1,0,0,9,0,\"\""], "line 2, x must be a number, got ''"),
    ([HEADER, "1,1,2,0.01,0,0.01,yes,0,0,9,0,\"\""], "observable must be 0 or 1, got 'yes'"),
    ([HEADER, "1,1,2,0,0,0,1,0,0,9,0,\"\"", "1,1,2,0,0,0,1,0,0,9,0,\"\""],
     "line 3: id 1 is listed twice"),
    (["id,x,y", "1,1,2"], "no column sxx, sxy, syy, observable"),
    ([HEADER, "1,,,,,,0,0,0,2,0,\"narrow\""], "places none of the beacons of 'paper-room'"),
])
def test_a_bad_survey_is_a_named_error(rows, message, tmp_path, capsys):
    (tmp_path / "survey.csv").write_text("\n".join(rows) + "\n")
    out = tmp_path / "out"
    assert cli.main(["layout", "analyze", "paper-room", "--frames", "0", "--survey",
                     str(tmp_path), "--out", str(out)]) == 2
    captured = capsys.readouterr()
    assert message in captured.err and captured.out == ""
    assert not out.exists()


def test_a_missing_binary_or_huge_survey_is_refused(tmp_path, capsys, monkeypatch):
    out = tmp_path / "out"
    argv = ["layout", "analyze", "paper-room", "--frames", "0", "--out", str(out), "--survey"]
    assert cli.main([*argv, str(tmp_path / "nowhere")]) == 2
    assert "--survey" in (err := capsys.readouterr().err) and "no such survey table" in err
    (tmp_path / "survey.csv").write_bytes(b"\xff\xfe\x00garbage")
    assert cli.main([*argv, str(tmp_path)]) == 2
    assert "not UTF-8 text" in capsys.readouterr().err
    monkeypatch.setattr(survey_file, "MAX_SURVEY_BYTES", 64)
    (tmp_path / "survey.csv").write_text(HEADER + "\n" + "1,1,2,0,0,0,1,0,0,9,0,\"\"\n" * 10)
    assert cli.main([*argv, str(tmp_path)]) == 2
    assert "larger than a survey table may be" in capsys.readouterr().err
    assert not out.exists()


def test_a_fifo_for_a_survey_is_refused_at_once(tmp_path):
    """A FIFO named survey.csv must not block the analysis waiting for a writer."""
    import os
    import subprocess
    import sys

    os.mkfifo(tmp_path / "survey.csv")
    done = subprocess.run([sys.executable, "-m", "azgym", "layout", "analyze", "paper-room",
                           "--frames", "0", "--out", str(tmp_path / "out"), "--survey",
                           str(tmp_path)], capture_output=True, text=True, timeout=60)
    assert done.returncode == 2
    assert "--survey" in done.stderr and "not a regular file" in done.stderr
    assert not (tmp_path / "out").exists()
