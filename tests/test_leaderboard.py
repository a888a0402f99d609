"""Leaderboard entries: what a sound entry is, and every way a bad one is caught."""

from __future__ import annotations

import gzip
import json
import re

import pytest

from azgym.bench import leaderboard as L
from azgym.bench.runner import Contender, run_benchmark
from azgym.bench.suites import get_suite


@pytest.fixture(scope="module")
def results(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench")
    run_benchmark(get_suite("stress"), [Contender("ransac", "ransac"), Contender("lsq", "lsq")],
                  quick=True).write(out)
    return out


@pytest.fixture
def entry_path(results, tmp_path):
    return L.submit(results, "lsq", tmp_path / "entries", name="lsq-ref", version="1.0",
                    authors=["A. Author"], link="https://example.org")


def test_a_submitted_entry_validates_builds_and_reproduces(entry_path, tmp_path):
    entry = L.load_entry(entry_path)
    assert entry["name"] == "lsq-ref" and entry["localizer"] == {"spec": "lsq", "params": {}}
    assert (entry_path.parent / "lsq-ref.frames.csv.gz").is_file()
    readme, page = L.build(entry_path.parent, tmp_path / "board")
    assert "| 1 | lsq-ref | 1.0 | A. Author |" in readme.read_text()
    text = page.read_text()
    assert "<table class=\"board\"" in text and "<script>" in text and "http" not in text.split(
        "<script>")[1]  # self-contained: no external resources
    assert L.verify(entry_path) == {}


def rewrite(path, change):
    entry = json.loads(path.read_text())
    change(entry)
    path.write_text(json.dumps(entry))


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda e: e.pop("authors"), "(top level): 'authors' is a required property"),
        (lambda e: e.update(seed="7"), "seed: '7' is not of type 'integer'"),
        (lambda e: e["metrics"]["all"].update(mean_cm=1.0),
         "metrics/all/mean_cm: the entry says 1.0, its per-frame results give"),
        (lambda e: e.update(suite_version=99), "suite_version: stress is at version 1"),
        (lambda e: e.update(suite="nonsense"), "suite: unknown suite 'nonsense'"),
        (lambda e: e.update(results_sha256="0" * 64), "results_sha256: the per-frame results"),
        (lambda e: e.update(name="bad name!"), "name: 'bad name!' does not match"),
    ],
)
def test_malformed_or_tampered_entries_are_rejected_with_the_reason(entry_path, change, message):
    rewrite(entry_path, change)
    with pytest.raises(L.LeaderboardError, match=re.escape(message)):
        L.load_entry(entry_path)


def test_a_tampered_frames_file_is_caught(entry_path):
    frames = entry_path.parent / "lsq-ref.frames.csv.gz"
    lines = gzip.decompress(frames.read_bytes()).decode().splitlines()
    cells = lines[1].split(",")
    cells[6] = "0.0"  # claim a perfect estimate on the first frame
    frames.write_bytes(gzip.compress(("\n".join([lines[0], ",".join(cells), *lines[2:]])
                                      + "\n").encode()))
    with pytest.raises(L.LeaderboardError, match="results_sha256: the per-frame results file"):
        L.load_entry(entry_path)


def test_missing_frames_file_and_invalid_json(entry_path):
    (entry_path.parent / "lsq-ref.frames.csv.gz").unlink()
    with pytest.raises(L.LeaderboardError, match="results_file: lsq-ref.frames.csv.gz is missing"):
        L.load_entry(entry_path)
    entry_path.write_text("{not json")
    with pytest.raises(L.LeaderboardError, match="not valid JSON"):
        L.load_entry(entry_path)


def test_submit_refuses_unknown_localizers_and_overwrites(results, entry_path):
    with pytest.raises(L.LeaderboardError, match="no localizer 'mex' in the results"):
        L.submit(results, "mex", entry_path.parent, name="x", version="1", authors=["a"])
    with pytest.raises(L.LeaderboardError, match="an entry of that name exists"):
        L.submit(results, "lsq", entry_path.parent, name="lsq-ref", version="1", authors=["a"])

