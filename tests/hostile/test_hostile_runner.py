"""A plug-in that looks for the seed of the test split it is scored on finds nothing.

Each attack of ``tests/hostile/plugins/seed_thief.py`` once let a plug-in redraw the stress
suite's frames and answer the truth (p75 0.00 cm, and ``verify`` said "reproduced"): the
runner's output redirected to a file, the runner's memory, ``verify``'s command line.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from azgym.bench.leaderboard.entries import submit

THIEF = Path(__file__).parent / "plugins" / "seed_thief.py"


def bench(out: Path, thief: str, *options: str, env: dict[str, str] | None = None,
          stdout=subprocess.PIPE) -> subprocess.Popen:
    """``azgym bench`` of the stress suite's quick test split with a thief, started."""
    return subprocess.Popen(
        [sys.executable, "-m", "azgym.cli", "bench", "--suite", "stress", "--quick", "--split",
         "test", "--localizer", f"{THIEF}:{thief}", "--workers", "1", "--time-limit", "60",
         "--out", str(out), *options],
        stdout=stdout, stderr=subprocess.PIPE, env={**os.environ, **(env or {})})


def thief_figures(out: Path, thief: str) -> dict:
    """The thief's overall figures in a run's results."""
    localizers = json.loads((out / "results.json").read_text())["localizers"]
    return localizers[f"{THIEF}:{thief}"]["all"]


def test_the_runner_s_output_in_a_file_does_not_give_the_seed_away(tmp_path):
    log = tmp_path / "bench.log"
    with log.open("w") as stdout:
        run = bench(tmp_path / "out", "StdoutThief", stdout=stdout)
        assert run.wait(timeout=600) == 0, run.stderr.read().decode()[-2000:]
    figures = thief_figures(tmp_path / "out", "StdoutThief")
    assert figures["availability"] == 0.0  # it never found the seed: no truth to answer
    text = log.read_text()
    assert "(test, seed withheld until every contender has answered)" in text
    seed = json.loads((tmp_path / "out" / "results.json").read_text())["seed"]
    assert f"(test, seed {seed}," in text  # in the table, once every contender has answered


@pytest.mark.parametrize(
    "backend", ["local", pytest.param("ray", marks=[pytest.mark.slow, pytest.mark.ray])])
def test_no_process_of_the_run_lets_a_worker_read_its_memory(tmp_path, backend):
    if backend == "ray":
        pytest.importorskip("ray", reason="ray is not installed")
    report = tmp_path / "readable.jsonl"
    run = bench(tmp_path / "out", "MemoryThief", "--backend", backend,
                env={"AZGYM_THIEF_REPORT": str(report)})
    assert run.wait(timeout=600) == 0, run.stderr.read().decode()[-2000:]
    readable = {pid for line in report.read_text().splitlines() for pid in json.loads(line)}
    assert run.pid not in readable  # the runner, which holds the cases and the seed
    assert thief_figures(tmp_path / "out", "MemoryThief")["availability"] == 0.0


@pytest.mark.slow
def test_verify_reruns_a_test_entry_on_a_fresh_seed_that_no_plug_in_can_read(tmp_path):
    # The submitter's own run, on a seed of their choosing, answered from the truth.
    own_run = (f"from pathlib import Path\n"
               f"from azgym.bench.run.contenders import contender\n"
               f"from azgym.bench.run.runner import run_benchmark\n"
               f"from azgym.bench.suites import get_suite\n"
               f"run_benchmark(get_suite('stress'), [contender('{THIEF}:CmdlineThief')], "
               f"split='test', seed=123456, quick=True).write(Path('{tmp_path / 'out'}'))\n")
    subprocess.run([sys.executable, "-c", own_run], check=True, timeout=600,
                   env={**os.environ, "THIEF_SEED": "123456"})
    assert thief_figures(tmp_path / "out", "CmdlineThief")["p75_all_cm"] == 0.0
    entry = submit(tmp_path / "out", f"{THIEF}:CmdlineThief", tmp_path / "entries",
                   name="thief-stress", version="1", authors=["A. Thief"])
    # verify names the entry, and the entry holds its seed; the rerun's frames are not those.
    done = subprocess.run([sys.executable, "-m", "azgym.cli", "leaderboard", "verify",
                           str(entry)], capture_output=True, text=True, timeout=600)
    assert done.returncode == 1, done.stdout + done.stderr
    assert "on a fresh secret seed" in done.stdout
    assert "ci95/p75_all_cm: entry [0.0, 0.0], rerun [None, None]" in done.stdout
    assert f"{entry}: NOT reproduced" in done.stdout
