"""First use of the board: which board submit and build use, and the warnings of a lone entry."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from azgym.cli import leaderboard as board_cli
from azgym.cli import main

REFERENCES = Path(__file__).parent.parent / "leaderboard" / "entries"


def submit(run: Path, name: str, *more: str) -> list[str]:
    """``azgym leaderboard submit`` of ransac's row of a run."""
    return ["leaderboard", "submit", str(run), "--localizer", "ransac", "--name", name,
            "--version", "1", "--authors", "Me", *more]


@pytest.fixture(scope="module")
def quick_run(tmp_path_factory):
    """An azgym bench output of ransac on the stress suite's quick size."""
    out = tmp_path_factory.mktemp("run") / "out"
    assert main(["bench", "--suite", "stress", "--quick", "--localizer", "ransac",
                 "--workers", "1", "--out", str(out)]) == 0
    return out


def test_without_a_board_here_or_above_submit_and_build_refuse_naming_entries(
        quick_run, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    assert board_cli.find_entries(tmp_path) is None
    for argv in (submit(quick_run, "mine"), ["leaderboard", "build"]):
        capsys.readouterr()
        assert main(argv) == 2
        error = capsys.readouterr().err
        assert "--entries: no leaderboard/entries/ in" in error and "--entries DIR" in error
    assert list(tmp_path.iterdir()) == []  # no new board made


def test_from_a_folder_below_the_board_submit_and_build_use_it_and_say_so(
        quick_run, tmp_path, monkeypatch, capsys):
    entries = tmp_path / "leaderboard" / "entries"
    entries.mkdir(parents=True)
    for file in ("ransac-stress.json", "ransac-stress.frames.csv.gz"):
        shutil.copy(REFERENCES / file, entries / file)
    below = tmp_path / "work" / "deeper"
    below.mkdir(parents=True)
    monkeypatch.chdir(below)
    capsys.readouterr()
    assert main(submit(quick_run, "mine")) == 0
    printed = capsys.readouterr()
    assert f"board: {entries}" in printed.out and (entries / "mine.json").is_file()
    # a quick run is ranked apart from the full-size references: said, with the table it lacks
    assert "mine is a quick run: the board ranks it apart" in printed.err
    assert re.search(r"has no other entry on stress \(dev split, quick size\): mine will be "
                     r"alone in its table", printed.err)
    assert "new board" not in printed.err  # the folder held the references
    assert main(["leaderboard", "build"]) == 0
    assert (tmp_path / "leaderboard" / "README.md").is_file()
    assert not (below / "leaderboard").exists()


def test_a_new_board_and_a_lone_table_are_warned_of_and_a_shared_one_is_not(
        quick_run, tmp_path, capsys):
    entries = tmp_path / "mine"
    assert main(submit(quick_run, "first", "--entries", str(entries))) == 0
    warned = capsys.readouterr().err
    assert f"{entries} held no entries: this is a new board" in warned
    assert main(submit(quick_run, "second", "--entries", str(entries))) == 0
    warned = capsys.readouterr().err
    assert "alone in its table" not in warned and "quick run" in warned


def test_empty_entries_or_out_are_refused(capsys):
    for argv in (submit(Path("x"), "n", "--entries", ""),
                 ["leaderboard", "build", "--out", ""], ["leaderboard", "build", "--entries", ""]):
        with pytest.raises(SystemExit):
            main(argv)
        assert "is empty" in capsys.readouterr().err


def test_verify_calls_a_built_in_azgyms_own_and_a_plug_in_the_submitters(
        quick_run, tmp_path, monkeypatch, capsys):
    from azgym.bench.leaderboard import entries as leaderboard

    entries = tmp_path / "board"
    assert main(submit(quick_run, "mine", "--entries", str(entries))) == 0
    monkeypatch.setattr(leaderboard, "verify", lambda *args, **kwargs: {})
    capsys.readouterr()
    assert main(["leaderboard", "verify", str(entries / "mine.json")]) == 0
    printed = capsys.readouterr().out
    assert "'ransac', which is azgym's own," in printed and "submitter" not in printed


def test_build_never_replaces_a_readme_or_page_that_is_no_board(quick_run, tmp_path, capsys):
    """``--entries DIR`` starts a board of one's own: its folder's own README.md is the user's."""
    folder = tmp_path / "mine"
    (folder / "entries").mkdir(parents=True)
    assert main([*submit(quick_run, "mine", "--entries", str(folder / "entries"))]) == 0
    (folder / "README.md").write_text("# My project\n")
    capsys.readouterr()
    assert main(["leaderboard", "build", "--entries", str(folder / "entries")]) == 2
    assert f"--out: {folder / 'README.md'} is no azgym board's; nothing was written" in \
        capsys.readouterr().err
    assert (folder / "README.md").read_text() == "# My project\n"
    assert not (folder / "index.html").exists()
    assert main(["leaderboard", "build", "--entries", str(folder / "entries"),
                 "--out", str(tmp_path / "board")]) == 0
    assert main(["leaderboard", "build", "--entries", str(folder / "entries"),
                 "--out", str(tmp_path / "board")]) == 0  # a board is rebuilt in place
    assert main(["leaderboard", "build", "--entries", str(folder / "entries"),
                 "--overwrite"]) == 0
    assert (folder / "README.md").read_text().startswith("# azgym leaderboard")
