"""The benchmark runner: every contender on every frame of a suite, scored with honest metrics.

A localizer that raises on a frame is scored as unavailable on that frame (the error is kept),
never taking the run down. Frames are drawn once, in this process, and split into chunks for the
worker processes, so the figures do not depend on ``workers``. Runtimes are measured per call,
and reported beside ``ransac``'s median from the same run, so runs on different machines compare.
"""

from __future__ import annotations

import csv
import importlib.util
import json
import math
import secrets
import sys
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from azgym.bench.suites import CAUSES, Frame, Suite
from azgym.core import wrap_angle
from azgym.errors import InvalidInputError
from azgym.localize.registry import make_localizer
from azgym.metrics import summarize_errors
from azgym.scenario import load_scenario

REFERENCE = "ransac"


@dataclass(frozen=True)
class Contender:
    """A localizer as the benchmark runs it.

    Attributes:
        label: Its name in reports.
        spec: A registered name, ``package.module:Class`` or ``path/file.py:Class``.
        params: Hyperparameters for ``make_localizer``.
    """

    label: str
    spec: str
    params: dict[str, Any] = field(default_factory=dict)


def default_contenders() -> list[Contender]:
    """The built-in localizers; mex runs coarse-to-fine (10 cm, then the 1 cm lattice)."""
    return [Contender("ransac", "ransac"), Contender("ransac-weighted", "ransac",
                                                     {"weighted": True}),
            Contender("loo", "loo"), Contender("lsq", "lsq"), Contender("triplet", "triplet"),
            Contender("mex", "mex", {"coarse_step": 0.1})]


def _localize_chunk(contender: Contender, frames: list[Frame]) -> dict[str, Any]:
    """Run one contender on some frames (in a worker); never raises for the localizer's sake."""
    count = len(frames)
    result = {"ok": np.zeros(count, dtype=bool), "position": np.full(count, np.nan),
              "heading": np.full(count, np.nan), "micros": np.full(count, np.nan),
              "errors": [""] * count}
    try:
        localizer = make_localizer(contender.spec, **contender.params)
    except Exception as exc:  # noqa: BLE001 - a plug-in that cannot even be built
        result["errors"] = [f"cannot build {contender.spec!r}: {exc}"] * count
        return result
    maps: dict[str, Any] = {}
    for frame in frames[:1]:  # warm-up: numba's first call loads compiled code; keep it untimed
        maps[frame.scenario] = load_scenario(frame.scenario).beacons
        try:
            localizer.localize(frame.measurements, maps[frame.scenario])
        except Exception:  # noqa: BLE001, S110 - the timed loop below records the failure
            pass
    for k, frame in enumerate(frames):
        if frame.scenario not in maps:
            maps[frame.scenario] = load_scenario(frame.scenario).beacons
        try:
            start = time.perf_counter_ns()
            estimate = localizer.localize(frame.measurements, maps[frame.scenario])
            result["micros"][k] = (time.perf_counter_ns() - start) / 1000.0
            ok = bool(estimate.ok) and math.isfinite(estimate.x) and math.isfinite(estimate.y)
        except Exception as exc:  # noqa: BLE001 - a failing plug-in is scored, not fatal
            result["errors"][k] = f"{type(exc).__name__}: {exc}"
            continue
        result["ok"][k] = ok
        if ok:
            x, y, heading = frame.pose
            result["position"][k] = math.hypot(estimate.x - x, estimate.y - y)
            result["heading"][k] = abs(wrap_angle(float(estimate.heading) - heading))
    return result


@dataclass
class BenchResult:
    """A benchmark run: the summary (results.json) and every frame's outcome (frames.csv)."""

    summary: dict[str, Any]
    frames: list[Frame]
    outcomes: dict[str, dict[str, Any]]

    def write(self, out: Path, figures: bool = True) -> list[Path]:
        """Write results.json, frames.csv and, with matplotlib installed, the figures."""
        out.mkdir(parents=True, exist_ok=True)
        summary_path, frames_path = out / "results.json", out / "frames.csv"
        summary_path.write_text(json.dumps(self.summary, indent=1) + "\n", encoding="utf-8")
        with frames_path.open("w", newline="", encoding="utf-8") as handle:
            writer = csv.writer(handle)
            writer.writerow(["localizer", "frame", "scenario", "group", "cause", "ok",
                             "position_error_m", "heading_error_rad", "micros", "error"])
            for label, outcome in self.outcomes.items():
                for k, frame in enumerate(self.frames):
                    writer.writerow([label, k, frame.scenario, frame.group, frame.cause,
                                     int(outcome["ok"][k]), f"{outcome['position'][k]:.17g}",
                                     f"{outcome['heading'][k]:.17g}",
                                     f"{outcome['micros'][k]:.3f}", outcome["errors"][k]])
        written = [summary_path, frames_path]
        if figures and importlib.util.find_spec("matplotlib") is not None:
            from azgym.bench.plots import write_figures

            written += write_figures(self.summary, self.frames, self.outcomes, out)
        return written


def run_benchmark(
    suite: Suite,
    contenders: Sequence[Contender] | None = None,
    *,
    split: str = "dev",
    quick: bool = False,
    workers: int = 1,
    seed: int | None = None,
    progress: Callable[[str], None] | None = None,
) -> BenchResult:
    """Score every contender on the suite's frames.

    Args:
        suite: The suite.
        contenders: The localizers (default: :func:`default_contenders`). ``ransac`` is added as
            the runtime reference if missing.
        split: "dev" (the suite's fixed seed) or "test" (a seed drawn now, and reported).
        quick: Draw the suite's small version.
        workers: Worker processes (1: this process).
        seed: Draw the frames from this seed instead (to rerun a reported test split).
        progress: Called with text as the run advances; text starting with a carriage
            return redraws the current line (a progress bar).
    """
    if split not in ("dev", "test"):
        raise InvalidInputError(f"split must be 'dev' or 'test', got {split!r}")
    contenders = list(contenders or default_contenders())
    if not any(c.spec == REFERENCE and not c.params for c in contenders):
        contenders.append(Contender(REFERENCE, REFERENCE))
    say = progress or (lambda _line: None)
    if seed is None:
        seed = suite.dev_seed if split == "dev" else secrets.randbits(31)
    started = time.perf_counter()
    frames = suite.build(seed, quick)
    say(f"{suite.name} v{suite.version} ({split}, seed {seed}): {len(frames)} frames drawn in "
        f"{time.perf_counter() - started:.1f} s")
    chunk = max(1, math.ceil(len(frames) / max(1, 4 * workers)))
    pieces = [frames[s:s + chunk] for s in range(0, len(frames), chunk)]
    outcomes: dict[str, dict[str, Any]] = {}
    executor = ProcessPoolExecutor(max_workers=workers) if workers > 1 else None
    try:
        for contender in contenders:
            begun = time.perf_counter()
            results = (map(_localize_chunk, [contender] * len(pieces), pieces) if executor is None
                       else executor.map(_localize_chunk, [contender] * len(pieces), pieces))
            parts = []
            for part in results:  # in order, as each chunk completes
                parts.append(part)
                done = len(parts) * 20 // len(pieces)
                say(f"\r  {contender.label:<20} [{'#' * done}{'.' * (20 - done)}] "
                    f"{len(parts)}/{len(pieces)}")
            outcomes[contender.label] = {
                key: (sum((p[key] for p in parts), []) if key == "errors"
                      else np.concatenate([p[key] for p in parts]))
                for key in ("ok", "position", "heading", "micros", "errors")}
            say(f"  {contender.label:<20} {time.perf_counter() - begun:6.1f} s")
    finally:
        if executor is not None:
            executor.shutdown()
    summary = summarize(suite, split, seed, quick, contenders, frames, outcomes)
    return BenchResult(summary, frames, outcomes)


def summarize(suite: Suite, split: str, seed: int, quick: bool,
              contenders: Sequence[Contender], frames: list[Frame],
              outcomes: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """The metrics of every contender, overall, by cause and by group, with runtimes."""
    causes = np.array([f.cause for f in frames])
    groups = np.array([f.group for f in frames])
    reference_label = next(c.label for c in contenders if c.spec == REFERENCE and not c.params)
    reference = float(np.nanmedian(outcomes[reference_label]["micros"]))
    results: dict[str, Any] = {}
    for contender in contenders:
        outcome = outcomes[contender.label]
        micros = outcome["micros"]
        timed = micros[np.isfinite(micros)]

        def stats(mask: np.ndarray, o: dict[str, Any] = outcome) -> dict[str, Any]:
            return summarize_errors(o["position"][mask], o["heading"][mask], o["ok"][mask])

        median_us = float(np.median(timed)) if timed.size else math.nan
        results[contender.label] = {
            "spec": contender.spec, "params": contender.params,
            "all": stats(np.ones(len(frames), dtype=bool)),
            "ci95": confidence_intervals(outcome["position"], outcome["ok"]),
            "by_cause": {c: stats(causes == c) for c in CAUSES if (causes == c).any()},
            "by_group": {g: stats(groups == g) for g in dict.fromkeys(groups)},
            "runtime_us": {"median": median_us,
                           "p99": float(np.percentile(timed, 99)) if timed.size else math.nan,
                           "ratio_to_ransac": median_us / reference},
            "crashes": sum(1 for e in outcome["errors"] if e),
            "first_error": next((e for e in outcome["errors"] if e), ""),
        }
    return {"suite": suite.name, "suite_version": suite.version, "split": split, "seed": seed,
            "quick": quick, "n_frames": len(frames), "azgym_version": _version(),
            "python": sys.version.split()[0], "localizers": results}


def confidence_intervals(position: np.ndarray, ok: np.ndarray, resamples: int = 400,
                         seed: int = 0) -> dict[str, list[float]]:
    """95 % bootstrap intervals of the mean and p75 position error [cm] and the failure rate.

    Frames are resampled with replacement (a missing estimate stays a failure), 50 resamples at
    a time to bound memory; the generator is seeded, so the intervals repeat like the figures.
    """
    count = position.size
    if count == 0:
        return {}
    rng = np.random.default_rng(seed)
    error = np.where(ok, position * 100, np.inf)
    means, p75, failures = [], [], []
    for _ in range(0, resamples, 50):
        samples = error[rng.integers(0, count, size=(50, count))]
        available = np.isfinite(samples)
        means += list(np.where(available, samples, 0.0).sum(axis=1)
                      / np.maximum(available.sum(axis=1), 1))
        p75 += [float(np.percentile(row[np.isfinite(row)], 75)) if np.isfinite(row).any()
                else math.nan for row in samples]
        failures += list(((~available) | (samples > 100.0)).mean(axis=1))

    def interval(values: list[float]) -> list[float]:
        finite = np.asarray(values, dtype=float)
        finite = finite[np.isfinite(finite)]
        if finite.size == 0:  # no estimate at all: no interval either
            return [math.nan, math.nan]
        return [float(np.percentile(finite, 2.5)), float(np.percentile(finite, 97.5))]

    return {"mean_cm": interval(means), "p75_cm": interval(p75),
            "failure_rate": interval(failures)}


def _version() -> str:
    from azgym import __version__

    return __version__


def ranked_table(summary: dict[str, Any]) -> str:
    """The contenders ranked by p75 error (the EvAAL headline), as a text table."""
    rows = sorted(summary["localizers"].items(),
                  key=lambda item: (_nan_last(item[1]["all"]["p75_cm"]),
                                    -item[1]["all"]["availability"]))
    lines = [f"{summary['suite']} v{summary['suite_version']} ({summary['split']}, seed "
             f"{summary['seed']}{', quick' if summary['quick'] else ''}): "
             f"{summary['n_frames']} frames; errors in cm",
             f"{'#':>2} {'localizer':<18} {'avail':>6} {'mean':>8} {'median':>8} {'p75':>8} "
             f"{'p75 95% CI':>15} {'p95':>8} {'fail':>6} {'µs':>9} {'×ransac':>8}"]
    for rank, (label, row) in enumerate(rows, 1):
        a, t = row["all"], row["runtime_us"]
        low, high = row["ci95"].get("p75_cm", [math.nan, math.nan])
        lines.append(f"{rank:>2} {label:<18} {100 * a['availability']:5.1f}% {a['mean_cm']:8.2f} "
                     f"{a['median_cm']:8.2f} {a['p75_cm']:8.2f} {f'{low:.2f}-{high:.2f}':>15} "
                     f"{a['p95_cm']:8.1f} {100 * a['failure_rate']:5.1f}% {t['median']:9.1f} "
                     f"{t['ratio_to_ransac']:8.2f}")
        if row["crashes"]:
            lines.append(f"   ! {row['crashes']} frames raised: {row['first_error']}")
    return "\n".join(lines)


def _nan_last(value: float) -> float:
    return math.inf if value is None or math.isnan(value) else value
