"""The real datasets shipped as logs: each reads, is what the converter writes, and is on the board.

The shipped files are pinned by digest, so that a change to them is seen where the toolbox's
files are not (CI); where they are (``AZGYM_TRIANGULATION_TOOLBOX``, default the shared data
folder beside the repository), the converter must write the very same bytes again.
"""

from __future__ import annotations

import csv
import functools
import gzip
import hashlib
import importlib.util
import io
import json
import math
import os
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest
from logs.mini_log import mini_files_2, write_log

from azgym.bench.leaderboard import board as B
from azgym.bench.leaderboard import entries as L
from azgym.bench.run.contenders import Contender
from azgym.bench.run.runner import run_log_benchmark
from azgym.cli import main
from azgym.errors import InvalidInputError
from azgym.logs import Log, read_log
from azgym.logs.calibrate import calibrate
from azgym.logs.read import log_digest, shipped_logs
from azgym.profile import Profile, profile_toml

ROOT = Path(__file__).resolve().parents[2]
TOOLBOX = Path(os.environ.get("AZGYM_TRIANGULATION_TOOLBOX",
                              ROOT.parent / "shared" / "data" / "triangulation-toolbox"))

SHIPPED = {  # name: the log's SHA-256 (what entries record), frames, detections
    "roh": ("ec63e359b2cc0ce5d10217f62e963f54251c45f67bba32df077a32adab77524c", 1800, 7200),
    "mrclam-1": ("d612ea5930e5ee2224f20133767f51d37655a3d93cca1d56b8436e963afd7484", 9782, 32970),
    "mrclam-2": ("e3f97554da53fbb691128bc2c4912c379e0ddeb4880cdc6359155c25b6f1d543", 17335,
                 60892),
    "mrclam-3": ("07496cea9f3e5e24e4cdadfef7ca143095f0910d82417b1defd1126073baee55", 19840,
                 73206),
    "mrclam-4": ("257c2ac66801929855e452f5138bdffeae6d0aaadcd19a13960414e99f4627cb", 18939,
                 69924),
    "mrclam-5": ("fe468340ae1dea6da8ad521baa27df3c6f1032d308c5ce336b0a526c9ec5059a", 24006,
                 100051),
    "mrclam-6": ("fc9ca1bcbf68884dcea1b0c2c100f319dbd903ad11bda93c273bb07db3b302e3", 6783, 27335),
    "mrclam-7": ("67372207ac0a236d638df2aa49164a6989d30f780ff6c8c7d68bec95d998ef95", 6233, 25894),
    "mrclam-8": ("ed8140ad01bf5c9be4108e63163393764da8417347a57df4242a298ab15d65e3", 32785,
                 113812),
    "mrclam-9": ("cb0c0679d48d2d1d60785c2af030351a017732bcd8308286cac68021bcbe0a4a", 1816, 5618),
}
FOLDERS = {  # name: the digest of every file of its folder (the licence and README too)
    "roh": "5ec4b96f33b3ed287a0ae9ba2f024670e9354fcae07bc7c8abe72771bd2a0ec1",
    "mrclam-1": "2888d2bcf615ee0f27854a22ad070ea9b96494499242e80dabdb600f1ed88719",
    "mrclam-2": "4356d8fc96349ebc31e8dadc7f9ef0ef64278886bc2dd00ae6ee48b6aa7f2da8",
    "mrclam-3": "1e3d0dfc2484c75a82efc29537b3a6d302b499c061157f5cd9dfe6a320277d43",
    "mrclam-4": "37af37073daf72e08a622df938a92b4a33c9aa5b1048e0e1296f862f39864598",
    "mrclam-5": "154e967d3be41c6589c9f3c7b54ff198a20b342953d1a45fa214ef10cbe441c8",
    "mrclam-6": "93d567d3bc049d9b73b93b9d10b4a74185ddf7c11c1c237c52e2f6d53da027f5",
    "mrclam-7": "91b43cb8c237ec5732a91dd77f549eeed4525c150a9dfdb39e6db1d24c80794c",
    "mrclam-8": "64c7682e4fb2cf77af6a17ced2dcc11e3a8f27846a0a376507ac751bee8dcd27",
    "mrclam-9": "dcbaaf6cd6c7c128624fbb052c8c4315d2a402c445119c30ac8fa359358c41e1",
}
needs_toolbox = pytest.mark.skipif(not (TOOLBOX / "LICENSE").is_file(),
                                   reason=f"the Triangulation Toolbox's data is not at {TOOLBOX}")


@functools.cache
def shipped(name: str) -> Log:
    """A shipped log read by name, once for the module."""
    return read_log(name)


def folder_digest(folder: Path) -> str:
    return log_digest(sorted(folder.iterdir()))


def load_script(name: str):
    spec = importlib.util.spec_from_file_location(name, ROOT / "baselines" / f"{name}.py")
    assert spec is not None and spec.loader is not None
    module = sys.modules.setdefault(name, importlib.util.module_from_spec(spec))
    spec.loader.exec_module(module)
    return module


real_datasets = load_script("real_datasets")


def test_the_converter_writes_the_pinned_logs_and_the_entries_script_finds_them():
    assert tuple(SHIPPED) == real_datasets.NAMES
    assert sorted(load_script("leaderboard_entries").real_logs()) == sorted(SHIPPED)


@pytest.mark.parametrize("name", SHIPPED)
def test_a_real_log_reads_by_name_says_real_and_is_the_pinned_data(name):
    log = shipped(name)  # by name; every check, the truth/azimuth plausibility included
    sha256, frames, detections = SHIPPED[name]
    assert (log.sha256, len(log.frames["frame"]), len(log.detections["id"])) == \
        (sha256, frames, detections)
    folder = shipped_logs()[name]
    assert folder_digest(folder) == FOLDERS[name]
    assert sorted(p.name for p in folder.iterdir()) == sorted(real_datasets.FILES)
    assert log.manifest.simulated is False and log.manifest.format == 2
    assert "(real)" in log.manifest.description
    assert "Copyright (c) 2007, Sunglok Choi" in (folder / "LICENSE").read_text()
    readme = (folder / "README.md").read_text()
    assert "BSD licence" in readme and "Triangulation-Toolbox" in readme
    globs = tomllib.loads((ROOT / "pyproject.toml").read_text())["tool"]["setuptools"][
        "package-data"]["azgym.site.scenarios"]
    installed = {p.name for g in globs for p in (ROOT / "envs").glob(g) if p.parent.name == name}
    assert installed == set(real_datasets.FILES)


BIG = ("mrclam-2", "mrclam-3", "mrclam-4", "mrclam-5", "mrclam-8")
"""Logs whose calibration takes seconds."""


@pytest.mark.parametrize("name", [pytest.param(name, marks=pytest.mark.slow) if name in BIG
                                  else name for name in SHIPPED])
def test_the_sensor_section_is_what_azgym_calibrate_fits(name):
    calibration = calibrate(shipped(name))
    sensor = real_datasets.sensor_of(calibration)
    assert shipped(name).manifest.profile.sensor == sensor
    if name == "roh":
        assert sensor.field_of_view == 2 * math.pi and 0.06 < sensor.delta_alpha_d < 0.08
    else:
        assert 1.1 < sensor.field_of_view < 1.2 and 0.015 < sensor.delta_alpha_d < 0.05
        assert shipped(name).manifest.profile.vehicle.kind == "differential-drive"
    # Roh's heading is 90°; MRCLAM's bearings are relative to the heading, counter-clockwise:
    # the truth predicts the azimuths without an offset.
    _, residual, _ = calibration.residuals["azimuth"]
    assert residual.size == len(shipped(name).detections["id"])  # no id outside the map
    assert abs(math.degrees(float(np.median(residual)))) < 1.5


def test_roh_has_nine_positions_of_200_frames_with_four_bearings():
    log = shipped("roh")
    sequences, counts = np.unique(log.frames["sequence"], return_counts=True)
    assert len(sequences) == 9 and set(counts) == {200}
    assert "x1.5-y4.5" in sequences
    assert set(np.bincount(log.detections["frame"])) == {4}
    assert np.all(log.frames["heading"] == math.pi / 2)


def test_an_existing_log_is_not_written_over_without_overwrite(tmp_path):
    files = {"README.md": "new\n"}
    (tmp_path / "roh").mkdir()
    (tmp_path / "roh" / "README.md").write_text("old\n")
    with pytest.raises(InvalidInputError, match="roh: exists; pass --overwrite"):
        real_datasets.write_log(files, tmp_path / "roh", overwrite=False)
    assert (tmp_path / "roh" / "README.md").read_text() == "old\n"
    real_datasets.write_log(files, tmp_path / "roh", overwrite=True)
    assert (tmp_path / "roh" / "README.md").read_text() == "new\n"


@pytest.mark.slow
@needs_toolbox
def test_the_converter_writes_the_shipped_logs_byte_for_byte(tmp_path, capsys):
    assert real_datasets.main([str(TOOLBOX), "--out", str(tmp_path)]) == 0
    for name in SHIPPED:
        shipped = shipped_logs()[name]
        for path in shipped.iterdir():
            assert (tmp_path / name / path.name).read_bytes() == path.read_bytes(), path
        assert folder_digest(tmp_path / name) == FOLDERS[name]
    assert real_datasets.main([str(TOOLBOX), "--out", str(tmp_path), "--only", "roh"]) == 2
    assert "exists; pass --overwrite" in capsys.readouterr().err


@pytest.mark.slow
def test_bench_data_roh_scores_it_and_the_board_puts_it_in_the_real_part(tmp_path):
    """A real log's table is in the part headed "real"; a simulated log's stays with the suites."""
    entries = tmp_path / "entries"
    for name in ("roh", "warehouse-small-simulated"):
        out = tmp_path / name
        assert main(["bench", "--data", name, "--localizer", "ransac", "--workers", "1",
                     "--out", str(out)]) == 0
        summary = json.loads((out / "results.json").read_text())
        assert summary["dataset"]["name"] == name and summary["n_frames"] > 200
        sensor = shipped(name).manifest.profile.sensor  # the contenders' defaults
        assert summary.get("profile", {}).get("sensor") == profile_toml(
            Profile(sensor=sensor)).get("sensor")
        L.submit(out, "ransac", entries, name=f"ransac-data-{name}", version="1",
                 authors=["me"])
    readme, page = B.build(entries, tmp_path / "board")
    text = readme.read_text()
    simulated = text.index("## data:warehouse-small-simulated — the log "
                           "warehouse-small-simulated: simulated data")
    part = text.index(f"# {B.REAL_PART}\n\n{B.REAL_NOTE}")
    real = text.index(f"## data:roh — the log roh: real data (log format 2, sha256 "
                      f"{SHIPPED['roh'][0][:12]})")
    assert simulated < part < real
    html = page.read_text()
    assert html.index("board-data-warehouse-small-simulated") < \
        html.index(f"<h1>{B.REAL_PART}</h1>") < html.index('id="board-data-roh"')
    (entries / "ransac-data-roh.json").unlink()
    readme, page = B.build(entries, tmp_path / "board")
    assert B.REAL_PART not in readme.read_text() and B.REAL_PART not in page.read_text()


def test_an_entry_keeps_the_logs_frame_numbers_and_a_position_only_truth(tmp_path):
    """Results number a log's frames as the log does, and score no heading without a true one:
    such an entry is sound, and a row claiming a heading error is refused."""
    files = mini_files_2()  # frames 10, 12, 13
    files["frames.csv"] = "frame,time,x,y\n10,0.0,5.0,5.0\n12,0.1,5.1,5.0\n13,0.2,5.2,5.0\n"
    log = read_log(write_log(tmp_path / "datasets" / "mini2", files))
    run_log_benchmark(log, [Contender("ransac", "ransac")]).write(tmp_path / "run",
                                                                    figures=False)
    path = L.submit(tmp_path / "run", "ransac", tmp_path / "entries", name="r", version="1",
                    authors=["me"])
    assert L.load_entry(path)["n_frames"] == 3
    frames = tmp_path / "entries" / "r.frames.csv.gz"
    rows = list(csv.reader(io.StringIO(gzip.decompress(frames.read_bytes()).decode())))
    assert [row[1] for row in rows[1:]] == ["10", "12", "13"] and rows[1][7] == "nan"
    rows[1][7] = "0.0"  # a heading error the truth cannot give
    text = L.frames_file_text(rows[1:])
    frames.write_bytes(gzip.compress(text.encode()))
    entry = json.loads(path.read_text())
    entry["results_sha256"] = hashlib.sha256(text.encode()).hexdigest()
    path.write_text(json.dumps(entry))
    with pytest.raises(L.LeaderboardError, match=r"line 2, column heading_error_rad: must be "
                                                 r"NaN \(the truth has no heading\), got 0.0"):
        L.load_entry(path)
