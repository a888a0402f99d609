"""Leaderboard entries scored on a log (``data:NAME``): made, checked against the log, rerun,
shown one table per dataset; and every way of tampering with one refused by name."""

from __future__ import annotations

import gzip
import hashlib
import json
import re
import shutil

import pytest
from logs.mini_log import mini_files, write_log

from azgym.bench.leaderboard import board as B
from azgym.bench.leaderboard import entries as L
from azgym.bench.run.runner import Contender, run_log_benchmark
from azgym.cli import main
from azgym.logs import read_log


@pytest.fixture(scope="module")
def mini_run(tmp_path_factory):
    """The mini log (its map a beacons.csv) and a run of lsq and ransac on it."""
    root = tmp_path_factory.mktemp("data")
    log = write_log(root / "mini", mini_files())
    out = root / "results"
    result = run_log_benchmark(read_log(log), [Contender("lsq", "lsq"),
                                               Contender("ransac", "ransac")])
    written = result.write(out)
    return log, out, written


@pytest.fixture
def board(mini_run, tmp_path):
    """An entry of lsq on the mini log, in entries/, its log in datasets/ beside it."""
    log, results, _ = mini_run
    shutil.copytree(log, tmp_path / "datasets" / "mini")
    path = L.submit(results, "lsq", tmp_path / "entries", name="lsq-data-mini", version="1",
                    authors=["A. Author"])
    return path


def rewrite(path, change):
    entry = json.loads(path.read_text())
    change(entry)
    path.write_text(json.dumps(entry))


def rewrite_frames(path, change):
    """Edit an entry's per-frame rows (lists of cells) and redo its results_sha256."""
    frames = path.parent / f"{path.stem}.frames.csv.gz"
    lines = gzip.decompress(frames.read_bytes()).decode().splitlines()
    rows = [line.split(",") for line in lines[1:]]
    change(rows)
    text = "\n".join([lines[0], *(",".join(row) for row in rows)]) + "\n"
    frames.write_bytes(gzip.compress(text.encode()))
    rewrite(path, lambda e: e.update(results_sha256=hashlib.sha256(text.encode()).hexdigest()))


def test_a_run_on_a_log_makes_a_sound_entry_that_verify_reproduces(board):
    entry = L.load_entry(board)
    log = read_log(board.parent.parent / "datasets" / "mini")
    assert (entry["suite"], entry["split"], entry["seed"], entry["quick"]) == \
        ("data:mini", "data", 0, False)
    assert entry["format"] == L.ENTRY_FORMAT == 4
    assert entry["dataset"] == {"name": "mini", "sha256": log.sha256, "format": 1,
                                "simulated": True}
    assert entry["n_frames"] == 3
    assert L.verify(board) == {}


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda e: e["dataset"].update(sha256="0" * 64),
         r"dataset/sha256: the log .*mini changed since the entry was made"),
        (lambda e: e["dataset"].update(simulated=False),
         "dataset/simulated: the entry says False, the log's log.toml says True"),
        (lambda e: e["dataset"].update(format=3),
         "dataset/format: log format 3, this azgym reads formats 1, 2"),
        (lambda e: e.update(suite="data:other"),
         "suite: the entry's dataset is 'mini', so its suite is 'data:mini'"),
        (lambda e: e.update(seed=5), "seed: a log's frames are fixed: seed 0 at full size"),
        (lambda e: e.pop("dataset"), r"dataset: an entry scored on a log \(data:mini, split "
                                     "data\\) must name its dataset"),
        (lambda e: e.update(split="dev"), "split: an entry scored on a log has split 'data'"),
        (lambda e: e["metrics"]["all"].update(p75_cm=0.5),
         "metrics/all/p75_cm: the entry says 0.5, its per-frame results give"),
        (lambda e: e["metrics"]["tracking"].update(availability_after_first_fix=1.0),
         "metrics/tracking/availability_after_first_fix: the entry says 1.0"),
    ],
)
def test_a_tampered_dataset_entry_is_refused_by_name(board, change, message):
    rewrite(board, change)
    with pytest.raises(L.LeaderboardError, match=message):
        L.load_entry(board)


def test_a_suite_entry_cannot_claim_a_dataset(board):
    rewrite(board, lambda e: e.update(suite="stress", split="dev"))
    with pytest.raises(L.LeaderboardError, match="suite: the entry's dataset is 'mini'"):
        L.load_entry(board)


def test_a_log_edited_after_the_entry_is_refused(board):
    detections = board.parent.parent / "datasets" / "mini" / "detections.csv"
    lines = detections.read_text().splitlines()
    frame, beacon, azimuth, quality = lines[1].split(",")
    lines[1] = ",".join([frame, beacon, repr(float(azimuth) + 0.01), quality])
    detections.write_text("\n".join(lines) + "\n")
    with pytest.raises(L.LeaderboardError, match=r"dataset/sha256: the log \S*mini changed "
                                                 "since the entry was made"):
        L.load_entry(board)


def test_rows_moved_or_relabelled_against_the_log_are_refused(board):
    rewrite_frames(board, lambda rows: rows[1].__setitem__(4, "clean"))
    with pytest.raises(L.LeaderboardError, match=re.escape(
            "line 3: frame 1 is mini/mini/unlabelled (scenario/group/cause), the file says "
            "mini/mini/clean")):
        L.load_entry(board)
    rewrite_frames(board, lambda rows: rows[1].__setitem__(4, "unlabelled"))
    L.load_entry(board)  # restored: sound again
    rewrite_frames(board, lambda rows: rows.insert(0, rows.pop(1)))
    with pytest.raises(L.LeaderboardError, match="column frame: expected 0"):
        L.load_entry(board)
    rewrite_frames(board, lambda rows: rows.pop())  # a frame left out, renumbering the rest
    rewrite_frames(board, lambda rows: [row.__setitem__(1, str(k)) for k, row in
                                        enumerate(rows)])
    with pytest.raises(L.LeaderboardError, match="per-frame results: 2 frames, but the log mini "
                                                 "has 3"):
        L.load_entry(board)


def test_a_missing_dataset_stops_the_board_unless_it_is_left_off(board, tmp_path):
    shutil.rmtree(tmp_path / "datasets" / "mini")
    with pytest.raises(L.DatasetUnavailable, match="dataset: the log 'mini' is not available"
                       ) as refused:
        L.load_entry(board)
    assert "--skip-unavailable" not in str(refused.value)  # only build takes it
    with pytest.raises(L.DatasetUnavailable, match="--skip-unavailable"):
        B.build(board.parent, tmp_path / "out")
    assert not (tmp_path / "out").exists()
    readme, page = B.build(board.parent, tmp_path / "out", skip_unavailable=True)
    text = readme.read_text()
    assert "## data:mini" not in text and "| lsq-data-mini |" not in text
    assert "Not shown, because their datasets were not available to check them: " \
           "lsq-data-mini (mini)." in text


def test_a_datasets_folder_given_elsewhere_is_used(board, tmp_path):
    moved = tmp_path / "elsewhere"
    shutil.move(tmp_path / "datasets", moved)
    assert L.load_entry(board, moved)["dataset"]["name"] == "mini"
    assert L.verify(board, datasets=moved) == {}


def test_the_board_has_one_table_per_dataset_saying_simulated(board, tmp_path):
    sha = json.loads(board.read_text())["dataset"]["sha256"]
    readme, page = B.build(board.parent, tmp_path / "out")
    text = readme.read_text()
    assert f"## data:mini — the log mini: simulated data (log format 1, sha256 {sha[:12]})" \
        in text
    assert "| 1 | lsq-data-mini | 1 | A. Author |" in text and "data (full)" in text
    assert 'id="board-data-mini"' in page.read_text()


def test_the_cli_submits_builds_and_verifies_with_a_datasets_folder(mini_run, tmp_path, capsys):
    log, results, _ = mini_run
    shutil.copytree(log, tmp_path / "logs" / "mini")
    entries, datasets = str(tmp_path / "entries"), str(tmp_path / "logs")
    # not beside the entries, not shipped: refused, naming the dataset
    assert main(["leaderboard", "submit", str(results), "--localizer", "ransac", "--name", "r",
                 "--version", "1", "--authors", "me", "--entries", entries]) != 0
    assert "dataset: the log 'mini' is not available" in capsys.readouterr().err
    assert main(["leaderboard", "submit", str(results), "--localizer", "ransac", "--name", "r",
                 "--version", "1", "--authors", "me", "--entries", entries,
                 "--datasets", datasets]) == 0
    assert main(["leaderboard", "build", "--entries", entries, "--out", str(tmp_path / "b"),
                 "--datasets", datasets]) == 0
    assert main(["leaderboard", "verify", f"{entries}/r.json", "--datasets", datasets]) == 0
    assert "reproduced" in capsys.readouterr().out


def test_an_entry_on_the_shipped_log_is_found_by_name(tmp_path):
    log = read_log("warehouse-small-simulated")
    run_log_benchmark(log, [Contender("ransac", "ransac")]).write(tmp_path / "run",
                                                                    figures=False)
    path = L.submit(tmp_path / "run", "ransac", tmp_path / "entries", name="ransac-data",
                    version="1", authors=["me"])
    assert L.load_entry(path)["dataset"] == {"name": "warehouse-small-simulated",
                                             "sha256": log.sha256, "format": 1,
                                             "simulated": True}
    readme, _ = B.build(path.parent, tmp_path / "out")
    assert "## data:warehouse-small-simulated — the log warehouse-small-simulated: simulated " \
           "data" in readme.read_text()


def test_a_log_with_a_beacon_table_for_map_gets_its_figures(mini_run):
    _, out, written = mini_run
    names = {path.name for path in written}
    pytest.importorskip("matplotlib")
    assert {"error_map_mini.png", "trajectories_mini.png", "cdf.png"} <= names
    assert (out / "error_map_mini.png").stat().st_size > 1000


def test_a_datasets_folder_cannot_shadow_a_shipped_log(tmp_path):
    from azgym.bench.leaderboard.entry_data import find_dataset

    shutil.copytree(read_log("warehouse-small-simulated").folder,
                    tmp_path / "warehouse-small-simulated")
    with pytest.raises(L.LeaderboardError, match=r"has the name of a log shipped with azgym "
                                                 r"\('warehouse-small-simulated'\); a shipped "
                                                 r"log's name is taken"):
        find_dataset("warehouse-small-simulated", tmp_path)
    assert find_dataset("warehouse-small-simulated", None) is not None


def test_the_digest_of_a_log_on_a_shipped_map_covers_the_map(monkeypatch):
    import dataclasses

    import azgym.site
    from azgym.core import BeaconMap

    before = read_log("warehouse-small-simulated").sha256
    load = azgym.site.load_scenario

    def moved(name):
        scenario = load(name)
        xyz = scenario.beacons.xyz.copy()
        xyz[0, 0] += 0.5  # one beacon moved half a metre
        beacons = BeaconMap(scenario.beacons.ids, xyz, scenario.beacons.width)
        return dataclasses.replace(scenario, beacons=beacons)

    monkeypatch.setattr(azgym.site, "load_scenario", moved)
    assert read_log("warehouse-small-simulated").sha256 != before
