"""Running contenders: every contender on every case, each in worker processes of its own.

``runner`` the one loop (:func:`~azgym.bench.run.runner.run_benchmark` on a suite,
:func:`~azgym.bench.run.runner.run_log_benchmark` on a log, ``run_contenders`` on any cases);
``contenders`` who runs; ``backends`` the backends by name (the local pool, Ray); ``profiles`` a
profile as the contenders' defaults and the simulator's noise; ``isolation`` (the runner's
side), ``processes`` (starting and stopping workers), ``worker`` (the contender's side), ``wire``
(what crosses the pipe), ``preload`` (what the fork server loads) and ``answers`` (what a
contender answered) the isolated pool; ``ray_backend`` and ``ray_actor`` the same batches on a
Ray cluster; ``outcome`` what each contender got, case by case.
"""
