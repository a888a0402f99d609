"""What --backend ray costs against the process pool, on the bench's default run.

    python baselines/ray_overhead.py [--workers N] [--rounds 2]

The default run is what ``azgym bench`` runs with no arguments: warehouse-static, quick, the
default contenders. Both backends run it in the same process, one after the other, ``--rounds``
times each (the best round is kept: shared machines drift), with the same number of workers.
Ray's start-up (``ray.init`` of a local instance) and shut-down are timed apart from the run;
the run's figures are checked to be identical. Needs ``pip install "azgym[ray]"``.
"""

from __future__ import annotations

import argparse
import logging
import time

import numpy as np

from azgym.bench.run.processes import default_workers
from azgym.bench.run.runner import run_benchmark
from azgym.bench.suites import get_suite


def timed(run) -> tuple[float, object]:
    begun = time.perf_counter()
    result = run()
    return time.perf_counter() - begun, result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=default_workers())
    parser.add_argument("--rounds", type=int, default=2)
    args = parser.parse_args()
    import ray

    suite = get_suite("warehouse-static")

    def bench(backend: str):
        return lambda: run_benchmark(suite, quick=True, workers=args.workers, backend=backend)

    run_benchmark(suite, quick=True, workers=args.workers)  # compiles or loads the kernels once
    pool = [timed(bench("local")) for _ in range(args.rounds)]
    started, _ = timed(lambda: ray.init(address="local", num_cpus=args.workers,
                                        include_dashboard=False,
                                        logging_level=logging.ERROR))
    remote = [timed(bench("ray")) for _ in range(args.rounds)]
    stopped, _ = timed(ray.shutdown)
    best_pool, best_ray = min(t for t, _ in pool), min(t for t, _ in remote)
    same = all(np.array_equal(pool[0][1].outcomes[k].position, remote[0][1].outcomes[k].position,
                              equal_nan=True) for k in pool[0][1].outcomes)
    frames = pool[0][1].summary["n_frames"]
    print(f"default run: {suite.name} quick, {frames} frames, "
          f"{len(pool[0][1].outcomes)} contenders, {args.workers} workers, best of {args.rounds}")
    print(f"process pool          {best_pool:6.2f} s")
    print(f"ray, run              {best_ray:6.2f} s   ({best_ray / best_pool:.1f}x the pool)")
    print(f"ray, start-up         {started:6.2f} s   (ray.init of a local instance)")
    print(f"ray, shut-down        {stopped:6.2f} s")
    print(f"ray, all told         {started + best_ray + stopped:6.2f} s   "
          f"({(started + best_ray + stopped) / best_pool:.1f}x the pool)")
    print(f"figures identical: {same}")


if __name__ == "__main__":
    main()
