"""A weight file in a navigation results file: pinned by its SHA-256, as in a frame suite's.

A contender ``ng-ransac:weights=FILE`` records the file's absolute path and SHA-256
(``weights_file``, ``weights_sha256``), and the board reads the file only while the weight file
its spec names still has that SHA-256: a changed or missing file is refused by name, so a board
always tells which weights produced a figure. Files of format 2 (before the pin) still read when
none of their contenders names a weight file, and are refused, with the remedy, when one does.
"""

from __future__ import annotations

import hashlib
import json
import shutil
from pathlib import Path

import pytest
from helpers import bounded_outcome, edited_json, quick_navigation_run

from azgym.bench.leaderboard import board
from azgym.bench.leaderboard.entry_files import LeaderboardError
from azgym.bench.navigation.board import verify_navigation
from azgym.bench.navigation.results_file import load_navigation
from azgym.localize.learned.ng_ransac import SHIPPED_WEIGHTS

SHIPPED_ENTRIES = Path(__file__).parents[2] / "leaderboard" / "entries"
LABEL = "ng-ransac:weights=model.npz"
"""The contender's localizer: a weight file named relative to the run's folder."""


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A quick run of pure pursuit with ng-ransac on a copy of the shipped weights."""
    work = tmp_path_factory.mktemp("work")
    shutil.copy(SHIPPED_WEIGHTS, work / "model.npz")
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(work)
        path = quick_navigation_run(work / "out", LABEL)
    return work, path


@pytest.fixture
def in_work(run, monkeypatch):
    """The run's folder as the working folder (where its spec names the weight file); the
    weight file put back afterwards."""
    work, path = run
    original = (work / "model.npz").read_bytes()
    monkeypatch.chdir(work)
    yield work, path
    (work / "model.npz").write_bytes(original)


def test_a_results_file_records_the_weight_file_and_its_digest(in_work):
    work, path = in_work
    contender = json.loads(path.read_text())["contenders"][0]
    assert contender["localizer"] == LABEL
    assert contender["weights_file"] == str((work / "model.npz").resolve())
    assert contender["weights_sha256"] == hashlib.sha256(SHIPPED_WEIGHTS.read_bytes()).hexdigest()
    assert load_navigation(path)["format"] == 3


def test_a_changed_weight_file_is_refused_naming_it(in_work, tmp_path):
    work, path = in_work
    weights = work / "model.npz"
    weights.write_bytes(weights.read_bytes() + b"\0")
    digest = hashlib.sha256(weights.read_bytes()).hexdigest()
    message = (rf"contenders/0 \(pure-pursuit \+ {LABEL}\)/weights_sha256: the weight file "
               rf"{weights.resolve()} changed since the run: sha256 {digest}, the run used ")
    with pytest.raises(LeaderboardError, match=message):
        load_navigation(path)
    with pytest.raises(LeaderboardError, match=message):
        verify_navigation(path)


def test_the_board_refuses_a_navigation_file_whose_weights_changed(in_work, tmp_path):
    work, path = in_work
    navigation = tmp_path / "navigation"
    navigation.mkdir()
    shutil.copy(path, navigation / "mine.json")
    entries = tmp_path / "entries"  # a board needs a frame entry: a shipped one
    entries.mkdir()
    for name in ("ransac-paper.json", "ransac-paper.frames.csv.gz"):
        shutil.copy(SHIPPED_ENTRIES / name, entries / name)
    (work / "model.npz").write_bytes(b"other weights")
    with pytest.raises(LeaderboardError, match=rf"mine.json: contenders/0 .*weight file "
                                               rf"{work.resolve()}/model.npz changed since"):
        board.build(entries, tmp_path / "out", navigation)


def test_a_missing_weight_file_is_refused_naming_it(in_work):
    work, path = in_work
    (work / "model.npz").unlink()
    with pytest.raises(LeaderboardError, match=rf"the weight file {work.resolve()}/model.npz "
                                               "does not exist"):
        load_navigation(path)


@pytest.mark.parametrize(("edit", "message"), [
    (lambda c: c.pop("weights_sha256"), r"missing keys \['weights_sha256'\]"),
    (lambda c: c.update(weights_sha256="0" * 63), "weights_sha256: must be a SHA-256"),
    (lambda c: c.update(weights_file=["x"]), "weights_file: must be a path"),
])
def test_a_pin_that_is_not_one_is_refused(in_work, tmp_path, edit, message):
    _, path = in_work
    with pytest.raises(LeaderboardError, match=message):
        load_navigation(edited_json(tmp_path, path, lambda d: edit(d["contenders"][0])))


def test_a_pinned_device_is_refused_by_name_in_bounded_time_and_memory(in_work, tmp_path):
    _, path = in_work
    forged = edited_json(tmp_path, path, lambda d: d["contenders"][0].update(
        localizer="ng-ransac:weights=/dev/zero"))  # its SHA-256 would be read without end
    assert bounded_outcome(f"""
        from pathlib import Path
        from azgym.bench.navigation.results_file import load_navigation
        load_navigation(Path({str(forged)!r}))
        """, memory_bytes=1536 * 2**20, seconds=60) == (
        f"LeaderboardError {forged}: contenders/0 (pure-pursuit + "
        "ng-ransac:weights=/dev/zero)/localizer: /dev/zero: cannot read the model file: it is "
        "a device, not a regular file")


def test_a_pin_beside_a_localizer_naming_no_weight_file_is_refused(in_work, tmp_path):
    _, path = in_work
    with pytest.raises(LeaderboardError, match=r"unknown keys \['weights_file', "
                                               r"'weights_sha256'\]"):
        load_navigation(edited_json(tmp_path, path, lambda d: d["contenders"][0].update(
            localizer="ng-ransac")))


def test_a_format_2_file_naming_a_weight_file_is_refused_with_the_remedy(in_work, tmp_path):
    _, path = in_work

    def old(data):
        data["format"] = 2
        for key in ("weights_file", "weights_sha256"):
            data["contenders"][0].pop(key)

    with pytest.raises(LeaderboardError, match=rf"{LABEL} names a weight file, and a format 2 "
                                               "file records no SHA-256 of it: run the "
                                               "contender again"):
        load_navigation(edited_json(tmp_path, path, old))


def test_a_format_2_file_naming_no_weight_file_still_reads(tmp_path):
    path = quick_navigation_run(tmp_path / "out", "ransac")
    data = json.loads(path.read_text())
    assert data["format"] == 3 and set(data["contenders"][0]) == {
        "navigator", "localizer", "summary", "runtime_s", "episodes"}  # nothing to pin
    data["format"] = 2
    path.write_text(json.dumps(data))
    assert load_navigation(path)["contenders"][0]["localizer"] == "ransac"


def test_evaluate_navigator_records_the_weight_file_too(in_work):
    from azgym.bench.navigation.benchmark import evaluate_navigator

    work, _ = in_work
    result = evaluate_navigator("pure-pursuit", "azgym/Navigate-WarehouseSmall-v2",
                                [LABEL, "ransac"], episodes=1, seed=0, sensor="geometry",
                                ids="oracle")
    pinned, plain = result.record["results"]
    assert (pinned["weights_file"], pinned["weights_sha256"]) == (
        str((work / "model.npz").resolve()),
        hashlib.sha256(SHIPPED_WEIGHTS.read_bytes()).hexdigest())
    assert "weights_sha256" not in plain
