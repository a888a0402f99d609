"""Mappers that attack the mapping benchmark's runner: each is stopped, named and charged.

A mapper is a plug-in and runs in a sealed process of its own
(:mod:`azgym.bench.mapping.worker`); what it can do is bounded: its time (killed at the time
limit), its answer's bytes (a cap), its death (recorded), its output (``/dev/null``), and what
its process holds (nothing of the truth). Each run here is the quick suite in a child process
limited in memory and time, so that a regression fails the test instead of hanging it.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

PLUGINS = Path(__file__).parent / "plugins" / "hostile_mappers.py"
MEMORY = 6 << 30
"""Address space the run may take [bytes]: far below what a 1 GB answer read whole would."""


def run(*attackers: str, time_limit: float = 2.0, env: dict[str, str] | None = None,
        seconds: float = 240.0) -> tuple[dict, str]:
    """The quick mapping suite with ``prior`` and the attackers: per mapper per case (case,
    failure, failed checkpoints), and everything the run printed."""
    specs = ["prior", *(f"{PLUGINS}:{name}" for name in attackers)]
    code = textwrap.dedent(f"""
        import json, resource
        resource.setrlimit(resource.RLIMIT_AS, ({MEMORY}, {MEMORY}))
        from azgym.bench.mapping.benchmark import run_mapping
        result = run_mapping("mapping", {specs!r}, quick=True, workers=2,
                             time_limit={time_limit})
        print(json.dumps({{spec: [[c.case, c.failure, c.checkpoint_failures] for c in cases]
                          for spec, cases in result.scores.items()}}))
    """)
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=seconds, env={**os.environ, **(env or {})}, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1]), done.stdout + done.stderr


def failures(scores: dict, name: str) -> list[str | None]:
    """Each case's failure of an attacker."""
    return [failure for _, failure, _ in scores[f"{PLUGINS}:{name}"]]


@pytest.mark.parametrize("attacker,why", [
    ("RaisingBuild", "it raised ValueError: no such survey"),
    ("HangingBuild", "timed out: building the mapper took longer than the 2 s limit"),
    ("ExitingBuild", "its process exited (exit code 4) without answering")])
def test_a_mapper_that_cannot_be_built_is_refused_before_any_case_runs(attacker, why, tmp_path):
    # as a plug-in localizer is: named by the command, exit code 2, nothing written
    began = time.monotonic()
    spec = f"{PLUGINS}:{attacker}"
    done = subprocess.run([sys.executable, "-m", "azgym", "bench", "mapping", "--quick",
                           "--mapper", "prior", "--mapper", spec, "--time-limit", "2",
                           "--out", str(tmp_path / "out")],
                          capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 2, done.stderr[-2000:]
    last = done.stderr.strip().splitlines()[-1]
    assert last == f"azgym: error: cannot build mapper {spec}: {why}"
    assert "mapping:" not in done.stderr  # no case was run
    assert not (tmp_path / "out" / "mapping.json").exists()
    assert time.monotonic() - began < 60.0


def test_a_mapper_that_sleeps_past_the_limit_is_killed_and_charged():
    began = time.monotonic()
    scores, _ = run("Sleeper", time_limit=1.0)
    assert failures(scores, "Sleeper") == ["timed out: the call took longer than the 1 s limit"] * 4
    # every checkpoint of the moved cases charged, but after three losses in a row given up, not
    # waited for one by one (45 checkpoints of a second each)
    lost = [lost for _, _, lost in scores[f"{PLUGINS}:Sleeper"]]
    assert lost[0] == lost[3] == 0 and lost[1] >= 3 and lost[2] >= 3
    assert time.monotonic() - began < 40.0 + 3 * 3 + 4
    assert all(f is None for _, f, _ in scores["prior"])


def test_a_mapper_that_exits_or_kills_itself_is_recorded_and_the_run_goes_on():
    scores, _ = run("Exiter", "Killer", "SystemExiter")
    assert set(failures(scores, "Exiter")) == {
        "its process exited (exit code 3) without answering"}
    assert set(failures(scores, "Killer")) == {
        "its process was killed by signal 9 without answering"}
    assert set(failures(scores, "SystemExiter")) == {"it raised SystemExit: bye"}
    assert all(f is None for _, f, _ in scores["prior"])


def test_a_mapper_s_output_goes_nowhere():
    scores, printed = run("Printer")
    assert "MAPPER WAS HERE" not in printed
    assert all(f is None for f in failures(scores, "Printer"))


def test_a_1_gb_answer_is_cut_at_the_cap():
    scores, _ = run("Flooder", time_limit=30.0, seconds=200.0)
    assert set(failures(scores, "Flooder")) == {"it answered more than 32 MiB"}


def test_a_malformed_answer_is_a_failure_named():
    scores, _ = run("Malformed")
    assert set(failures(scores, "Malformed")) == {
        "MapAnswer.xy holds a NaN or infinite position"}


def test_a_mapper_finds_no_truth_in_its_process(tmp_path):
    from azgym.bench.mapping.suites import get_mapping_suite

    suite = get_mapping_suite("mapping")
    cases = suite.build(suite.dev_seed, True)
    wanted = set()
    for case in cases:  # where the world has each beacon the prior has elsewhere or lacks
        truth = case.truth
        known = {} if case.prior.beacons is None else dict(zip(
            case.prior.beacons.ids.tolist(), case.prior.beacons.xyz[:, :2].tolist(),
            strict=True))
        for beacon, xy in zip(truth.beacons.ids.tolist(), truth.beacons.xyz[:, :2].tolist(),
                              strict=True):
            if known.get(beacon) != xy:  # (a shipped site's round figures are no secret)
                wanted.update(v for v in xy if v != round(v, 3))
        wanted.update(truth.poses[len(truth.poses) // 2].tolist())  # a true pose mid-drive
    given = {cases[0].drive.start[0]}  # the true start, which every case's drive carries
    report = tmp_path / "seeker.jsonl"
    scores, _ = run("TruthSeeker", time_limit=60.0, env={
        "AZGYM_SEEKER_VALUES": json.dumps([sorted(given), sorted(wanted - given)]),
        "AZGYM_SEEKER_REPORT": str(report)})
    assert all(f is None for f in failures(scores, "TruthSeeker"))
    found = [json.loads(line) for line in report.read_text().splitlines()]
    assert len(found) >= 4  # every call looked ...
    assert all(f["given"] == sorted(given) for f in found)  # ... and finds what it was given
    assert [f for f in found if f["hidden"] or f["types"]] == []
