"""What feeding a route one frame at a time costs, against the batch path, on the route suites.

    python baselines/causal_cost.py [--workers 2] [--rounds 3] [--backend local|ray]
                                    [--out results/causal_cost.json]

A worker gets a route's frames one at a time, the next only once it has answered this one (a
tracker cannot see its route's future). The batch path sent a whole route in one message. For
each route suite (dev seed, full size) and each contender its leaderboard has (the six default
localizers, ng-ransac, learned and the five trackers), ``run_contenders`` is timed on the
suite's cases both ways, in the same process, ``--rounds`` times, alternating which goes first:

- **causal**: as azgym runs it;
- **batch**: the same run, with the runner's one step rule (``_step_end``) replaced by "the
  whole batch at once", which is the batch path: the worker answers a route from one message.

What is timed is the wall-clock time of ``run_contenders``: starting the workers, sending the
frames, answering, collecting. Each contender's time is its least disturbed round (the
minimum: shared machines drift); a suite's ratio is its contenders' causal total over their
batch total. The per-frame answers of both paths are checked to be identical. With ``--backend
ray`` the same on Ray actors of a local Ray instance started once (an actor relays each frame to
its worker process; the batch path relays the whole batch at once).
"""

from __future__ import annotations

import argparse
import json
import logging
import time
from pathlib import Path

import numpy as np

from azgym.bench.run import runner
from azgym.bench.run.contenders import DEFAULT_SPECS, contender
from azgym.bench.run.isolation import IsolatedRun
from azgym.bench.suites import get_suite

SUITES = ("warehouse-routes", "image-routes", "route-events")
SPECS = (*DEFAULT_SPECS, "ng-ransac", "learned", "dead-reckoning", "tkf", "lpkf", "gated-ekf",
         "robust")


class BatchedRun(IsolatedRun):
    """The process pool's batch path: a batch (a whole route) in one step."""

    def _step_end(self, first: int, stop: int) -> int:
        return stop


def batched_ray_run() -> type:
    """The Ray backend's batch path: a batch relayed to the actor's worker in one step."""
    from azgym.bench.run.ray_backend import RayRun

    class BatchedRayRun(RayRun):
        def _step_end(self, first: int, stop: int) -> int:
            return stop

    return BatchedRayRun


def timed_run(cases, candidate, workers: int, backend: str, batched: bool):
    """(seconds, outcome) of one contender on the cases, by the causal or the batch path."""
    if backend == "ray":
        from azgym.bench.run import ray_backend

        original, name, module = ray_backend.RayRun, "RayRun", ray_backend
        replacement = batched_ray_run()
    else:
        original, name, module = runner.IsolatedRun, "IsolatedRun", runner
        replacement = BatchedRun
    if batched:
        setattr(module, name, replacement)
    try:
        begun = time.perf_counter()
        outcome = runner.run_contenders(cases, [candidate], workers=workers, backend=backend)
        return time.perf_counter() - begun, outcome[candidate.label]
    finally:
        setattr(module, name, original)


def same(a, b) -> bool:
    return (a.errors == b.errors and np.array_equal(a.position, b.position, equal_nan=True)
            and np.array_equal(a.heading, b.heading, equal_nan=True))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--backend", choices=("local", "ray"), default="local")
    parser.add_argument("--out", default="results/causal_cost.json")
    args = parser.parse_args()
    if args.backend == "ray":
        import ray

        ray.init(num_cpus=args.workers, include_dashboard=False, logging_level=logging.ERROR)
    report: dict[str, dict] = {}
    candidates = [contender(spec) for spec in SPECS]
    for name in SUITES:
        suite = get_suite(name)
        cases = suite.build(suite.dev_seed, False)
        best: dict[str, dict[str, float]] = {c.label: {} for c in candidates}
        timed_run(cases[:50], candidates[0], args.workers, args.backend, False)  # warm start
        for round_ in range(args.rounds):
            for candidate in candidates:
                order = (False, True) if round_ % 2 == 0 else (True, False)
                outcomes = {}
                for batched in order:
                    seconds, outcomes[batched] = timed_run(cases, candidate, args.workers,
                                                           args.backend, batched)
                    path = "batch" if batched else "causal"
                    best[candidate.label][path] = min(best[candidate.label].get(path, np.inf),
                                                      seconds)
                if not same(outcomes[False], outcomes[True]):
                    raise SystemExit(f"{name} {candidate.label}: the paths' answers differ")
        causal = sum(times["causal"] for times in best.values())
        batch = sum(times["batch"] for times in best.values())
        report[name] = {"frames": len(cases), "causal_s": causal, "batch_s": batch,
                        "ratio": causal / batch, "contenders": best}
        print(f"{name} ({len(cases)} frames, {len(candidates)} contenders, {args.backend}, "
              f"{args.workers} workers): causal {causal:.3f} s, batch {batch:.3f} s, "
              f"ratio {causal / batch:.3f}")
        for label, times in best.items():
            print(f"  {label:<16} causal {times['causal']:.3f} s  batch {times['batch']:.3f} s"
                  f"  ratio {times['causal'] / times['batch']:.3f}")
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(report, indent=1) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
