"""What the workers' fork server loads before it forks any worker.

Importing this module (the fork server does, once) imports the worker and runs every default
built-in, and the ``repair`` mapper's tracker, through the warm-up route
(:func:`~azgym.bench.run.contenders.warm_up`), which loads their compiled code, or compiles it
on a machine's first run. Every worker forked afterwards
starts with that code in memory instead of loading it again, so starting one costs
milliseconds. Nothing of a benchmark run is here: the server starts from a fresh interpreter,
not from the process that runs the benchmark. It lets go of the runner's standard streams (a
worker could otherwise open the runner's output through ``/proc/SERVER/fd/1``) and turns
non-dumpable, as its workers then are (:func:`~azgym.bench.run.worker.hide_process`).
"""

from __future__ import annotations

from azgym.bench.run import worker
from azgym.bench.run.contenders import contender, default_contenders, warm_up

__all__: list[str] = []  # imported for what importing does, not for a name

MAP_REPAIR = "robust:repair=true"
"""The ``repair`` mapper's tracker. Its warm-up also reaches the motion model's kernels that every
built-in mapper steps a drive through (its lag keeps each frame's steps), so that a mapping run's
first case does not compile them inside its time limit."""

worker.quiet_streams()
worker.hide_process()
warm_up([*default_contenders(), contender(MAP_REPAIR)])
