"""Isolated contenders: a plug-in that hangs, crashes, exits, snoops or scribbles hurts itself."""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from azgym.bench.run import worker
from azgym.bench.run.contenders import Contender
from azgym.bench.run.isolation import GIVE_UP_AFTER, STARTUP_LIMIT, IsolatedRun
from azgym.bench.run.processes import Worker
from azgym.bench.run.runner import run_contenders
from azgym.bench.suites import get_suite
from azgym.cli import main
from azgym.jit import PRECOMPILE_SWITCH
from azgym.localize.registry import is_builtin

PLUGINS = Path(__file__).parents[1] / "hostile" / "plugins"
"""Hostile plug-ins, one a file: each names the attack in its docstring."""


@pytest.fixture(scope="module")
def cases():
    return get_suite("warehouse-static").build(7, True)[:24]


@pytest.fixture(scope="module")
def plugins():
    specs = {}
    for path in sorted(PLUGINS.glob("*.py")):
        name = re.search(r"^class (\w+)", path.read_text(), re.MULTILINE).group(1)
        specs[path.stem] = Contender(path.stem, f"{path}:{name}")
    return specs


@pytest.fixture(scope="module")
def alone(cases):
    return run_contenders(cases, [Contender("ransac", "ransac")])["ransac"]


def same_scores(a, b):
    return (np.array_equal(a.ok, b.ok) and np.array_equal(a.position, b.position, equal_nan=True)
            and np.array_equal(a.heading, b.heading, equal_nan=True))


def test_a_localizer_that_hangs_costs_at_most_its_time_limit_per_frame(cases, plugins, alone):
    limit = 0.5  # (``alone`` ran first: the fork server is up, its first-run compile not timed)
    begun = time.monotonic()
    outcome = run_contenders(cases, [plugins["sleeper"]], time_limit=limit)["sleeper"]
    assert time.monotonic() - begun < len(cases) * limit
    assert not outcome.ok.any()
    timed_out = [e for e in outcome.errors if e.startswith("timed out")]
    assert len(timed_out) == GIVE_UP_AFTER
    assert all(e.startswith(("timed out", "not run")) for e in outcome.errors)


def test_a_localizer_that_forges_its_progress_is_still_stopped(cases, plugins, alone):
    limit = 0.3
    begun = time.monotonic()
    outcome = run_contenders(cases[:6], [plugins["forger"]], time_limit=limit)["forger"]
    assert time.monotonic() - begun < 6 * (6 + 1) * limit
    assert not outcome.ok.any()
    assert outcome.errors[0].startswith("timed out")


def test_segfaults_and_exits_are_scored_and_the_others_figures_do_not_move(cases, plugins,
                                                                             alone):
    contenders = [plugins["crasher"], Contender("ransac", "ransac"), plugins["exiter"],
                  plugins["hard_exiter"], plugins["hoarder"]]
    outcomes = run_contenders(cases, contenders, workers=2, time_limit=5.0)
    assert same_scores(outcomes["ransac"], alone)
    crasher = outcomes["crasher"]
    even = np.array([len(case.measurements) % 2 == 0 for case in cases])
    assert even.any() and (~even).any()
    killed = [e for e in crasher.errors if "killed by SIGSEGV" in e]
    assert killed and not crasher.ok[even].any()
    assert np.array_equal(crasher.position[crasher.ok], alone.position[crasher.ok])
    assert outcomes["exiter"].errors == ["SystemExit: 3"] * len(cases)
    hard = outcomes["hard_exiter"].errors
    assert "exited (exit code 4)" in hard[0] and hard[-1].startswith("not run")
    assert outcomes["hoarder"].errors == ["MemoryError: asked for 1 TB"] * len(cases)


def test_a_localizer_cannot_find_the_truth_in_its_process(cases, plugins):
    outcome = run_contenders(cases, [plugins["snoop"]])["snoop"]
    assert not outcome.ok.any()
    assert outcome.errors == [""] * len(cases)  # it answered every frame: "no truth here"


def test_a_localizer_cannot_change_what_others_are_given(cases, plugins, alone):
    outcomes = run_contenders(cases, [plugins["scribbler"], Contender("ransac", "ransac")])
    assert same_scores(outcomes["ransac"], alone)
    assert not same_scores(outcomes["scribbler"], alone)  # its own map copy is shifted 5 m


def test_a_localizer_cannot_fake_its_runtime_by_replacing_the_timer(cases, plugins):
    outcome = run_contenders(cases[:4], [plugins["clock_forger"]])["clock_forger"]
    assert outcome.ok.all() and (outcome.micros >= 4000).all()


def test_a_localizer_that_cannot_be_built_in_time_is_scored_unavailable(cases, plugins):
    outcome = run_contenders(cases, [plugins["slow_builder"]], time_limit=0.5)["slow_builder"]
    assert not outcome.ok.any()
    assert set(outcome.errors) == {"building the localizer took longer than the 0.5 s limit"}


@pytest.mark.parametrize("bad", [0, -1.0, float("nan"), "10", 1e-300])
def test_the_time_limit_must_be_a_positive_number(cases, bad):
    with pytest.raises(Exception,
                       match=r"time_limit must be (>= 0\.01 s|a finite number \[s\]), got "):
        run_contenders(cases, [Contender("ransac", "ransac")], time_limit=bad)


def test_bench_with_a_sleeper_finishes_within_frames_times_the_limit(plugins, alone, tmp_path,
                                                                     capsys):
    begun = time.monotonic()
    code = main(["bench", "--suite", "stress", "--quick", "--localizer", plugins["sleeper"].spec,
                 "--time-limit", "0.5", "--workers", "1", "--out", str(tmp_path)])
    assert code == 0
    frames = json.loads((tmp_path / "results.json").read_text())["n_frames"]
    assert time.monotonic() - begun < frames * 0.5
    assert "timed out: took longer than the 0.5 s limit" in capsys.readouterr().out


def test_bench_refuses_a_localizer_whose_constructor_hangs_before_the_run(plugins, tmp_path,
                                                                         capsys):
    code = main(["bench", "--localizer", plugins["slow_builder"].spec, "--time-limit", "0.5",
                 "--out", str(tmp_path / "out")])
    assert code == 2
    assert "building the localizer took longer than the 0.5 s limit" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(("bad", "message"), [
    ("0", "--time-limit: must be >= 0.01 s, got 0.0"),
    ("-2", "--time-limit: must be >= 0.01 s, got -2.0"),
    ("nan", "--time-limit: must be a finite number [s], got nan"),
    ("soon", "--time-limit: must be a number of seconds, got 'soon'"),
])
def test_bench_refuses_a_time_limit_that_is_not_a_positive_number(bad, message, capsys):
    with pytest.raises(SystemExit) as stop:
        main(["bench", "--time-limit", bad])
    assert stop.value.code == 2
    assert message in capsys.readouterr().err


@pytest.mark.parametrize(("spec", "builtin"), [
    ("ransac", True), ("ng-ransac:max_hypotheses=5", True), ("mex-coarse", True),
    ("robust", True), ("my_localizer.py:Mine", False), ("package.module:Class", False),
    ("not a spec::", False)])
def test_only_azgym_s_own_localizers_count_as_built_in(spec, builtin):
    assert is_builtin(spec) is builtin


def test_a_built_in_compiling_its_kernels_has_the_startup_allowance_not_the_time_limit():
    # A built-in's worker warms it up (compiling on a machine's first run) before it is ready;
    # that phase has the startup allowance, a build or a frame has the time limit.
    run = IsolatedRun("ransac", {}, [], {}, workers=1, time_limit=0.5, batches=[])
    began = time.monotonic()
    progress = [worker.WARMING, int(began * 1e9)]
    warming = Worker(process=None, conn=None, progress=progress, answers=None, started=began)
    assert run._deadline(warming) == pytest.approx(began + STARTUP_LIMIT)
    assert "compiling the built-in took longer than 300 s" in run._overrun_reason(warming)
    progress[0] = worker.BUILDING
    assert run._deadline(warming) == pytest.approx(began + 0.5)


WARM_UP_CHECK = """
import sys
import numba
from azgym.bench.run import worker
from azgym.bench.suites import get_suite
from azgym.bench.run.wire import pack, pack_map, unpack, unpack_map
from azgym.localize.registry import PRESETS, list_localizers, list_trackers
from azgym.site import load_scenario
from azgym.track.base import make_tracker

def overloads():
    return {f"{name}.{attr}": len(value.overloads)
            for name, module in list(sys.modules.items()) if name.startswith("azgym")
            for attr, value in vars(module).items()
            if isinstance(value, numba.core.dispatcher.Dispatcher)}

frames, maps = [], {}
for suite, seed in (("warehouse-static", 7), ("image-routes", 17), ("paper", 2021)):
    for case in get_suite(suite).build(seed, True)[:20]:
        frames.append(unpack(pack(case.scenario, case.measurements, case.sequence, case.initial,
                                  case.motion)))
        maps[case.scenario] = unpack_map(pack_map(load_scenario(case.scenario).beacons))
names = [n for n in list_localizers() if n not in PRESETS] + list(list_trackers())
trackers = [make_tracker(name) for name in names]
for tracker in trackers:
    worker.warm_up(tracker)
warm = overloads()

import os
quiet = os.open(os.devnull, os.O_WRONLY)
for tracker in trackers:
    worker.answer_step(quiet, [0, 0], [0.0] * (worker.ANSWER_SIZE * len(frames)), tracker,
                        frames, maps, None)
print({key: (warm.get(key, 0), count) for key, count in overloads().items()
       if count != warm.get(key, 0)})
"""


@pytest.mark.slow
def test_a_built_in_s_warm_up_reaches_every_specialization_of_a_real_frame():
    # numba compiles a kernel once per combination of argument types: a frame from the wire
    # (read-only arrays) with a quality column, or motion, is a new one. Whatever a warm-up
    # leaves out compiles inside a timed call, and on a slow machine runs past the time limit.
    done = subprocess.run([sys.executable, "-c", WARM_UP_CHECK], capture_output=True, text=True,
                          timeout=600, check=True)
    assert done.stdout.strip() == "{}", "compiled after the warm-up: " + done.stdout


def bench_availability(out: Path, env: dict[str, str]) -> dict[str, float]:
    """``azgym bench`` of the learned built-ins with a 1 s limit: each one's availability."""
    subprocess.run(
        [sys.executable, "-m", "azgym.cli", "bench", "--suite", "warehouse-static", "--quick",
         "--localizer", "ng-ransac", "--localizer", "learned", "--time-limit", "1",
         "--workers", "2", "--out", str(out)],
        capture_output=True, text=True, timeout=900, env=env, check=True)
    assert "timed out" not in (out / "frames.csv").read_text()
    localizers = json.loads((out / "results.json").read_text())["localizers"]
    return {label: row["all"]["availability"] for label, row in localizers.items()}


@pytest.mark.slow
def test_a_fresh_installation_scores_the_learned_built_ins_as_a_warm_one(tmp_path):
    # An empty kernel cache and no kernels from the installation (as after an edit of an editable
    # one): the run compiles everything, yet never inside a timed call (1 s here; a learned
    # built-in's first frame alone once compiled for 5-14 s), and the next run loads the kernels
    # the first one cached instead of taking them for stale.
    kernels = tmp_path / "kernels"
    env = {**os.environ, "NUMBA_CACHE_DIR": str(kernels), PRECOMPILE_SWITCH: "0"}
    fresh = bench_availability(tmp_path / "fresh", env)
    cached = {path: path.stat().st_mtime_ns for path in kernels.rglob("*.nbi")}
    assert fresh == bench_availability(tmp_path / "warm", env)
    assert min(fresh.values()) > 0.8
    assert cached and all(path.stat().st_mtime_ns == mtime for path, mtime in cached.items())


@pytest.mark.parametrize("phase", [worker.BUILDING, worker.WARMING, worker.IDLE])
def test_a_plugin_scribbling_on_its_build_progress_cannot_wait_without_end(phase):
    # During its build a plug-in can reach the shared progress slots: a phase and a start time
    # set far in the future must not lengthen the runner's own bound on the build.
    run = IsolatedRun("some/plugin.py:Plug", {}, [], {}, workers=1, time_limit=2.0,
                      batches=[])
    scribbled = Worker(None, None, [phase, 2**62], None, started=1000.0)
    assert run._deadline(scribbled) <= 1000.0 + STARTUP_LIMIT + 2.0
    builtin = IsolatedRun("ransac", {}, [], {}, workers=1, time_limit=2.0, batches=[])
    warming = Worker(None, None, [worker.WARMING, int(1001e9)], None, started=1000.0)
    assert builtin._deadline(warming) == 1001.0 + STARTUP_LIMIT  # a built-in's compile allowance
    assert run._deadline(warming) <= 1000.0 + STARTUP_LIMIT  # not a plug-in's


def test_a_message_nested_too_deeply_is_a_protocol_breach_not_a_crash():
    import struct

    from azgym.bench.run.wire import ProtocolError, heard

    body = b"[" * 100_000 + b"]" * 100_000
    inbox = bytearray(struct.pack("!i", len(body)) + body)
    with pytest.raises(ProtocolError, match="not JSON"):
        heard(inbox)
