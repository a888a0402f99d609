"""Helpers the tests share: noise-free frames seen from a known pose, small beacon maps, and an
attack run in a child process with bounded memory and time."""

from __future__ import annotations

import hashlib
import json
import subprocess
import sys
import textwrap

import numpy as np

import azgym
from azgym.core import BeaconMap, Measurements, pose_error
from azgym.sensing.synthetic import ideal_azimuths
from azgym.track.repair_fit import SHARED_ERROR_S

__all__ = ["answers_digest", "beacon_map", "bounded_outcome", "dense_likelihood_ratio",
           "edited_json", "ideal_frame", "pose_error_of", "quick_navigation_run"]


def answers_digest(tracker, frames, beacons: BeaconMap) -> str:
    """A reset tracker driven along ``frames``: the SHA-256 of every answer (ok, pose, inliers)."""
    digest = hashlib.sha256()
    for frame in frames:
        tracker.predict(frame.motion)
        estimate = tracker.update(frame.measurements, beacons)
        digest.update(np.array([estimate.ok, *estimate.pose]).tobytes()
                      + estimate.inliers.tobytes())
    return digest.hexdigest()


def ideal_frame(x: float, y: float, heading: float, beacons: BeaconMap) -> Measurements:
    """Every beacon measured once, without error, from the pose (x, y, heading)."""
    azimuth, _ = ideal_azimuths(x, y, heading, beacons)
    return Measurements(beacons.ids, azimuth)


def pose_error_of(estimate: azgym.Estimate, x: float, y: float,
                  heading: float) -> tuple[float, float]:
    """(position error [m], absolute wrapped heading error [rad]) of an estimate."""
    return pose_error(estimate.pose, (x, y, heading))


def beacon_map(xy, width: float = 0.03, first_id: int = 1) -> BeaconMap:
    """A beacon map from horizontal positions, ids counting up from ``first_id``, z = 2.5 m."""
    xy = np.asarray(xy, dtype=float)
    return BeaconMap(np.arange(first_id, first_id + len(xy)), np.c_[xy, np.full(len(xy), 2.5)],
                     width=width)


def quick_navigation_run(out, *localizers: str):
    """A quick dev run of pure pursuit with the localizers, through the command; its file."""
    from azgym import cli

    argv = ["bench", "--suite", "navigation", "--quick", "--navigator", "pure-pursuit"]
    for localizer in localizers:
        argv += ["--localizer", localizer]
    assert cli.main([*argv, "--workers", "1", "--out", str(out)]) == 0
    return out / "navigation.json"


def edited_json(folder, path, edit, name: str = "navigation.json"):
    """A copy of the JSON file ``path`` in ``folder``, its data changed by ``edit`` first."""
    data = json.loads(path.read_text())
    edit(data)
    copy = folder / name
    copy.write_text(json.dumps(data))
    return copy


def bounded_outcome(code: str, *, memory_bytes: int, seconds: float,
                    stdin: int | None = None) -> str:
    """What ``code`` ends in, run in a child process limited to ``memory_bytes`` of address
    space and ``seconds``: the type and message of what it raises, or ``no error``.

    An attack's test runs it so: a regression then fails (a MemoryError, a timeout) instead of
    hanging the tests or exhausting the machine.
    """
    script = "\n".join([
        "import resource",
        f"resource.setrlimit(resource.RLIMIT_AS, ({memory_bytes}, {memory_bytes}))",
        "try:",
        textwrap.indent(textwrap.dedent(code).strip(), "    "),
        "except BaseException as exc:  # the attack's outcome, whatever it is",
        "    print(type(exc).__name__, exc)",
        "else:",
        "    print('no error')"])
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         timeout=seconds, stdin=stdin, check=False)
    assert run.returncode == 0, run.stderr[-2000:]
    return run.stdout.strip()


def dense_likelihood_ratio(times, cameras, bearings, covariance, variances, beacon) -> float:
    """Map repair's fit-test ratio Λ = rᵀ Σ⁻¹ J (Jᵀ Σ⁻¹ J)⁻¹ Jᵀ Σ⁻¹ r, with numpy, Σ as
    ``azgym.track.repair_fit``'s docstring writes it: the reference its kernel is held to."""
    offsets = beacon - cameras
    sensitivity = np.column_stack((-offsets[:, 1], offsets[:, 0])) \
        / (offsets ** 2).sum(axis=1)[:, None]
    shared = np.column_stack((sensitivity, np.ones(len(times))))
    residuals = np.angle(np.exp(1j * (bearings - np.arctan2(offsets[:, 1], offsets[:, 0]))))
    sigma = np.diag(variances) + (shared @ covariance @ shared.T) * np.exp(
        -np.abs(np.subtract.outer(times, times)) / SHARED_ERROR_S)
    inverse = np.linalg.inv(sigma)
    projected = sensitivity.T @ inverse @ residuals
    return float(projected @ np.linalg.solve(sensitivity.T @ inverse @ sensitivity, projected))
