"""Ray's own idea of which cluster to use, and a cluster that asks for a token.

Ray's ``ray.init()`` joins whatever ``RAY_ADDRESS`` names or the last ``ray start`` recorded (a
record that outlives its cluster is enough), and a head node started by Ray 2.60 asks for a
token when one exists. Each case runs azgym in a child process whose Ray files live in a
temporary folder of its own (``RAY_TMPDIR``), with a time limit, so the tests never read or
disturb another Ray on the machine: the one cluster started here is stopped by its process
group, never by ``ray stop``. Ray's ``auto`` joins any live instance it finds among the
machine's processes, so the case that needs none first waits until no instance lives.
"""

from __future__ import annotations

import os
import re
import secrets
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

pytest.importorskip("ray", reason="ray is not installed (pip install \"azgym[ray]\")")
pytestmark = [pytest.mark.skipif(sys.platform == "win32", reason="Ray's files and process groups"),
              pytest.mark.ray]

TIME_LIMIT = 150.0
"""The child's time [s]: a local Ray instance and a quick bench take about 15 s."""
STALE = "127.0.0.1:1"
"""A cluster's address where nothing listens: a record its cluster outlived."""


@pytest.fixture
def ray_dir() -> Iterator[Path]:
    """A Ray temporary folder of this test's own (short: Ray's socket paths must fit 107 bytes)."""
    with tempfile.TemporaryDirectory(prefix="azr", dir="/tmp") as folder:
        yield Path(folder)


def ray_env(ray_dir: Path, **extra: str) -> dict[str, str]:
    """The environment of a child that keeps its Ray files in ``ray_dir``; no Ray settings else."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("RAY_ADDRESS", "RAY_AUTH_MODE", "RAY_AUTH_TOKEN", "RAY_AUTH_TOKEN_PATH")}
    return {**env, "RAY_TMPDIR": str(ray_dir), **extra}


def record(ray_dir: Path, address: str) -> None:
    """Leave ``address`` where ``ray start`` records the current cluster."""
    (ray_dir / "ray").mkdir(exist_ok=True)
    (ray_dir / "ray" / "ray_current_cluster").write_text(address)


def bench(ray_dir: Path, env: dict[str, str], *options: str) -> subprocess.CompletedProcess[str]:
    """``azgym bench --backend ray`` on the quick default suite, lsq alone, one worker."""
    return subprocess.run(
        [sys.executable, "-m", "azgym.cli", "bench", "--backend", "ray", *options, "--quick",
         "--workers", "1", "--localizer", "lsq", "--out", str(ray_dir / "out")],
        capture_output=True, text=True, timeout=TIME_LIMIT, env=env)


@pytest.mark.slow
@pytest.mark.parametrize("where", ["a stale record", "RAY_ADDRESS"])
def test_without_address_azgym_starts_its_own_instance_whatever_ray_would_join(where, ray_dir):
    """Ray alone would join the address and refuse the local instance's size with a traceback."""
    if where == "RAY_ADDRESS":
        env = ray_env(ray_dir, RAY_ADDRESS=STALE)
    else:
        record(ray_dir, STALE)
        env = ray_env(ray_dir)
    done = bench(ray_dir, env)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "Traceback" not in done.stderr
    assert (ray_dir / "out" / "results.json").is_file()


def no_live_ray(wait: float = 60.0) -> None:
    """Wait until no Ray instance lives on this machine, as ``address="auto"`` looks for one.

    Ray's "auto" joins any live instance it finds among the machine's processes (a raylet's
    ``--gcs-address``) before it reads a record; an instance an earlier test started (or a
    test running beside this one) may take seconds to end. Ray's ``find_gcs_addresses``
    remembers the first non-empty answer for the life of the process, so this asks its
    uncached scan each time.
    """
    from ray._private.services import _find_address_from_flag

    def live() -> set[str]:
        return set(_find_address_from_flag("--gcs-address"))

    deadline = time.monotonic() + wait
    while found := live():
        assert time.monotonic() < deadline, f"a Ray instance still lives: {found}"
        time.sleep(0.5)


def test_auto_with_a_stale_record_is_refused_by_name_at_once(ray_dir):
    """Not 20 s of Ray retrying, then an error about something answering there."""
    no_live_ray()
    record(ray_dir, STALE)
    begun = time.monotonic()
    done = bench(ray_dir, ray_env(ray_dir), "--address", "auto")
    assert done.returncode == 2, done.stderr[-2000:]
    error = done.stderr.strip().splitlines()[-1]
    assert error.startswith("azgym: error: --address auto: the cluster `ray start` recorded, at "
                            ), error
    assert "does not answer within 5 s" in error
    assert time.monotonic() - begun < 60


def session(env: dict[str, str], address: str | None) -> subprocess.CompletedProcess[str]:
    """What :func:`~azgym.bench.run.ray_session.ray_session` says of where the actors run."""
    code = ("from azgym.bench.run.ray_session import ray_session\n"
            f"with ray_session({address!r}, 0, print):\n"
            "    pass\n")
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=TIME_LIMIT, env=env)


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


@pytest.fixture
def head(ray_dir: Path) -> Iterator[tuple[str, Path]]:
    """A one-node Ray cluster with token authentication, as docs/scaling.md starts one.

    Yields its address and its token's file. ``ray start --block`` stops its processes when
    it is signalled; it runs in a process group of its own, which is signalled at the end
    (never ``ray stop``, which would stop every Ray on the machine).
    """
    token = ray_dir / "token"
    token.write_text(secrets.token_hex(32))
    address = f"127.0.0.1:{free_port()}"
    log = (ray_dir / "head.log").open("w")
    starter = subprocess.Popen(
        ["ray", "start", "--head", "--block", "--port", address.rpartition(":")[2],
         "--num-cpus", "1", "--include-dashboard", "false", "--disable-usage-stats"],
        stdout=log, stderr=subprocess.STDOUT, start_new_session=True,
        env=ray_env(ray_dir, RAY_AUTH_MODE="token", RAY_AUTH_TOKEN_PATH=str(token),
                    RAY_GRACEFUL_SHUTDOWN_DRAIN_TIMEOUT_S="0"))  # stop at once when signalled
    try:
        deadline = time.monotonic() + 60
        while "Ray runtime started" not in (ray_dir / "head.log").read_text():
            assert starter.poll() is None and time.monotonic() < deadline, \
                (ray_dir / "head.log").read_text()[-2000:]
            time.sleep(0.5)
        yield address, token
    finally:
        os.killpg(starter.pid, signal.SIGTERM)
        try:
            starter.wait(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(starter.pid, signal.SIGKILL)
            starter.wait(timeout=30)
        log.close()


@pytest.mark.slow
def test_a_cluster_with_token_authentication_is_named_and_joined_with_its_token(head, ray_dir):
    """docs/scaling.md's one-node recipe: refused by name without the token, scored with it."""
    address, token = head
    begun = time.monotonic()
    refused = bench(ray_dir, ray_env(ray_dir), "--address", address)
    assert refused.returncode == 2, refused.stderr[-2000:]
    error = refused.stderr.strip().splitlines()[-1]
    assert error.startswith(f"azgym: error: --address {address}: the Ray cluster there requires "
                            "token authentication"), error
    assert "RAY_AUTH_MODE=token" in error
    assert refused.stderr.count("InvalidAuthToken") <= 2  # not Ray's twenty retries
    assert time.monotonic() - begun < 60
    joined = bench(ray_dir, ray_env(ray_dir, RAY_AUTH_MODE="token",
                                    RAY_AUTH_TOKEN_PATH=str(token)), "--address", address)
    assert joined.returncode == 0, joined.stderr[-2000:]
    assert (ray_dir / "out" / "results.json").is_file()
    # on the head node, `auto` finds the cluster `ray start` recorded (and Ray its token)
    found = session(ray_env(ray_dir, RAY_AUTH_TOKEN_PATH=str(token)), "auto")
    assert found.returncode == 0, found.stderr[-2000:]
    port = address.rpartition(":")[2]
    assert re.fullmatch(rf"Ray: the cluster at [\d.]+:{port} \(1 CPU\)\n", found.stdout)
