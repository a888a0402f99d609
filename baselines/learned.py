"""The learned localizers beside ransac: wrong answers, right answers, hypotheses, runtime.

    python baselines/learned.py [--suite stress --suite warehouse-static ...] [--out FILE]

1. **On the suites** (dev split, full size): every frame goes to ransac, ng-ransac, learned
   and learned's pure regression (``learned:refine_rounds=0``) in turn, each call timed, so the
   runtimes come from the same run and the same machine state.
   Per localizer: frames answered, right (within 1 m) and wrong (further off) answers, p75 of the
   answered frames' errors, the median number of triplets solved and scored (ransac's
   ``n_triplets``; ng-ransac's ``n_hypotheses``: its features' consensus triplets and its guided
   search's), and the median runtime with its ratio to ransac's.
   ng-ransac also runs with its answer test off, to sweep the test's threshold: right and
   wrong answers kept at each (``answer-test.png`` beside the output).
2. **Generalization**: ng-ransac's search and answer test (the shipped weights and threshold) on
   frames of generated warehouses it was trained on and of the held-out ones it never saw
   (``azgym.learn.dataset``; data seed 99, which no training run uses by default). Their
   hypotheses are the guided search's alone, and they are not timed.
"""

from __future__ import annotations

import argparse
import json
import os
import time
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import azgym  # noqa: E402
from azgym.bench.suites import SUITES  # noqa: E402
from azgym.core import pose_error  # noqa: E402
from azgym.learn.calibrate import RIGHT_M, guided_runs  # noqa: E402
from azgym.learn.dataset import HELD_OUT_LAYOUTS, TRAIN_LAYOUTS, make_frames  # noqa: E402
from azgym.localize.learned import NG_RANSAC_WEIGHTS, InlierScorer  # noqa: E402
from azgym.site import load_scenario  # noqa: E402

CONTENDERS = ("ransac", "ng-ransac", "learned", "learned:refine_rounds=0")
DEFAULT_SUITES = ("stress", "warehouse-static", "paper")
GENERALIZATION_SEED = 99


def on_suite(name: str) -> dict:
    suite = SUITES[name]
    cases = suite.build(suite.dev_seed, False)
    localizers = {label: azgym.make_localizer(label) for label in CONTENDERS}
    untested = azgym.make_localizer("ng-ransac", min_support_weight=0.0)
    weights, errors = [], []
    maps: dict[str, azgym.BeaconMap] = {}
    rows = {label: {"error": [], "micros": [], "hypotheses": []} for label in CONTENDERS}
    for case in cases:
        beacons = maps.setdefault(case.scenario, load_scenario(case.scenario).beacons)
        for label, localizer in localizers.items():
            start = time.perf_counter_ns()
            estimate = localizer.localize(case.measurements, beacons)
            rows[label]["micros"].append((time.perf_counter_ns() - start) / 1000.0)
            rows[label]["error"].append(pose_error(estimate.pose, case.pose)[0]
                                        if estimate.ok else np.inf)
            diagnostics = estimate.diagnostics
            rows[label]["hypotheses"].append(diagnostics.get(
                "n_hypotheses", diagnostics.get("n_triplets", np.nan)))
        estimate = untested.localize(case.measurements, beacons)
        weights.append(estimate.diagnostics.get("support_weight", 0.0))
        errors.append(pose_error(estimate.pose, case.pose)[0] if estimate.ok else np.inf)
    reference = float(np.median(rows["ransac"]["micros"]))
    result = {label: figures(row, reference) for label, row in rows.items()}
    result["answer_test"] = tradeoff(np.asarray(weights), np.asarray(errors))
    return result


def tradeoff(weights: np.ndarray, errors: np.ndarray) -> dict:
    """Right and wrong answers kept at each support threshold (the answer test swept)."""
    thresholds = np.round(np.arange(0.0, 4.01, 0.25), 2)
    answered = np.isfinite(errors)
    return {"thresholds": thresholds.tolist(),
            "right": [int(((errors <= RIGHT_M) & (weights >= t)).sum()) for t in thresholds],
            "wrong": [int((answered & (errors > RIGHT_M) & (weights >= t)).sum())
                      for t in thresholds]}


def tradeoff_figure(report: dict, path: Path) -> None:
    """Per suite, wrong against right answers as the threshold moves; ransac as a point."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    suites = list(report["suites"])
    figure, axes = plt.subplots(1, len(suites), figsize=(4.2 * len(suites), 3.6))
    threshold = report["generalization"]["min_support_weight"]
    for axis, suite in zip(np.atleast_1d(axes), suites, strict=True):
        by = report["suites"][suite]
        sweep = by["answer_test"]
        frames = by["ransac"]["frames"]
        axis.plot(np.array(sweep["right"]) / frames * 100, np.array(sweep["wrong"]) / frames * 100,
                  "o-", ms=3, label="ng-ransac, threshold 0 to 4")
        axis.plot(by["ng-ransac"]["right"] / frames * 100, by["ng-ransac"]["wrong_rate"] * 100,
                  "s", ms=8, label=f"shipped threshold {threshold:.2f}")
        axis.plot(by["ransac"]["right"] / frames * 100, by["ransac"]["wrong_rate"] * 100, "k*",
                  ms=11, label="ransac")
        axis.set_title(suite)
        axis.set_xlabel("right answers [% of frames]")
        axis.set_ylabel("wrong answers [% of frames]")
        axis.grid(True, alpha=0.3)
    np.atleast_1d(axes)[0].legend(fontsize=8)
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)


def figures(row: dict, reference_us: float) -> dict:
    error = np.asarray(row["error"])
    answered = np.isfinite(error)
    micros = float(np.median(row["micros"]))
    return {
        "frames": int(error.size), "answered": int(answered.sum()),
        "right": int((error <= RIGHT_M).sum()), "wrong": int((answered & (error > RIGHT_M)).sum()),
        "wrong_rate": float((answered & (error > RIGHT_M)).mean()),
        "p75_cm": float(np.percentile(error[answered], 75) * 100.0) if answered.any() else None,
        "hypotheses_median": float(np.nanmedian(row["hypotheses"])),
        "median_us": micros, "ratio_to_ransac": micros / reference_us}


def generalization() -> dict:
    scorer = InlierScorer.load(NG_RANSAC_WEIGHTS)
    threshold = scorer.manifest["calibration"]["min_support_weight"]
    result = {"min_support_weight": threshold, "data_seed": GENERALIZATION_SEED}
    for label, layouts in (("training layouts", list(TRAIN_LAYOUTS[:20])),
                           ("held-out layouts", list(HELD_OUT_LAYOUTS))):
        runs = guided_runs(make_frames(layouts, 100, GENERALIZATION_SEED), scorer)
        kept = runs.answered & (runs.support_weight >= threshold)
        error = np.where(kept, runs.error, np.inf)
        result[label] = figures({"error": error, "micros": [np.nan],
                                 "hypotheses": runs.hypotheses}, np.nan)
    return result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--suite", action="append", choices=sorted(SUITES))
    parser.add_argument("--out", type=Path, default=Path("results/learned.json"))
    args = parser.parse_args()
    report = {"suites": {name: on_suite(name) for name in args.suite or DEFAULT_SUITES},
              "generalization": generalization()}
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(report, indent=2) + "\n")
    tradeoff_figure(report, args.out.with_name("answer-test.png"))
    header = (f"{'':28} {'answered':>9} {'right':>6} {'wrong':>6} {'wrong %':>8} {'p75 cm':>7} "
              f"{'hyp.':>5} {'µs':>6} {'×ransac':>8}")
    print(header)
    rows = [(f"{suite} {label}", row) for suite, by in report["suites"].items()
            for label, row in by.items() if label in CONTENDERS]
    rows += [(f"generated, {label}", row) for label, row in report["generalization"].items()
             if isinstance(row, dict)]
    for title, row in rows:
        print(f"{title:28} {row['answered']:9d} {row['right']:6d} {row['wrong']:6d} "
              f"{100 * row['wrong_rate']:8.2f} {row['p75_cm'] or float('nan'):7.2f} "
              f"{row['hypotheses_median']:5.0f} {row['median_us']:6.1f} "
              f"{row['ratio_to_ransac']:8.2f}")
    print(f"wrote {args.out} and {args.out.with_name('answer-test.png')}")


if __name__ == "__main__":
    main()
