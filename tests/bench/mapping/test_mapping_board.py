"""The board's mapping part: one table per suite and size, after the rest of the board, which it
leaves as it was; ``azgym leaderboard verify`` of a mapping file compares every figure but the
runtimes with a rerun."""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

import pytest
from mapping_files import hand_result

from azgym.bench.leaderboard import board
from azgym.bench.mapping import board as mapping_board
from azgym.bench.mapping.report import write_mapping

SHIPPED_ENTRIES = Path(__file__).resolve().parents[3] / "leaderboard" / "entries"


@pytest.fixture
def entries(tmp_path):
    folder = tmp_path / "entries"
    folder.mkdir()
    for name in ("ransac-paper.json", "ransac-paper.frames.csv.gz"):
        shutil.copy(SHIPPED_ENTRIES / name, folder / name)
    return folder


def test_a_mapping_file_is_one_table_its_mappers_ranked_with_the_boards_glyphs(tmp_path):
    write_mapping(hand_result(), tmp_path, "mapping-dev-quick.json")
    [(suite, _, title, table_id, header, rows)] = mapping_board.mapping_tables(tmp_path)
    assert (suite, table_id) == ("mapping", "board-mapping-quick")
    assert title == "dev split (seed 2900), quick size, 4 cases, 60 s a call"
    assert header[:4] == ["#", "mapper", "median cm", "p95 cm"]
    assert [row[:2] for row in rows] == [["1", "rays"], ["2", "prior"]]
    assert rows[1][3:7] == ["∞", "∞", "0.0", "–"]  # p95, worst, placed %, precision


@pytest.mark.slow
def test_the_mapping_part_comes_last_and_leaves_the_rest_of_the_board_as_it_was(entries,
                                                                              tmp_path):
    mapping = tmp_path / "mapping"
    write_mapping(hand_result(), mapping)
    before = board.build(entries, tmp_path / "before")
    after = board.build(entries, tmp_path / "after", mapping_dir=mapping)
    old, new = (path.read_text() for path in (before[0], after[0]))
    assert new.startswith(old)
    assert new[len(old):].startswith("\n# Mapping: beacon maps surveyed and repaired from a "
                                     "drive\n")
    assert "### dev split (seed 2900), quick size, 4 cases, 60 s a call" in new
    page = after[1].read_text()
    assert '<table class="board" id="board-mapping-quick">' in page
    assert "<h1>Mapping: beacon maps surveyed and repaired from a drive</h1>" in page


def test_verify_compares_every_figure_but_the_runtimes(tmp_path, monkeypatch):
    import azgym.bench.mapping.benchmark as benchmark

    claimed = hand_result()
    path = write_mapping(claimed, tmp_path)
    asked = []

    def rerun(suite, mappers, *, quick, workers, time_limit, progress):
        asked.append((suite, mappers, quick, workers, time_limit))
        return fresh

    monkeypatch.setattr(benchmark, "run_mapping", rerun)
    slower = {mapper: tuple(dataclasses.replace(score, runtime=score.runtime + 1)
                            for score in scores) for mapper, scores in claimed.scores.items()}
    fresh = dataclasses.replace(claimed, scores=slower, summaries={
        mapper: dataclasses.replace(summary, runtime_median_s=9.0)
        for mapper, summary in claimed.summaries.items()})
    assert mapping_board.verify_mapping(path, workers=2) == {}
    assert asked == [("mapping", ["prior", "rays"], True, 2, 60.0)]
    worse = dict(claimed.scores)
    worse["rays"] = (dataclasses.replace(worse["rays"][0], false_moves=3), *worse["rays"][1:])
    fresh = dataclasses.replace(claimed, scores=worse, summaries={
        **claimed.summaries, "rays": dataclasses.replace(claimed.summaries["rays"],
                                                         error_p95_cm=7.5)})
    assert mapping_board.verify_mapping(path) == {
        "mappers/rays/summary/error_p95_cm": (claimed.summaries["rays"].error_p95_cm, 7.5),
        "mappers/rays/cases/0/false_moves": (0, 3)}


@pytest.mark.slow
def test_a_real_quick_run_reads_back_goes_on_the_board_and_verifies(tmp_path, capsys):
    from azgym import cli

    out = tmp_path / "run"
    assert cli.main(["bench", "mapping", "--quick", "--mapper", "prior", "--workers", "2",
                     "--out", str(out)]) == 0
    assert [row[1] for _, _, _, _, _, rows in mapping_board.mapping_tables(out)
            for row in rows] == ["prior"]
    capsys.readouterr()
    assert cli.main(["leaderboard", "verify", str(out / "mapping.json"), "--workers", "2"]) == 0
    assert f"{out / 'mapping.json'}: reproduced" in capsys.readouterr().out


def test_a_rerun_whose_frames_differ_is_told_one_line_a_list(tmp_path, monkeypatch):
    # A case's ransac errors are one figure per frame: a changed map moves hundreds at once.
    import azgym.bench.mapping.benchmark as benchmark

    claimed = hand_result()
    path = write_mapping(claimed, tmp_path)
    first = claimed.scores["rays"][2]
    moved = dataclasses.replace(first, localization_updated=(
        *first.localization_updated[:3], *(e + 1.0 for e in first.localization_updated[3:])))
    scores = {**claimed.scores, "rays": (*claimed.scores["rays"][:2], moved,
                                         *claimed.scores["rays"][3:])}
    fresh = dataclasses.replace(claimed, scores=scores)
    monkeypatch.setattr(benchmark, "run_mapping", lambda *_args, **_kwargs: fresh)
    [(key, (said, rerun))] = mapping_board.verify_mapping(path).items()
    assert key == "mappers/rays/cases/2/localization_updated"
    assert said == f"frame 3: {first.localization_updated[3]!r} (and 8 more frames)"
    assert rerun == f"frame 3: {first.localization_updated[3] + 1.0!r}"


def test_the_committed_mapping_file_is_sound_and_complete():
    """The board's file: the full suite, every built-in mapper."""
    from azgym.bench.mapping.results_file import load_mapping
    from azgym.mapping.registry import DEFAULT_MAPPERS

    committed = Path(__file__).resolve().parents[3] / "leaderboard" / "mapping"
    checked = load_mapping(committed / "mapping-dev.json")
    assert checked.record["quick"] is False
    assert list(checked.scores) == list(DEFAULT_MAPPERS)
    assert [path.name for path in committed.glob("*.json")] == ["mapping-dev.json"]
