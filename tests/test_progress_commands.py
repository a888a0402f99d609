"""The last silent commands show their progress through the shared meter (azgym.progress).

``layout analyze``, ``layout optimize`` and ``study error-model`` count what they do; piped (a
CI log, ``| tee``), each count is a plain line with done/total, the rate and the time left on
standard error (the meter writes one at least every few seconds, and one at the end), and
``layout analyze`` prints no count lines of its own any more. What they write is the same,
byte for byte, with the meter as without it.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from azgym import cli
from azgym.cli import layout as cli_layout
from azgym.cli import studies as cli_studies

pytest.importorskip("matplotlib")

ANALYZE = ["layout", "analyze", "paper-room", "--step", "3", "--frames", "20", "--workers", "1"]
OPTIMIZE = ["layout", "optimize", "paper-room", "--add", "2", "--step", "2"]
STUDY = ["study", "error-model", "--frames", "5"]


def count_lines(err: str, label: str, total: int, unit: str) -> list[str]:
    """The meter's plain lines of one count (``  LABEL: done/total unit [elapsed<left, rate]``)."""
    line = re.compile(rf"  {re.escape(label)}: \d+/{total} {unit} \[\d\d:\d\d<(\d\d:\d\d|\?), "
                      rf"(\?|[\d.]+)({unit}/s|s/{unit})\]")
    return [text for text in err.splitlines() if line.fullmatch(text)]


def written(folder: Path) -> dict[str, bytes]:
    """Every file a run wrote, by name."""
    return {path.name: path.read_bytes() for path in sorted(folder.iterdir())}


def run(argv: list[str], out: Path, capsys: pytest.CaptureFixture[str]) -> tuple[str, str]:
    """The command, piped (pytest's capture is no terminal): its standard output and error."""
    assert cli.main([*argv, "--out", str(out)]) == 0
    captured = capsys.readouterr()
    return captured.out, captured.err


def test_layout_analyze_counts_on_the_shared_meter(tmp_path, capsys):
    out, err = run(ANALYZE, tmp_path / "metered", capsys)
    assert count_lines(err, "line of sight", 64, "cells")[-1].startswith(
        "  line of sight: 64/64 cells [")
    assert count_lines(err, "Monte Carlo", 64, "cells")[-1].startswith(
        "  Monte Carlo: 64/64 cells [")
    assert not re.search(r"Monte Carlo: \d+/\d+ cells", out)  # no count lines of its own


def test_layout_optimize_says_what_it_is_doing(tmp_path, capsys):
    _, err = run(OPTIMIZE, tmp_path / "metered", capsys)
    cells = int(re.search(r"(\d+)/\1 cells", err).group(1))  # type: ignore[union-attr]
    assert count_lines(err, "line of sight", cells, "cells")
    assert count_lines(err, "greedy", 2, "beacons")[-1].startswith("  greedy: 2/2 beacons [")
    assert count_lines(err, "swaps", 10, "rounds")  # at most ten rounds; ends when none helps


def test_study_error_model_counts_its_frames(tmp_path, capsys):
    _, err = run(STUDY, tmp_path / "metered", capsys)
    assert count_lines(err, "rendering", 5, "frames")[-1].startswith(
        "  rendering: 5/5 frames [")


@pytest.mark.parametrize("argv", [ANALYZE, OPTIMIZE, STUDY], ids=["analyze", "optimize", "study"])
def test_the_meter_changes_nothing_written(argv, tmp_path, capsys, monkeypatch):
    run(argv, tmp_path / "metered", capsys)
    for module in (cli_layout, cli_studies):  # no meter: the counts hear nothing
        monkeypatch.setattr(module, "progress_printer", lambda: None)
    _, err = run(argv, tmp_path / "silent", capsys)
    assert not re.search(r"\d+/\d+ \w+ \[", err)
    metered, plain = written(tmp_path / "metered"), written(tmp_path / "silent")
    assert metered.keys() == plain.keys() and metered  # figures included
    assert metered == plain
