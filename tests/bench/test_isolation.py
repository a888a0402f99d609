"""Isolated contenders: a plug-in that hangs, crashes, exits, snoops or scribbles hurts itself."""

from __future__ import annotations

import json
import textwrap
import time

import numpy as np
import pytest

from azgym.bench.contenders import Contender
from azgym.bench.isolation import GIVE_UP_AFTER
from azgym.bench.runner import run_contenders
from azgym.bench.suites import get_suite
from azgym.cli import main

PLUGINS = {
    "sleeper": """
        import time

        class Sleeper:
            def localize(self, measurements, beacons):
                time.sleep(3600)
    """,
    "crasher": """
        import ctypes
        import azgym

        class Crasher:
            '''Segfaults on frames with an even number of detections, else answers as ransac.'''
            def __init__(self):
                self.ransac = azgym.make_localizer("ransac")

            def localize(self, measurements, beacons):
                if len(measurements) % 2 == 0:
                    ctypes.string_at(0)
                return self.ransac.localize(measurements, beacons)
    """,
    "exiter": """
        import sys

        class Exiter:
            def localize(self, measurements, beacons):
                sys.exit(3)
    """,
    "hard_exiter": """
        import os

        class HardExiter:
            def localize(self, measurements, beacons):
                os._exit(4)
    """,
    "hoarder": """
        class Hoarder:
            def localize(self, measurements, beacons):
                raise MemoryError("asked for 1 TB")
    """,
    "slow_builder": """
        import time

        class SlowBuilder:
            def __init__(self):
                time.sleep(3600)

            def localize(self, measurements, beacons):
                raise AssertionError("never built")
    """,
    "snoop": """
        import gc, sys
        import azgym

        def looks_like_truth(value):
            return type(value).__name__ in ("Case", "Pose", "Frame", "Observation") or (
                isinstance(value, tuple) and len(value) == 3
                and all(isinstance(v, float) for v in value))

        class Snoop:
            '''Answers the true pose if it can find one anywhere in its process.'''
            def localize(self, measurements, beacons):
                frame = sys._getframe()
                while frame is not None:
                    for name, value in frame.f_locals.items():
                        if name in ("case", "cases", "truth") or looks_like_truth(value):
                            raise RuntimeError(f"found {name}")
                    frame = frame.f_back
                found = [o for o in gc.get_objects() if type(o).__name__ == "Case"]
                if found:
                    raise RuntimeError(f"found {len(found)} cases")
                return azgym.Estimate.failure("no truth here", len(measurements))
    """,
    "forger": """
        import sys, threading, time

        class Forger:
            '''Hangs, while a thread keeps telling the runner that a new call just began.'''
            def localize(self, measurements, beacons):
                frame = sys._getframe()
                while "progress" not in frame.f_locals:
                    frame = frame.f_back
                progress = frame.f_locals["progress"]

                def forge():
                    while True:
                        progress[1] = time.monotonic_ns()
                        time.sleep(0.01)

                threading.Thread(target=forge, daemon=True).start()
                time.sleep(3600)
    """,
    "scribbler": """
        import azgym

        class Scribbler:
            '''Tries to corrupt what the other contenders are given, then answers as ransac.'''
            def __init__(self):
                self.ransac = azgym.make_localizer("ransac")
                self.refused = 0

            def localize(self, measurements, beacons):
                try:
                    measurements.azimuth.setflags(write=True)
                    measurements.azimuth[:] += 1.0
                except ValueError:
                    self.refused += 1
                beacons.xyz.setflags(write=True)
                beacons.xyz[:] += 5.0
                return self.ransac.localize(measurements, beacons)
    """,
}


@pytest.fixture(scope="module")
def cases():
    return get_suite("warehouse-static").build(7, True)[:24]


@pytest.fixture(scope="module")
def plugins(tmp_path_factory):
    folder = tmp_path_factory.mktemp("plugins")
    specs = {}
    for name, source in PLUGINS.items():
        (folder / f"{name}.py").write_text(textwrap.dedent(source))
        cls = source.split("class ")[1].split(":")[0].strip()
        specs[name] = Contender(name, f"{folder / name}.py:{cls}")
    return specs


@pytest.fixture(scope="module")
def alone(cases):
    return run_contenders(cases, [Contender("ransac", "ransac")])["ransac"]


def same_scores(a, b):
    return (np.array_equal(a.ok, b.ok) and np.array_equal(a.position, b.position, equal_nan=True)
            and np.array_equal(a.heading, b.heading, equal_nan=True))


def test_a_localizer_that_hangs_costs_at_most_its_time_limit_per_frame(cases, plugins):
    limit = 0.5
    begun = time.monotonic()
    outcome = run_contenders(cases, [plugins["sleeper"]], time_limit=limit)["sleeper"]
    assert time.monotonic() - begun < len(cases) * limit
    assert not outcome.ok.any()
    timed_out = [e for e in outcome.errors if e.startswith("timed out")]
    assert len(timed_out) == GIVE_UP_AFTER
    assert all(e.startswith(("timed out", "not run")) for e in outcome.errors)


def test_a_localizer_that_forges_its_progress_is_still_stopped(cases, plugins):
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


def test_a_localizer_that_cannot_be_built_in_time_is_scored_unavailable(cases, plugins):
    outcome = run_contenders(cases, [plugins["slow_builder"]], time_limit=0.5)["slow_builder"]
    assert not outcome.ok.any()
    assert set(outcome.errors) == {"building the localizer took longer than the 0.5 s limit"}


@pytest.mark.parametrize("bad", [0, -1.0, float("nan"), "10"])
def test_the_time_limit_must_be_a_positive_number(cases, bad):
    with pytest.raises(Exception, match="time_limit must be a finite number > 0"):
        run_contenders(cases, [Contender("ransac", "ransac")], time_limit=bad)


def test_bench_with_a_sleeper_finishes_within_frames_times_the_limit(plugins, tmp_path, capsys):
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


@pytest.mark.parametrize("bad", ["0", "-2", "nan", "soon"])
def test_bench_refuses_a_time_limit_that_is_not_a_positive_number(bad, capsys):
    with pytest.raises(SystemExit) as stop:
        main(["bench", "--time-limit", bad])
    assert stop.value.code == 2
    assert "--time-limit: must be a number of seconds > 0" in capsys.readouterr().err
