"""The mapping benchmark: mappers scored on drives whose beacon map is unknown, stale or right.

:mod:`~azgym.bench.mapping.suites` draws the cases (a scenario's route driven under one
perturbation of its map: :mod:`~azgym.bench.mapping.perturb`), :mod:`~azgym.bench.mapping.worker`
runs a mapper in a sealed process of its own, :mod:`~azgym.bench.mapping.benchmark` runs the
suite (:func:`~azgym.bench.mapping.benchmark.run_mapping`) and
:mod:`~azgym.bench.mapping.scoring` scores it.
"""
