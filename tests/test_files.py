"""Output files: written atomically, never through a planted link, the folder checked first."""

from __future__ import annotations

import os
import stat

import pytest

from azgym.cli import main
from azgym.errors import InvalidInputError
from azgym.files import prepare_folder, write_file


def test_a_file_is_replaced_whole_and_no_temporary_is_left(tmp_path):
    target = write_file(tmp_path / "a.json", "old")
    write_file(target, "new")
    assert target.read_text() == "new" and os.listdir(tmp_path) == ["a.json"]


def test_a_planted_link_is_refused_and_its_target_untouched(tmp_path):
    outside = tmp_path / "outside.txt"
    outside.write_text("precious")
    board = prepare_folder(tmp_path / "board")
    (board / "README.md").symlink_to(outside)
    with pytest.raises(InvalidInputError, match="symbolic link; refusing to write through it"):
        write_file(board / "README.md", "# forged")
    linked = tmp_path / "linked"
    linked.symlink_to(board)
    with pytest.raises(InvalidInputError, match="is a symbolic link; give a real folder"):
        prepare_folder(linked)
    assert outside.read_text() == "precious"


def test_bench_refuses_an_output_folder_it_cannot_write_before_running(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    assert main(["bench", "--suite", "stress", "--quick", "--out", str(blocker / "out")]) == 2
    error = capsys.readouterr().err
    assert "cannot write there" in error and "frames drawn" not in error


@pytest.fixture
def umask():
    """Set the process's umask for one test, and put the old one back."""
    old = os.umask(0o022)
    yield os.umask
    os.umask(old)


@pytest.mark.parametrize(("mask", "mode"), [(0o022, 0o644), (0o027, 0o640), (0o002, 0o664)])
def test_a_new_file_gets_the_mode_the_users_umask_gives(mask, mode, umask, tmp_path):
    umask(mask)
    written = write_file(tmp_path / "index.html", "<p>board</p>")
    assert stat.S_IMODE(written.stat().st_mode) == mode
    with open(tmp_path / "plain.txt", "w") as stream:  # what an ordinary open gives
        stream.write("x")
    assert stat.S_IMODE((tmp_path / "plain.txt").stat().st_mode) == mode


@pytest.mark.parametrize("kept", [0o600, 0o664, 0o640])
def test_a_replaced_file_keeps_its_mode(kept, umask, tmp_path):
    umask(0o022)
    target = tmp_path / "frames.csv"
    target.write_text("old")
    target.chmod(kept)
    write_file(target, "new")
    assert target.read_text() == "new" and stat.S_IMODE(target.stat().st_mode) == kept
    assert os.listdir(tmp_path) == ["frames.csv"]
