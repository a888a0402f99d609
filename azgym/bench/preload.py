"""What the workers' fork server loads before it forks any worker.

Importing this module (the fork server does, once) imports the worker and runs every built-in
localizer once on a small exact frame (:func:`~azgym.bench.contenders.warm_up`), which loads
their compiled code, or compiles it on a machine's first run. Every worker forked afterwards
starts with that code in memory instead of loading it again, so starting one costs
milliseconds. Nothing of a benchmark run is here: the server starts from a fresh interpreter,
not from the process that runs the benchmark.
"""

from __future__ import annotations

from azgym.bench import worker  # noqa: F401 - imported for the workers that fork from here
from azgym.bench.contenders import default_contenders, warm_up

warm_up(default_contenders())
