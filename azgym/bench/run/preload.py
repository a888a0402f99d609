"""What the workers' fork server loads before it forks any worker.

Importing this module (the fork server does, once) imports the worker and runs the built-in
contenders the run that started the server named
(:func:`~azgym.bench.run.processes.start_fork_server`; by default the bench's default contenders
and the ``repair`` mapper's tracker) through the warm-up route
(:func:`~azgym.bench.run.contenders.warm_up`), which loads their compiled code, or compiles it
on a machine's first run. Every worker forked afterwards starts with that code in memory
instead of loading it again, so starting one costs milliseconds. A plug-in is never loaded
here, whatever the list says (:func:`~azgym.bench.run.contenders.warm_up` skips it): its code
runs in its own workers only. Nothing of a benchmark run is here: the server starts from a fresh
interpreter, not from the process that runs the benchmark. It lets go of the runner's standard
streams (a worker could otherwise open the runner's output through ``/proc/SERVER/fd/1``) and
turns non-dumpable, as its workers then are (:func:`~azgym.bench.run.worker.hide_process`).
"""

from __future__ import annotations

import os

from azgym.bench.run import worker
from azgym.bench.run.contenders import contenders_named, warm_up
from azgym.bench.run.processes import WARM_UP

__all__: list[str] = []  # imported for what importing does, not for a name

worker.quiet_streams()
worker.hide_process()
warm_up(contenders_named(os.environ.pop(WARM_UP, None)))  # popped: the workers do not inherit it
