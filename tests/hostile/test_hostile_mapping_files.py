"""Forged, tampered and oversized mapping results files: ``azgym leaderboard build`` and
``verify`` refuse each by name (the file, the mapper, the case and the field) before anything is
published or run.

A mapping file's summaries are recomputed from its case records, so a forger who edits a figure
must redo that bookkeeping; what does not depend on the mapper (the beacons scored, the moved
beacons and when they were seen, ransac on the true map) must agree between its mappers; and the
case records obey the scoring's rules. The attacks are made on a file of an invented run that
keeps every rule (tests/mapping_files.py).
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest
from mapping_files import edited, hand_result

from azgym import cli
from azgym.bench.leaderboard.entry_files import MAX_JSON_BYTES
from azgym.bench.mapping.report import write_mapping
from azgym.bench.mapping.results_file import MAX_MAPPERS

SHIPPED_ENTRIES = Path(__file__).resolve().parents[2] / "leaderboard" / "entries"


@pytest.fixture
def genuine(tmp_path):
    return write_mapping(hand_result(), tmp_path / "run")


def _build(tmp_path: Path, files: dict[str, Path], capsys) -> tuple[int, str]:
    """``azgym leaderboard build`` of one borrowed frame entry and these mapping files."""
    entries, mapping = tmp_path / "entries", tmp_path / "mapping"
    entries.mkdir(parents=True)
    mapping.mkdir()
    for name in ("ransac-paper.json", "ransac-paper.frames.csv.gz"):
        shutil.copy(SHIPPED_ENTRIES / name, entries / name)
    for name, source in files.items():
        shutil.copy(source, mapping / name)
    code = cli.main(["leaderboard", "build", "--entries", str(entries), "--out",
                     str(tmp_path / "out"), "--mapping", str(mapping)])
    return code, capsys.readouterr().err


@pytest.fixture(autouse=True)
def no_mapper_runs(monkeypatch):
    """A refused file must be refused before anything is run: running one fails the test."""
    import azgym.bench.mapping.benchmark as benchmark

    def no_run(*_args, **_kwargs):
        raise AssertionError("a mapper ran")

    monkeypatch.setattr(benchmark, "run_mapping", no_run, raising=False)


def _refused(tmp_path, capsys, forged: Path, pattern: str, board: bool = False) -> None:
    """``azgym leaderboard verify`` (or, with ``board``, ``build``) refuses ``forged`` with a
    message matching ``pattern`` before running anything; a board writes nothing."""
    if board:
        code, err = _build(tmp_path, {forged.name: forged}, capsys)
        assert not (tmp_path / "out").exists() or not any((tmp_path / "out").iterdir())
    else:
        code, err = cli.main(["leaderboard", "verify", str(forged)]), capsys.readouterr().err
    assert code == 2, err
    assert re.search(pattern, err), err


def _rays(data: dict) -> dict:
    return next(m for m in data["mappers"] if m["mapper"] == "rays")


def test_the_genuine_file_goes_on_the_board(genuine, tmp_path, capsys):
    code, err = _build(tmp_path, {"mapping-dev.json": genuine}, capsys)
    assert code == 0, err
    readme = (tmp_path / "out" / "README.md").read_text()
    assert "# Mapping: beacon maps surveyed and repaired from a drive" in readme
    assert "| 1 | rays | 2.6 | 4.2 |" in readme and "| 2 | prior | 0.0 | ∞ | ∞ |" in readme


def test_a_summary_that_does_not_follow_from_its_cases_is_refused(genuine, tmp_path, capsys):
    def better(data):
        _rays(data)["summary"]["error_p95_cm"] = 1.0

    forged = edited(genuine, tmp_path / "forged.json", better)
    for board in (False, True):
        _refused(tmp_path, capsys, forged, r"forged\.json: mappers/1 \(rays\)/summary/"
                 r"error_p95_cm: the file says 1\.0, its cases give 4\.2", board)


def test_the_truth_made_to_differ_between_mappers_is_refused(genuine, tmp_path, capsys):
    # Easier true-map figures for rays alone, which would flatter its ratio.
    def easier(data):
        case = _rays(data)["cases"][0]
        case["localization_true"] = [2 * e for e in case["localization_true"]]

    forged = edited(genuine, tmp_path / "forged.json", easier)
    _refused(tmp_path, capsys, forged, r"warehouse-small/aisle-loop/unknown: localization_true "
             r"differ between prior and rays, and they do not depend on the mapper")


def test_a_hard_case_left_out_is_refused(genuine, tmp_path, capsys):
    def drop(data):
        data["cases"].pop(0)
        for mapper in data["mappers"]:
            mapper["cases"].pop(0)

    forged = edited(genuine, tmp_path / "forged.json", drop)
    _refused(tmp_path, capsys, forged, r"forged\.json: cases must be the mapping suite's quick "
             r"cases, in order: warehouse-small/aisle-loop/unknown, ")


@pytest.mark.parametrize(("edit", "pattern"), [
    (lambda c: c["beacons"][0].update(error=None),
     r"cases/0/beacons/0/error: must be a finite number ≥ 0$"),
    (lambda c: c["beacons"][0].update(error=-0.01), r"cases/0/beacons/0/error: must be a "
     "finite number ≥ 0$"),
    (lambda c: c["beacons"][0].update(placed=1), r"cases/0/beacons/0/placed: must be true or "
     "false"),
    (lambda c: c["beacons"].append(dict(c["beacons"][0])), r"cases/0/beacons: names a beacon "
     "twice"),
    (lambda c: c.update(runtime=None), r"\(warehouse-small/aisle-loop/unknown\): a failed call "
     "has a reason and no runtime"),
    (lambda c: c.update(failure="x" * 3000), r"cases/0/failure: must be a text of 1 to 2000"),
    (lambda c: c.update(localization_updated=c["localization_updated"][1:]),
     r"localization_updated and localization_true must hold the same frames"),
    (lambda c: c.update(checkpoint_failures=True), r"cases/0/checkpoint_failures: must be a "
     "whole number"),
    (lambda c: c.update(extra=1), r"cases/0: unknown keys \['extra'\]"),
    (lambda c: c.pop("route"), r"cases/0: missing keys \['route'\]"),
    (lambda c: c.update(perturbation="moved"), r"cases/0: must be the case "
     r"warehouse-small/aisle-loop/unknown"),
], ids=["placed-without-position", "negative-error", "placed-not-bool", "beacon-twice",
        "no-runtime", "long-reason", "frames-differ", "bool-count", "unknown-key",
        "missing-key", "case-renamed"])
def test_a_case_record_out_of_its_rules_is_refused_by_field(edit, pattern, genuine, tmp_path,
                                                            capsys):
    def one(data):
        case = _rays(data)["cases"][0]
        edit(case)

    forged = edited(genuine, tmp_path / "forged.json", one)
    _refused(tmp_path, capsys, forged, r"forged\.json: mappers/1 \(rays\)/.*" + pattern)


@pytest.mark.parametrize(("edit", "pattern"), [
    (lambda m: m.update(delay=32.0), r"cases/1/moved/0/delay: must be a finite number from 0 "
     "to 30 or null"),
    (lambda m: m.update(seen=None), r"cases/1/moved/0/delay: a beacon never seen has no delay"),
    (lambda m: m.update(said=False), r"cases/1 \(warehouse-small/aisle-loop/moved\)/moved/0/"
     r"said: must be whether said_moved names beacon 8"),
], ids=["delay-past-window", "delay-never-seen", "said-disagrees"])
def test_a_moved_beacon_out_of_the_scoring_rules_is_refused(edit, pattern, genuine, tmp_path,
                                                           capsys):
    forged = edited(genuine, tmp_path / "forged.json",
                    lambda data: edit(_rays(data)["cases"][1]["moved"][0]))
    _refused(tmp_path, capsys, forged, pattern)


def test_a_false_move_count_that_disagrees_with_the_moves_said_is_refused(genuine, tmp_path,
                                                                         capsys):
    forged = edited(genuine, tmp_path / "forged.json",
                    lambda data: _rays(data)["cases"][3].update(false_moves=0))
    _refused(tmp_path, capsys, forged, r"cases/3 \(warehouse-small/aisle-loop/unchanged\)/"
             r"false_moves: the file says 0, its said_moved and moved give 1")


def test_a_plug_in_named_in_a_file_is_never_imported(genuine, tmp_path, capsys):
    marker = tmp_path / "imported"
    plugin = tmp_path / "evil.py"
    plugin.write_text(f"open({str(marker)!r}, 'w').close()\n"
                      "class Evil:\n    def survey(self, drive, prior):\n        return None\n")
    forged = edited(genuine, tmp_path / "forged.json",
                    lambda data: _rays(data).update(mapper=f"{plugin}:Evil"))
    _refused(tmp_path, capsys, forged, r"mappers/1/mapper: '.*evil\.py:Evil' is not a built-in "
             r"mapper \(a board runs no plug-in named in a file\)")
    assert not marker.exists()


@pytest.mark.parametrize(("edit", "pattern"), [
    (lambda d: d.update(split="test", seed=7), r"a mapping suite has a dev split only \(its "
     r"routes are public\), on seed 2900: got split 'test', seed 7"),
    (lambda d: d.update(suite_version=0), r"suite_version 0: mapping is at version 1; rerun it"),
    (lambda d: d.update(suite="navigation"), r"suite 'navigation' is not a mapping suite"),
    (lambda d: d.update(format=2), r"format must be 1, got 2"),
    (lambda d: d.update(time_limit_s=-1), r"time_limit_s \[s\]: must be a finite number from "
     r"0\.01 to 600$"),
    (lambda d: d.update(time_limit_s=1e9), r"time_limit_s \[s\]: must be a finite number from "
     r"0\.01 to 600$"),
    (lambda d: d.update(python="3" * 65), r"python: must be a text of at most 64 characters"),
    (lambda d: d["mappers"].append(d["mappers"][1]), r"mappers/2/mapper: rays is in the file "
     "twice"),
    (lambda d: d["mappers"].extend([d["mappers"][1]] * MAX_MAPPERS),
     rf"mappers must be a list of 1 to {MAX_MAPPERS}"),
    (lambda d: d["mappers"][1].update(mapper="rays:nonsense=1"), r"mappers/1/mapper: "
     r"'rays:nonsense=1' does not build"),
], ids=["test-split", "old-version", "other-suite", "format", "time-limit", "days-long-limit",
        "long-text", "mapper-twice", "too-many-mappers", "bad-hyperparameter"])
def test_a_file_out_of_its_suites_rules_is_refused(edit, pattern, genuine, tmp_path, capsys):
    _refused(tmp_path, capsys, edited(genuine, tmp_path / "forged.json", edit), pattern)


def test_an_oversized_file_is_refused_before_it_is_parsed(genuine, tmp_path, capsys):
    big = tmp_path / "big.json"
    text = genuine.read_text()
    big.write_text(text[:-3] + " " * MAX_JSON_BYTES + text[-3:])
    _refused(tmp_path, capsys, big,
             r"big\.json: \d+ bytes, larger than a mapping results file may be", board=True)


def test_nesting_and_nan_are_refused(genuine, tmp_path, capsys):
    deep = tmp_path / "deep.json"
    deep.write_text('{"kind": "mapping", "x": ' + "[" * 5000 + "]" * 5000 + "}")
    _refused(tmp_path / "deep", capsys, deep, r"deep\.json: not valid JSON: nested deeper than "
             "16", board=True)
    nan = tmp_path / "nan.json"
    nan.write_text(genuine.read_text().replace('"error_median_cm": 0.0', '"error_median_cm": NaN',
                                               1))
    _refused(tmp_path / "nan", capsys, nan, r"nan\.json: not valid JSON: NaN is not a JSON "
             "number", board=True)


def test_an_overflowing_number_read_as_infinity_is_refused(genuine, tmp_path, capsys):
    # 1e999 is no NaN or Infinity literal: JSON reads it as a float, infinite.
    text = genuine.read_text()
    for k, (old, new, pattern) in enumerate([
            ('"seed": 2900', '"seed": 1e999', r"got split 'dev', seed inf"),
            ('"error": 0.011', '"error": 1e999', r"mappers/1 \(rays\)/cases/1/beacons/0/error: "
             "must be a finite number ≥ 0$")]):
        assert old in text
        forged = tmp_path / f"forged-{k}.json"
        forged.write_text(text.replace(old, new, 1))
        _refused(tmp_path, capsys, forged, pattern)


@pytest.mark.parametrize(("old", "pattern"), [
    ('"error": 0.011', r"mappers/1 \(rays\)/cases/1/beacons/0/error: must be a finite number "
     "≥ 0$"),
    ('"time_limit_s": 60.0', r"time_limit_s \[s\]: must be a finite number from 0\.01 to "
     "600$"),
    ('"error_median_cm": 0.0', r"mappers/0 \(prior\)/summary/error_median_cm: the file says "
     r"1000+, its cases give 0\.0"),
    ('"runtime": 0.26', r"mappers/0 \(prior\)/cases/1/runtime: must be a finite number ≥ 0"),
], ids=["beacon-error", "time-limit", "summary", "runtime"])
def test_an_integer_too_large_for_a_float_is_refused_by_name(old, pattern, genuine, tmp_path,
                                                              capsys):
    # JSON integers have no bound: 10^400 overflows a float wherever one is made of it.
    text = genuine.read_text()
    assert old in text
    forged = tmp_path / "forged.json"
    forged.write_text(text.replace(old, old.split(": ")[0] + ": 1" + "0" * 400, 1))
    _refused(tmp_path, capsys, forged, pattern)


def test_two_runs_of_one_suite_and_size_are_refused_naming_both(genuine, tmp_path, capsys):
    code, err = _build(tmp_path, {"a.json": genuine, "b.json": genuine}, capsys)
    mapping = tmp_path / "mapping"
    assert code == 2
    assert (f"{mapping / 'a.json'} and {mapping / 'b.json'} are both runs of the mapping "
            "suite's quick cases: a board shows each case once") in err


def test_a_fifo_named_like_a_mapping_file_is_refused_at_once(tmp_path):
    import os
    import subprocess
    import sys

    fifo = tmp_path / "mapping-dev.json"
    os.mkfifo(fifo)
    code = ("import sys; from pathlib import Path\n"
            "from azgym.bench.mapping.results_file import load_mapping\n"
            "from azgym.errors import AzgymError\n"
            "try:\n    load_mapping(Path(sys.argv[1]))\n"
            "except AzgymError as exc:\n    print(exc)\n")
    try:
        done = subprocess.run([sys.executable, "-c", code, str(fifo)], capture_output=True,
                              text=True, timeout=20)
    except subprocess.TimeoutExpired:
        pytest.fail("a FIFO named like a mapping file hung its reader")
    assert "mapping-dev.json: cannot read the" in done.stdout and "FIFO" in done.stdout
