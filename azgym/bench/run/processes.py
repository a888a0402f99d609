"""The worker processes of the pool: started from the fork server, heard, stopped.

The fork server (:mod:`azgym.bench.run.preload`) is a fresh interpreter that imported azgym and
loaded the compiled code of the run's built-ins; every worker forks from it, so it starts in
milliseconds and holds nothing of the run that started it. :mod:`azgym.bench.run.isolation`
drives the workers.
"""

from __future__ import annotations

import contextlib
import json
import multiprocessing
import os
import sys
import time
import types
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from azgym.bench.run import worker
from azgym.bench.run.answers import death
from azgym.bench.run.wire import STOP, MapData, ProtocolError, heard, write_all
from azgym.profile import Profile

__all__ = ["WARM_UP", "Worker", "build_verdict", "caller_main_hidden", "context",
           "default_workers", "poll", "start_fork_server", "start_worker", "stop"]

PRELOAD = "azgym.bench.run.preload"
WARM_UP = "AZGYM_FORK_SERVER_WARMS"
"""The environment variable that tells a starting fork server which built-ins to warm up: their
labels, a JSON list (:func:`start_fork_server`)."""


def context() -> Any:
    """The fork-server context the workers start from (the server starts on first use)."""
    ctx = multiprocessing.get_context("forkserver")
    ctx.set_forkserver_preload([PRELOAD])
    return ctx


def start_fork_server(warm: Sequence[str] | None = None) -> None:
    """Start the fork server now, so its warm-up overlaps whatever the caller does next.

    Args:
        warm: The labels of the built-in contenders it runs through the warm-up route, in that
            order (:mod:`~azgym.bench.run.preload`; None: the bench's defaults). A fork server
            already running keeps what it loaded: a worker whose contender it did not warm up
            loads or compiles its kernels itself, within the allowance a built-in's warm-up has.
    """
    context()
    from multiprocessing import forkserver

    before = os.environ.get(WARM_UP)
    if warm is not None:
        os.environ[WARM_UP] = json.dumps(list(warm))  # the server's environment is ours
    try:
        forkserver.ensure_running()
    finally:
        if before is None:
            os.environ.pop(WARM_UP, None)
        else:
            os.environ[WARM_UP] = before


@dataclass
class Worker:
    """One worker process and its shared memory (progress, and its step's answers).

    ``inbox`` holds what it has said that is not a whole message yet.
    """

    process: Any
    conn: Any
    progress: Any
    answers: Any
    ready: bool = False
    batch: Any = None  # the isolation's batch it is answering, if any
    started: float = 0.0
    inbox: bytearray = field(default_factory=bytearray)


def start_worker(spec: str, params: dict[str, Any], profile: Profile | None,
                 maps: Mapping[str, MapData], capacity: int) -> Worker:
    """A fresh worker process for a contender, answering steps of up to ``capacity`` frames.

    It builds the contender with ``params`` and the profile's defaults under them.
    """
    ctx = context()
    mine, theirs = ctx.Pipe()
    progress = ctx.RawArray("q", [worker.IDLE, 0])
    answers = ctx.RawArray("d", capacity * worker.ANSWER_SIZE)
    process = ctx.Process(target=worker.serve, daemon=True, name=f"azgym {spec}",
                          args=(theirs, progress, answers, spec, params, profile, maps,
                                os.getcwd()))
    started = time.monotonic()  # before start(): the worker may begin building at once
    with caller_main_hidden():
        process.start()
    theirs.close()
    return Worker(process, mine, progress, answers, started=started)


@contextlib.contextmanager
def caller_main_hidden() -> Iterator[None]:
    """Start workers without the caller's main script.

    multiprocessing re-runs the parent's ``__main__`` in a new process so that functions defined
    there can be found. A worker needs none of it (it runs azgym's worker and a localizer given
    by an importable spec), and re-running a user's script there would repeat its work, fail for
    a script read from standard input, and put whatever that script computes (true poses
    included) into the localizer's process. While a worker starts, ``__main__`` is a bare
    stand-in module.
    """
    main = sys.modules["__main__"]
    sys.modules["__main__"] = types.ModuleType("__main__")
    try:
        yield
    finally:
        sys.modules["__main__"] = main


def build_verdict(w: Worker) -> str | None:
    """What a worker has said of its build so far.

    "" when it is ready, why it is not, or None when it has not said it all yet.
    """
    try:
        data = os.read(w.conn.fileno(), 1 << 16)
        w.inbox += data
        messages = heard(w.inbox)
    except (OSError, ProtocolError) as exc:
        return f"the localizer's process broke the worker's protocol: {exc}"
    match messages[:1]:
        case [["ready"]]:
            w.ready = True
            return ""
        case [["unbuildable", str(why)]]:
            return why
        case []:
            return None if data else death(w.process)
    return f"the localizer's process broke the worker's protocol: {str(messages[0])[:80]}"


def poll(conn: Any) -> bool:
    """Whether the pipe has something to read (its end, too); False when it cannot be read."""
    try:
        return bool(conn.poll())
    except (EOFError, OSError):
        return False


def stop(w: Worker) -> None:
    """End a worker: ask politely when idle, kill it otherwise."""
    if w.process.is_alive():
        if w.batch is None and w.ready:
            try:
                write_all(w.conn.fileno(), STOP)
            except OSError:
                pass
            w.process.join(timeout=1.0)
        if w.process.is_alive():
            w.process.kill()
    w.process.join(timeout=5.0)
    w.conn.close()


def default_workers() -> int:
    """One worker process per core."""
    return max(1, os.cpu_count() or 1)
