"""Where the contenders run, by name: worker processes forked here, or Ray actors on a cluster.

A backend gives the runner (:func:`azgym.bench.run.runner.run_contenders`) the class that runs
one contender's batches of frames (:class:`~azgym.bench.run.isolation.IsolatedRun` or
:class:`~azgym.bench.run.ray_backend.RayRun`, which take the same arguments) and the session
that yields how many run at once, and says where they run when that is not on the command
line (which Ray instance or cluster). Neither is imported before a run asks for it, so naming the
backends (``--backend``) costs nothing, and Ray is imported only when ``backend="ray"`` is.
"""

from __future__ import annotations

from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from typing import Any

from azgym.arguments import whole_number
from azgym.errors import InvalidInputError
from azgym.registry import Registry

__all__ = ["BACKENDS", "Backend", "Say", "open_local", "open_ray"]

Say = Callable[[str], None] | None
"""Hears, as the session starts, where the contenders run (None: nobody)."""
Backend = Callable[[str | None, int, Say], tuple[Any, AbstractContextManager[int]]]
"""``(address, workers, say) -> (run class, session)``; the session yields the workers."""


def open_local(address: str | None, workers: int, say: Say = None
               ) -> tuple[Any, AbstractContextManager[int]]:
    """The process pool here: ``workers`` (at least one) processes from the fork server.

    ``say`` hears nothing: the pool's size is the command line's ``--workers``.

    Raises:
        InvalidInputError: An address (that is Ray's), or fewer than one worker.
    """
    from azgym.bench.run.isolation import IsolatedRun

    if address is not None:
        raise InvalidInputError("address is for backend 'ray' (a Ray cluster's address)")
    workers = whole_number("workers", workers, minimum=1)
    return IsolatedRun, nullcontext(workers)


def open_ray(address: str | None, workers: int, say: Say = None
             ) -> tuple[Any, AbstractContextManager[int]]:
    """Ray actors on the cluster at ``address``, else on a local instance (0 workers: one a CPU).

    ``say`` hears which, and its CPUs, once the session has started.

    Raises:
        DependencyNotInstalled: Ray is not installed (when the session starts).
        InvalidInputError: Fewer than zero workers.
    """
    from azgym.bench.run.ray_backend import RayRun
    from azgym.bench.run.ray_session import ray_session

    return RayRun, ray_session(address, whole_number("workers", workers, minimum=0), say)


BACKENDS: Registry[Backend] = Registry("backend", {"local": open_local, "ray": open_ray})
"""The backends by name (``run_contenders(backend=...)``, ``--backend``)."""
