"""The trackers' own figures: the cost of a Kalman update, faults, and dead reckoning's drift.

    python baselines/trackers.py [--rounds 5] [--out results/trackers]

Three parts, each printed and written to ``OUT/trackers.json``:

1. **Speed.** Every route of warehouse-small is driven (seed 1, 10 Hz) and replayed through
   each tracker from the true start pose. Timed per frame: the tracker's correction alone (the
   Kalman update: for ``tkf`` and ``lpkf`` the update with the frame's ransac fix, which is
   computed untimed; for ``gated-ekf`` and ``robust`` the gating and update on the raw
   azimuths), the whole frame (``predict`` and ``update``, the fix included), and ransac on the
   same frame. Shared machines drift in speed by up to 2x within seconds, so ``--rounds`` rounds
   are run and for each figure the least disturbed round is reported (the lowest ratio to
   ransac timed in the same round), with that ratio. The frame's motion samples are gathered
   before the clock starts, as the measurements ransac gets are.
2. **Faults.** ``tkf`` against ``gated-ekf`` on the frames with a mirror ghost or a misread id,
   read from the committed leaderboard entries (their per-frame files; ``azgym leaderboard
   verify`` reruns them). A frame without an answer counts as a failure, never as a zero error.
3. **Drift.** ``dead-reckoning`` beside ``robust`` along the field-test route of
   warehouse-paper, five seeds: ``OUT/drift.png``.
"""

from __future__ import annotations

import argparse
import csv
import gzip
import json
import os
import time
from collections.abc import Callable
from pathlib import Path

os.environ.setdefault("NUMBA_NUM_THREADS", "1")

import numpy as np  # noqa: E402

import azgym  # noqa: E402
from azgym.core import pose_error  # noqa: E402
from azgym.world.drive import simulate  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
ENTRIES = ROOT / "leaderboard" / "entries"
TRACKERS = ("tkf", "lpkf", "gated-ekf", "robust")
FRAME_TARGET_RATIO = 2.0
"""tkf's and lpkf's target: a whole frame at most this many times ransac's."""
FRAME_TARGET_US = 30.0
"""gated-ekf's and robust's target: a whole frame within this many µs."""
FAULTS = ("ghost", "misidentified")


def replay_timings(name: str, scenario, routes: list[list]) -> dict[str, np.ndarray]:
    """Per-frame µs of the tracker's correction, its whole frame, and ransac on the frame."""
    tracker = azgym.make_tracker(name)
    ransac = azgym.make_localizer("ransac")
    correction = tracker._correct  # the Kalman update, wrapped to time it alone
    times: dict[str, list[float]] = {"update": [], "frame": [], "ransac": []}

    def timed_correction(*args):
        start = time.perf_counter_ns()
        result = correction(*args)
        times["update"].append(time.perf_counter_ns() - start)
        return result

    tracker._correct = timed_correction
    for frames in routes:
        tracker.reset(seed=0, initial=frames[0].pose)
        for frame in frames[1:]:
            measurements, motion = frame.observation.measurements, frame.motion  # untimed
            start = time.perf_counter_ns()
            ransac.localize(measurements, scenario.beacons)
            middle = time.perf_counter_ns()
            tracker.predict(motion)
            tracker.update(measurements, scenario.beacons)
            times["ransac"].append(middle - start)
            times["frame"].append(time.perf_counter_ns() - middle)
    return {key: np.asarray(value) / 1000.0 for key, value in times.items()}


def speed(rounds: int) -> dict:
    scenario = azgym.load_scenario("warehouse-small")
    routes = [list(simulate(scenario, route.name, 1)) for route in scenario.routes]
    report = {"frames": sum(len(frames) - 1 for frames in routes), "rounds": rounds,
              "trackers": {}}
    for name in TRACKERS:
        replay_timings(name, scenario, routes[:1])  # compile and warm up
        medians = [{k: float(np.median(v)) for k, v in replay_timings(name, scenario,
                                                                    routes).items()}
                   for _ in range(rounds)]
        # For each figure, the round least disturbed: the lowest ratio to ransac in its round.
        update = min(medians, key=lambda m: m["update"] / m["ransac"])
        frame = min(medians, key=lambda m: m["frame"] / m["ransac"])
        report["trackers"][name] = {
            "update_us": update["update"], "frame_us": frame["frame"],
            "ransac_us": frame["ransac"], "update_per_ransac": update["update"] / update["ransac"],
            "frame_per_ransac": frame["frame"] / frame["ransac"]}
    return report


def frame_rows(name: str) -> list[dict[str, str]]:
    with gzip.open(ENTRIES / f"{name}.frames.csv.gz", "rt", newline="") as handle:
        return list(csv.DictReader(handle))


def fault_figures(rows: list[dict[str, str]], keep: Callable[[dict], bool]) -> dict:
    """Failure rate, p50/p95 with failures counted as failed, over the kept frames [cm]."""
    errors = np.array([float(r["position_error_m"]) * 100.0 if r["ok"] == "1" else np.inf
                       for r in rows if keep(r)])
    failed = ~(errors <= 100.0)
    ranked = np.sort(errors)
    return {"frames": int(errors.size), "failure_rate": float(failed.mean()),
            "p50_cm": float(np.quantile(ranked, 0.5, method="inverted_cdf")),
            "p95_cm": float(np.quantile(ranked, 0.95, method="inverted_cdf")),
            "max_answered_cm": float(errors[np.isfinite(errors)].max())}


def faults() -> dict:
    report = {}
    for suite in ("warehouse-routes", "image-routes"):
        tkf, gated = frame_rows(f"tkf-{suite}"), frame_rows(f"gated-ekf-{suite}")
        for cause in FAULTS:
            def keep(row, cause=cause):
                return row["cause"] == cause
            if not any(keep(r) for r in tkf):
                continue
            both = [k for k, (a, b) in enumerate(zip(tkf, gated, strict=True))
                    if keep(a) and a["ok"] == "1" and b["ok"] == "1"]
            report[f"{suite}/{cause}"] = {
                "tkf": fault_figures(tkf, keep), "gated-ekf": fault_figures(gated, keep),
                "both_answered": len(both),
                "both_answered_median_cm": {
                    name: float(np.median([float(rows[k]["position_error_m"]) * 100
                                           for k in both]))
                    for name, rows in (("tkf", tkf), ("gated-ekf", gated))}}
    return report


def drift(out: Path) -> dict:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    scenario = azgym.load_scenario("warehouse-paper")
    figure, axes = plt.subplots(figsize=(7.5, 4.2))
    report = {}
    for seed in range(5):
        frames = list(simulate(scenario, scenario.routes[0].name, seed))
        for name, colour in (("dead-reckoning", "tab:red"), ("robust", "tab:blue")):
            tracker = azgym.make_tracker(name)
            tracker.reset(seed=seed, initial=frames[0].pose)
            errors = []
            for frame in frames[1:]:
                tracker.predict(frame.motion)
                estimate = tracker.update(frame.observation.measurements, scenario.beacons)
                errors.append(pose_error(estimate.pose, frame.pose)[0] * 100.0
                              if estimate.ok else np.nan)
            seconds = [frame.time for frame in frames[1:]]
            axes.plot(seconds, errors, color=colour, lw=1.0, alpha=0.8,
                      label=name if seed == 0 else None)
            report.setdefault(name, []).append({"seed": seed, "final_cm": errors[-1],
                                                "max_cm": float(np.nanmax(errors))})
    axes.set_yscale("log")
    axes.set_xlabel("time along the route [s]")
    axes.set_ylabel("position error [cm]")
    axes.set_title(f"warehouse-paper, route {scenario.routes[0].name}: 5 seeds, from the "
                   "true start pose")
    axes.grid(True, which="both", alpha=0.3)
    axes.legend()
    figure.tight_layout()
    figure.savefig(out / "drift.png", dpi=110)
    plt.close(figure)
    return report


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--out", type=Path, default=Path("results/trackers"))
    args = parser.parse_args()
    args.out.mkdir(parents=True, exist_ok=True)
    report = {"speed": speed(args.rounds), "faults": faults(), "drift": drift(args.out)}
    (args.out / "trackers.json").write_text(json.dumps(report, indent=2) + "\n")

    print(f"Speed on {report['speed']['frames']} frames of warehouse-small (median µs, each "
          "figure's least disturbed round; ransac's is the frame's round)")
    print(f"{'tracker':<11} {'update':>7} {'x ransac':>9} {'frame':>7} {'x ransac':>9} "
          f"{'ransac':>7}   targets: a frame <= {FRAME_TARGET_RATIO:.0f} x ransac (tkf, lpkf), "
          f"<= {FRAME_TARGET_US:.0f} µs (gated-ekf, robust)")
    for name, row in report["speed"]["trackers"].items():
        print(f"{name:<11} {row['update_us']:7.1f} {row['update_per_ransac']:9.2f} "
              f"{row['frame_us']:7.1f} {row['frame_per_ransac']:9.2f} {row['ransac_us']:7.1f}")
    print("\nFrames with faults (committed entries; a frame without an answer is a failure)")
    for key, row in report["faults"].items():
        for name in ("tkf", "gated-ekf"):
            figures = row[name]
            print(f"{key:<30} {name:<10} n={figures['frames']:4d} failed "
                  f"{100 * figures['failure_rate']:5.1f} %  p50 {figures['p50_cm']:6.2f}  "
                  f"p95 {figures['p95_cm']:6.2f} cm  max answered "
                  f"{figures['max_answered_cm']:5.1f} cm  median where both answered "
                  f"{row['both_answered_median_cm'][name]:.2f} cm ({row['both_answered']})")
    print("\nDrift along warehouse-paper (max error over the route, cm, per seed)")
    for name, runs in report["drift"].items():
        print(f"{name:<15} " + "  ".join(f"{run['max_cm']:.1f}" for run in runs))
    print(f"\nwrote {args.out / 'trackers.json'} and {args.out / 'drift.png'}")


if __name__ == "__main__":
    main()
