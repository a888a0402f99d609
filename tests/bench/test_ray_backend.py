"""--backend ray: the same figures as one local worker, the same isolation where Ray allows it."""

from __future__ import annotations

import os
import re
import socket
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from azgym.bench.run.contenders import Contender, contender
from azgym.bench.run.ray_session import ray_session
from azgym.bench.run.runner import run_benchmark, run_contenders
from azgym.bench.suites import get_suite
from azgym.bench.sweep.config import parse_sweep
from azgym.bench.sweep.run import run_sweep
from azgym.cli import main
from azgym.errors import DependencyNotInstalled

ray = pytest.importorskip("ray", reason="ray is not installed (pip install \"azgym[ray]\")")
pytestmark = pytest.mark.ray

PLUGINS = Path(__file__).parents[1] / "hostile" / "plugins"
ACCURACY = ("all", "ci95", "by_cause", "by_group", "tracking", "crashes", "first_error")


@pytest.fixture(scope="module")
def local_ray():
    """A local Ray instance of two CPUs for this module, stopped at its end.

    A new one (``local``) even where ``ray.init()`` would join ``RAY_ADDRESS`` or the cluster
    the last ``ray start`` recorded.
    """
    ray.init(address="local", num_cpus=2, include_dashboard=False)
    try:
        yield
    finally:
        ray.shutdown()


def plugin(stem: str) -> Contender:
    path = PLUGINS / f"{stem}.py"
    name = re.search(r"^class (\w+)", path.read_text(), re.MULTILINE).group(1)
    return Contender(stem, f"{path}:{name}")


def same_outcome(a, b) -> bool:
    return (np.array_equal(a.ok, b.ok) and a.errors == b.errors
            and np.array_equal(a.position, b.position, equal_nan=True)
            and np.array_equal(a.heading, b.heading, equal_nan=True)
            and np.array_equal(a.estimate, b.estimate, equal_nan=True))


@pytest.mark.slow
def test_ray_gives_the_figures_of_one_local_worker_on_the_default_suite(local_ray):
    suite = get_suite("warehouse-static")
    contenders = [contender("ransac"), contender("lsq"), contender("mex-coarse")]
    alone = run_benchmark(suite, contenders, quick=True, workers=1)
    spread = run_benchmark(suite, contenders, quick=True, workers=2, backend="ray")
    for label in alone.outcomes:
        assert same_outcome(alone.outcomes[label], spread.outcomes[label]), label
        mine, theirs = alone.summary["localizers"][label], spread.summary["localizers"][label]
        assert {k: mine[k] for k in ACCURACY} == {k: theirs[k] for k in ACCURACY}
        assert np.isfinite(spread.outcomes[label].micros).all()  # every call timed, remotely
    assert alone.summary["cases_sha256"] == spread.summary["cases_sha256"]


@pytest.mark.slow
def test_ray_keeps_a_route_whole_for_a_tracker(local_ray):
    cases = get_suite("warehouse-routes").build(11, True)[:60]
    tracker = [contender("gated-ekf")]
    alone = run_contenders(cases, tracker, workers=1)["gated-ekf"]
    spread = run_contenders(cases, tracker, workers=2, backend="ray")["gated-ekf"]
    assert same_outcome(alone, spread)


@pytest.mark.slow
def test_a_raising_and_a_hanging_plugin_cost_their_frames_under_ray_as_in_the_pool(local_ray):
    cases = get_suite("warehouse-static").build(7, True)[:8]
    contenders = [plugin("exiter"), plugin("hoarder"), plugin("sleeper")]
    pool = run_contenders(cases, contenders, workers=1, time_limit=1.0)
    begun = time.monotonic()
    remote = run_contenders(cases, contenders, workers=1, time_limit=1.0, backend="ray")
    # The sleeper sleeps an hour a frame: the run ends long before one frame would. (The bound
    # leaves room for a loaded machine: starting three actors took 38 s beside a busy suite.)
    assert time.monotonic() - begun < 300
    assert remote["exiter"].errors == ["SystemExit: 3"] * len(cases)
    assert remote["hoarder"].errors == ["MemoryError: asked for 1 TB"] * len(cases)
    sleeper = remote["sleeper"].errors
    assert sleeper[:3] == ["timed out: took longer than the 1 s limit"] * 3
    assert all(e.startswith("not run: 3 frames in a row were lost") for e in sleeper[3:])
    for label in pool:
        assert same_outcome(pool[label], remote[label]), label


@pytest.mark.slow
def test_a_localizer_that_kills_its_process_costs_its_frames_only(local_ray):
    cases = get_suite("warehouse-static").build(7, True)[:10]
    outcomes = run_contenders(cases, [plugin("crasher"), contender("ransac")], workers=2,
                              time_limit=5.0, backend="ray")
    alone = run_contenders(cases, [contender("ransac")], workers=1)["ransac"]
    assert same_outcome(outcomes["ransac"], alone)
    crasher = outcomes["crasher"]
    died = [e for e in crasher.errors if e == "the localizer's process was killed by SIGSEGV"]
    assert died and not crasher.ok[[bool(e) for e in crasher.errors]].any()
    assert np.array_equal(crasher.position[crasher.ok], alone.position[crasher.ok])


@pytest.mark.slow
def test_a_sweep_gives_the_same_table_on_ray_as_locally(local_ray):
    config = parse_sweep({"suites": ["warehouse-static"], "quick": True, "seeds": [7, 8],
                          "localizer": [{"name": "ransac", "grid": {"weighted": [False, True]}},
                                        {"name": "lsq"}]})
    here = run_sweep(config, workers=1)
    there = run_sweep(config, backend="ray", workers=2)
    assert here.csv() == there.csv()
    assert len(here.rows) == 6 and here.rows[0][:4] == ["warehouse-static", 7, "ransac", False]


@pytest.mark.slow
def test_a_session_in_a_process_that_has_ray_running_uses_it_and_says_so(local_ray):
    said: list[str] = []
    with ray_session(None, 0, said.append) as slots:
        assert slots == 2
    assert said == ["Ray: the Ray instance already running (2 CPUs)"]
    assert ray.is_initialized()  # not the session's to shut down


@pytest.mark.slow
def test_a_session_without_address_starts_a_local_instance_and_says_so(tmp_path):
    """Whatever RAY_ADDRESS names: Ray alone would join it (nothing listens there)."""
    code = ("from azgym.bench.run.ray_session import ray_session\n"
            "with ray_session(None, 1, print) as slots:\n"
            "    print(slots)\n")
    env = {**os.environ, "RAY_ADDRESS": "127.0.0.1:1"}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout == "Ray: a local Ray instance (1 CPU)\n1\n"


def test_bench_refuses_an_address_where_nothing_listens_by_name(tmp_path, capsys):
    begun = time.monotonic()
    code = main(["bench", "--backend", "ray", "--address", "127.0.0.1:1", "--localizer", "lsq",
                 "--workers", "1", "--out", str(tmp_path)])
    assert code == 2
    assert ("azgym: error: --address 127.0.0.1:1: no Ray cluster answers there within 5 s"
            in capsys.readouterr().err)
    assert time.monotonic() - begun < 60


@pytest.mark.parametrize(("command", "address", "problem"), [
    ("bench", "nonsense", "must be HOST:PORT"),
    ("bench", "127.0.0.1:99999", "invalid port 99999: a port is a whole number in 1-65535"),
    ("sweep", "127.0.0.1:0", "invalid port 0"),
    ("sweep", ":6379", "must be HOST:PORT"),
])
def test_an_address_of_the_wrong_form_is_refused_as_it_is_parsed(command, address, problem,
                                                                 tmp_path, capsys):
    """Before a config is read or a frame drawn: the port is not left to a connection attempt."""
    first = ["bench", "--quick"] if command == "bench" else ["sweep", str(tmp_path / "none.toml")]
    with pytest.raises(SystemExit) as exit_:
        main([*first, "--backend", "ray", "--address", address, "--out", str(tmp_path)])
    assert exit_.value.code == 2
    assert f"argument --address: {problem}" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())


@pytest.mark.slow
def test_an_address_where_something_else_listens_fails_by_name_within_the_deadline(tmp_path):
    """A server that accepts connections but is not Ray: Ray alone would wait for minutes."""
    with socket.create_server(("127.0.0.1", 0)) as server:
        port = server.getsockname()[1]
        code = ("import azgym.bench.run.ray_session as backend\n"
                "backend.JOIN_TIMEOUT = 3.0\n"
                "from azgym.cli import main\n"
                f"raise SystemExit(main(['bench', '--backend', 'ray', '--address', "
                f"'127.0.0.1:{port}', '--quick', '--workers', '1', '--localizer', 'lsq', "
                f"'--out', {str(tmp_path)!r}]))\n")
        begun = time.monotonic()
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              timeout=120)
    assert done.returncode == 2, done.stderr[-2000:]
    assert (f"azgym: error: --address 127.0.0.1:{port}: something answers there but no Ray "
            "cluster joined within 3 s") in done.stderr
    assert time.monotonic() - begun < 60


def test_address_is_refused_without_the_ray_backend():
    cases = get_suite("warehouse-static").build(7, True)[:2]
    with pytest.raises(ValueError, match="address is for backend 'ray'"):
        run_contenders(cases, [contender("lsq")], address="127.0.0.1:6379")


def test_a_missing_ray_names_the_extra_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)
    cases = get_suite("warehouse-static").build(7, True)[:2]
    with pytest.raises(DependencyNotInstalled, match=r'pip install "azgym\[ray\]"'):
        run_contenders(cases, [contender("lsq")], backend="ray")


def test_azgym_and_the_default_bench_never_import_ray():
    code = ("import sys, azgym, azgym.cli, azgym.bench.run.runner, azgym.bench.sweep.run\n"
            "from azgym.bench.run.runner import run_contenders\n"
            "from azgym.bench.suites import get_suite\n"
            "from azgym.bench.run.contenders import contender\n"
            "run_contenders(get_suite('warehouse-static').build(7, True)[:2], [contender('lsq')])\n"
            "assert 'ray' not in sys.modules, 'ray imported'\n")
    subprocess.run([sys.executable, "-c", code], check=True, timeout=300)
