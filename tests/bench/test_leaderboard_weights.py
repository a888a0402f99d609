"""A weight file in results and entries: pinned by its SHA-256 as a plug-in file is."""

from __future__ import annotations

import hashlib
import json
import os
import shutil

import pytest

from azgym.bench.leaderboard import entries as L
from azgym.bench.leaderboard.plugin_files import plugin_record
from azgym.bench.run.runner import Contender, run_benchmark
from azgym.bench.suites import get_suite
from azgym.localize.learned.ng_ransac import SHIPPED_WEIGHTS


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A run of ng-ransac with a weight file named relative to the run's folder."""
    work = tmp_path_factory.mktemp("work")
    weights = shutil.copy(SHIPPED_WEIGHTS, work / "model.npz")
    with pytest.MonkeyPatch.context() as patch:
        patch.chdir(work)
        run_benchmark(get_suite("stress"),
                      [Contender("mine", "ng-ransac", {"weights": "model.npz"})],
                      quick=True).write(work / "out", figures=False)
    return weights


@pytest.fixture
def weights_entry(run, tmp_path, monkeypatch):
    """The run's entry, submitted to another folder; the weight file is put back afterwards."""
    original = run.read_bytes()
    path = L.submit(run.parent / "out", "mine", tmp_path / "site" / "entries", name="mine",
                    version="1", authors=["a"])
    monkeypatch.chdir(tmp_path / "site")  # verify runs from elsewhere
    yield run, path
    run.write_bytes(original)


def test_results_record_the_weight_file_beside_its_path(weights_entry):
    weights, _ = weights_entry
    row = json.loads((weights.parent / "out" / "results.json").read_text())["localizers"]["mine"]
    assert row["params"] == {"weights": "model.npz"}
    assert row["weights_file"] == str(weights.resolve())
    assert row["weights_sha256"] == hashlib.sha256(weights.read_bytes()).hexdigest()


def test_a_weight_file_entry_verifies_from_any_folder_and_names_a_changed_or_missing_file(
        weights_entry):
    weights, path = weights_entry
    stored = json.loads(path.read_text())["localizer"]
    relative = os.path.relpath(weights, path.parent)  # the file named from the entry's folder
    assert stored["params"] == {"weights": relative} and not os.path.isabs(relative)
    assert stored["weights_sha256"] == hashlib.sha256(weights.read_bytes()).hexdigest()
    assert L.verify(path) == {}
    weights.write_bytes(weights.read_bytes() + b"\0")
    with pytest.raises(L.LeaderboardError, match="localizer/weights_sha256: weight file changed "
                       "since the entry was made: sha256 [0-9a-f]{64}, the entry was scored "
                       "with"):
        L.verify(path)
    weights.unlink()
    with pytest.raises(L.LeaderboardError, match=r"localizer/params/weights: the weight file "
                       r"\S+model.npz does not exist .a weight file is named relative to the "
                       "entry's folder"):
        L.verify(path)


def test_submit_refuses_a_weight_file_changed_since_the_run(weights_entry, tmp_path):
    weights, _ = weights_entry
    weights.write_bytes(weights.read_bytes() + b"\0")
    with pytest.raises(L.LeaderboardError, match="localizer/params/weights: weight file changed "
                       "since the run"):
        L.submit(weights.parent / "out", "mine", tmp_path / "site" / "entries",
                 name="mine2", version="1", authors=["a"])


@pytest.mark.parametrize(("change", "message"), [
    (lambda localizer: localizer["params"].update(weights="/abs/model.npz"),
     "localizer/params/weights: '/abs/model.npz' is an absolute path; a weight file is named "
     "relative to the entry's folder"),
    (lambda localizer: localizer.pop("weights_sha256"),
     "localizer/weights_sha256: a weight file's SHA-256 is required"),
    # hyperparameters in the spec would escape the checks of localizer/params
    (lambda localizer: localizer.update(spec="ng-ransac:weights=/abs/model.npz"),
     "localizer/spec: 'ng-ransac:weights=/abs/model.npz' carries hyperparameters"),
    (lambda localizer: localizer.update(spec="/abs/evil.py:Evil:tag=1"),
     "localizer/spec: '/abs/evil.py:Evil:tag=1' carries hyperparameters"),
])
def test_an_entry_must_pin_its_weight_file(weights_entry, change, message):
    _, path = weights_entry
    entry = json.loads(path.read_text())
    change(entry["localizer"])
    path.write_text(json.dumps(entry))
    with pytest.raises(L.LeaderboardError, match=message):
        L.load_entry(path)


def test_a_weight_path_that_is_no_file_is_left_out_of_the_record(tmp_path):
    # The run scored it as unable to build; recording it must not read a device or wait.
    assert plugin_record("ng-ransac", {"weights": "/dev/zero"}) == {}
    assert plugin_record("ng-ransac", {"weights": str(tmp_path / "none.npz")}) == {}
    assert plugin_record("ng-ransac") == {}
