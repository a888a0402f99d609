"""The command line's shared options and progress: one rule per kind of option, for every command.

``--time-limit SECONDS``, ``--workers N`` and ``--out DIR`` mean the same in ``azgym bench``,
``sweep``, ``layout``, ``leaderboard verify`` and ``reproduce``, and are refused the same way
while the command line is read; :func:`add_backend_options` defines ``--backend`` and
``--address`` once for ``bench`` and ``sweep``, and :func:`check_backend` and
:func:`resolve_workers` are the one reading of them and of ``--workers`` for the commands that
run the benchmark. ``--profile PROFILE.toml`` (:func:`profile_option`) names a profile file.
Every command that writes takes its output as ``--out DIR`` (:func:`out_folder`) or ``--out
FILE`` (:func:`out_file`), an empty name refused by both, and replaces nothing already there
without ``--overwrite`` (:func:`add_overwrite`, checked by :func:`azgym.files.claim_file` and
:func:`azgym.files.claim_folder` before any work). :func:`progress_printer` shows a run's
progress; :func:`stopped` ends a command interrupted by Ctrl-C with one line (what it kept,
:class:`Interrupted`, raised by :func:`on_ctrl_c`) and exit code 130;
:func:`ctrl_c_never_lost` delivers again a Ctrl-C that a library's clean-up swallowed.
"""

from __future__ import annotations

import _thread
import argparse
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any, TypeVar

from azgym.arguments import time_limit
from azgym.errors import InvalidInputError

if TYPE_CHECKING:
    from azgym.progress import Meter

T = TypeVar("T")

REDELIVERY_S = 0.02
"""How long after a finalizer dropped a Ctrl-C :func:`ctrl_c_never_lost` delivers it again."""

__all__ = ["REDELIVERY_S", "Interrupted", "add_backend_options", "add_overwrite", "check_backend",
           "ctrl_c_never_lost", "interruption_within", "on_ctrl_c", "out_file", "out_folder",
           "profile_option", "progress_printer", "resolve_workers", "seconds_option", "stopped",
           "workers_option"]


def seconds_option(text: str) -> float:
    """``--time-limit SECONDS``: a finite number of seconds, at least the runner's floor."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number of seconds, got {text!r}") from None
    try:
        return time_limit("", value)
    except InvalidInputError as exc:
        raise argparse.ArgumentTypeError(str(exc).strip()) from None


def workers_option(text: str) -> int:
    """``--workers N``: a whole number >= 0, 0 meaning one per core (or per CPU on Ray)."""
    try:
        value = int(text)
    except ValueError:
        value = -1
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be an integer >= 0 (0: one per core), "
                                         f"got {text!r}")
    return value


def out_folder(text: str) -> str:
    """``--out DIR``: refuse an empty folder name (it would mean the current folder, unasked)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("is empty: give a folder (. for the current one)")
    return text


def out_file(text: str) -> str:
    """``--out FILE``: refuse an empty file name (it names no file)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("is empty: give a file name")
    return text


def add_overwrite(parser: argparse._ActionsContainer, what: str) -> None:
    """``--overwrite``: let the command replace ``what`` it writes when it exists already.

    Without it an existing output is refused before any work starts; with it only the files
    the command writes are replaced, nothing else is removed.
    """
    parser.add_argument("--overwrite", action="store_true",
                        help=f"replace {what} if it exists (only the files azgym writes; "
                             "nothing else is removed)")


def profile_option(text: str) -> str:
    """``--profile PROFILE.toml``: refuse an empty file name (it names no profile)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("is empty: give a profile file (PROFILE.toml, as "
                                         "azgym calibrate writes it)")
    return text


def check_backend(args: argparse.Namespace) -> None:
    """``--address`` only with ``--backend ray``: refused before anything is drawn or run."""
    if args.address is not None and args.backend != "ray":
        raise InvalidInputError("--address is for --backend ray")


def resolve_workers(args: Any) -> int:
    """``--workers``: 0 is one per core here, or (with Ray) one per CPU of the cluster."""
    from azgym.bench.run.processes import default_workers

    if args.workers:
        return args.workers
    return 0 if getattr(args, "backend", "local") == "ray" else default_workers()


def add_backend_options(parser: argparse.ArgumentParser, note: str = "") -> None:
    """``--backend local|ray`` and ``--address ADDR``: one definition for bench and sweep."""
    from azgym.bench.run.backends import BACKENDS

    parser.add_argument("--backend", choices=BACKENDS.names(), default="local",
                        help="local: worker processes here; ray: Ray actors (pip install "
                             f"\"azgym[ray]\"), on --address or a local instance{note}")
    parser.add_argument("--address", metavar="ADDR", type=_address,
                        help="--backend ray: a Ray cluster's head, HOST:PORT (`ray start --head` "
                             "prints it; a cluster with token authentication also needs "
                             "RAY_AUTH_MODE=token, docs/scaling.md), ray://HOST:PORT, auto (the "
                             "cluster RAY_ADDRESS names or `ray start` recorded) or local "
                             "(default: a new local instance, whatever RAY_ADDRESS says)")


def _address(text: str) -> str:
    """``--address``: checked for its form (HOST:PORT, a port in 1-65535) as it is parsed."""
    from azgym.bench.run.ray_session import check_address

    try:
        check_address(text)
    except InvalidInputError as exc:
        raise argparse.ArgumentTypeError(str(exc).removeprefix(f"--address {text}: ")) from None
    return text


def progress_printer() -> Meter:
    """The progress every command shows: an :class:`azgym.progress.Meter`.

    Lines go to standard output, counts to standard error (a bar with the time left in a
    terminal, a line at least every few seconds otherwise).
    """
    from azgym.progress import Meter

    return Meter()


class Interrupted(KeyboardInterrupt):
    """Ctrl-C while a command runs, with what it kept (its message: ``checkpoints kept in ...``)."""


def interruption_within(error: BaseException) -> KeyboardInterrupt | None:
    """The Ctrl-C an error was raised from, if any.

    A Ctrl-C that lands inside a compiled kernel's machinery (numba unpickling a constant, say)
    reaches Python as a ``SystemError`` raised from the ``KeyboardInterrupt``; it is still the
    user's Ctrl-C, not a fault of the command.
    """
    seen: set[int] = set()
    cause: BaseException | None = error
    while cause is not None and id(cause) not in seen:
        if isinstance(cause, KeyboardInterrupt):
            return cause
        seen.add(id(cause))
        cause = cause.__cause__ or cause.__context__
    return None


def on_ctrl_c(run: Callable[[], T], kept: Callable[[], str]) -> T:
    """``run()``; a Ctrl-C during it raised as :class:`Interrupted` saying what was ``kept()``.

    The one rule of the commands that keep something when interrupted, the Ctrl-C a compiled
    kernel's machinery wrapped (:func:`interruption_within`) included.
    """
    try:
        return run()
    except (KeyboardInterrupt, SystemError) as exc:
        if interruption_within(exc) is None:
            raise
        raise Interrupted(kept()) from None


@contextmanager
def ctrl_c_never_lost() -> Iterator[None]:
    """Within: a Ctrl-C that landed in a finalizer is delivered again, not lost.

    Python cannot raise from a finalizer (an object's ``__del__``, a weakref callback, a cffi
    ``ffi.gc`` callback, which is how pymunk frees its spaces): a Ctrl-C that arrives while one
    runs is printed as "Exception ignored ..." and dropped, and the command would carry on as if
    no one had pressed it. Python hands every such exception to :data:`sys.unraisablehook`;
    within this block the hook passes anything else to the hook it replaced, and has an
    interruption delivered to the main thread again once the finalizer is over (a timer's
    thread, :data:`REDELIVERY_S` later: delivered at once, it would land in the hook itself and be
    dropped again). It lands in the command's own code, or in the next finalizer and comes back
    here.
    """
    previous = sys.unraisablehook
    redeliveries: list[threading.Timer] = []

    def deliver_again(unraisable: Any) -> None:
        exc_value = unraisable.exc_value
        if exc_value is not None and interruption_within(exc_value) is not None:
            redelivery = threading.Timer(REDELIVERY_S, _thread.interrupt_main)
            redelivery.daemon = True
            redelivery.start()
            redeliveries.append(redelivery)
        else:
            previous(unraisable)

    sys.unraisablehook = deliver_again
    try:
        yield
    finally:
        sys.unraisablehook = previous
        for redelivery in redeliveries:  # the command ended meanwhile: nothing left to stop
            redelivery.cancel()


def stopped(interruption: KeyboardInterrupt) -> int:
    """Say on one line that the command was interrupted, and what it kept; exit code 130.

    Wired in :func:`azgym.cli.main` around every command, so Ctrl-C shows no traceback.
    """
    kept = str(interruption) if isinstance(interruption, Interrupted) else ""
    print(f"\nazgym: interrupted{'; ' + kept if kept else ''}", file=sys.stderr, flush=True)
    return 130
