"""Truth sampled on its own clock put onto the camera's frames: interpolated, never extrapolated.

A motion-capture system, a total station or a ROS topic gives the true pose at its own times;
a log holds it on each frame (docs/logs.md). :func:`truth_at` takes it to the frames' times:
a frame at a sample's very time gets that sample bit for bit, any other frame the pose
between the samples around it, linear in position and along the shorter arc in heading
(:func:`azgym.core.interpolate_pose`). A frame before the first sample or after the last, or
between two samples further apart than ``max_gap`` (default :data:`MAX_GAP`), is refused:
its truth would be invented.
"""

from __future__ import annotations

import numpy as np

from azgym.arguments import positive_number
from azgym.core import interpolate_pose
from azgym.errors import InvalidInputError
from azgym.logs.problems import seconds

__all__ = ["MAX_GAP", "covered", "truth_at"]

MAX_GAP = 0.5
"""The longest time between two truth samples a frame's truth is interpolated across [s]:
a vehicle at 2 m/s turning at 1 rad/s strays about 6 cm from the chord over half a second."""


def covered(frame_times: np.ndarray, stamps: np.ndarray) -> np.ndarray:
    """Whether each frame lies within the samples' span (from the first sample to the last).

    Args:
        frame_times: The frames' times [s].
        stamps: The samples' times [s], increasing.
    """
    frame_times = np.asarray(frame_times, dtype=np.float64)
    return (frame_times >= stamps[0]) & (frame_times <= stamps[-1])


def truth_at(frame_times: np.ndarray, stamps: np.ndarray, x: np.ndarray, y: np.ndarray,
             heading: np.ndarray | None, *, source: str, max_gap: float = MAX_GAP,
             numbers: np.ndarray | None = None
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """The true pose at each frame's time, from samples at their own times.

    Args:
        frame_times: The frames' times [s], on the samples' clock.
        stamps: The samples' times [s], strictly increasing.
        x: The samples' x [m].
        y: The samples' y [m].
        heading: The samples' headings [rad], or None (position-only truth).
        source: Where the samples come from, for messages (``"topic /mocap"``, ``"truth.tum"``).
        max_gap: The longest time between two samples a frame may lie between [s].
        numbers: The frames' numbers, for messages (default: their rows, from 0).

    Returns:
        x, y and heading (None without one) on every frame.

    Raises:
        InvalidInputError: A sample not finite or out of order, or a frame the samples do not
            cover (before the first, after the last, or in a gap longer than ``max_gap``),
            naming ``source`` and the first such sample or frame.
    """
    max_gap = positive_number("max_gap", max_gap, "s")
    frame_times = np.asarray(frame_times, dtype=np.float64)
    stamps = np.asarray(stamps, dtype=np.float64)
    columns = {"x": np.asarray(x, dtype=np.float64), "y": np.asarray(y, dtype=np.float64)}
    if heading is not None:
        columns["heading"] = np.asarray(heading, dtype=np.float64)
    _check_samples(stamps, columns, source)
    numbers = np.arange(frame_times.size) if numbers is None else np.asarray(numbers)
    before = np.searchsorted(stamps, frame_times, side="right") - 1
    exact = (before >= 0) & (stamps[np.maximum(before, 0)] == frame_times)
    _check_covered(frame_times, stamps, before, exact, max_gap, source, numbers)
    xs, ys = columns["x"], columns["y"]
    hs = columns.get("heading", np.zeros(stamps.size))
    rows = np.maximum(before, 0)
    out = [xs[rows].copy(), ys[rows].copy(), hs[rows].copy()]
    for k in np.flatnonzero(~exact):
        i = int(before[k])
        fraction = float((frame_times[k] - stamps[i]) / (stamps[i + 1] - stamps[i]))
        out[0][k], out[1][k], out[2][k] = interpolate_pose(
            (float(xs[i]), float(ys[i]), float(hs[i])),
            (float(xs[i + 1]), float(ys[i + 1]), float(hs[i + 1])), fraction)
    return out[0], out[1], out[2] if heading is not None else None


def _check_samples(stamps: np.ndarray, columns: dict[str, np.ndarray], source: str) -> None:
    """Samples: at least one, as many values as times, all finite, times strictly increasing."""
    if stamps.ndim != 1 or not stamps.size:
        raise InvalidInputError(f"{source}: no truth samples")
    for name, column in {"time": stamps, **columns}.items():
        if column.shape != stamps.shape:
            raise InvalidInputError(f"{source}: {column.size} {name} values for {stamps.size} "
                                    "samples")
        bad = np.flatnonzero(~np.isfinite(column))
        if bad.size:
            raise InvalidInputError(f"{source}: sample {int(bad[0])}: {name} "
                                    f"{column[bad[0]].item()!r} is not finite ({bad.size} such "
                                    "sample(s))")
    back = np.flatnonzero(np.diff(stamps) <= 0)
    if back.size:
        k = int(back[0]) + 1
        raise InvalidInputError(f"{source}: sample {k}: time {seconds(stamps[k])} is not after "
                                f"the sample before's {seconds(stamps[k - 1])} (truth samples' "
                                "times increase strictly)")


def _check_covered(frame_times: np.ndarray, stamps: np.ndarray, before: np.ndarray,
                   exact: np.ndarray, max_gap: float, source: str, numbers: np.ndarray) -> None:
    """Refuse frames outside the samples' span, or between samples more than max_gap apart."""
    outside = ~covered(frame_times, stamps)
    if outside.any():
        k = int(np.flatnonzero(outside)[0])
        raise InvalidInputError(
            f"{source}: frame {numbers[k]} (time {seconds(frame_times[k])}) lies outside the "
            f"truth samples' span ({seconds(stamps[0])} to {seconds(stamps[-1])}); "
            f"{int(outside.sum())} frame(s) do: truth is interpolated, never extrapolated")
    inner = np.flatnonzero(~exact)
    gaps = stamps[before[inner] + 1] - stamps[before[inner]]
    wide = inner[gaps > max_gap]
    if wide.size:
        k, i = int(wide[0]), int(before[wide[0]])
        raise InvalidInputError(
            f"{source}: frame {numbers[k]} (time {seconds(frame_times[k])}) lies in a "
            f"{stamps[i + 1] - stamps[i]:.3f} s gap between truth samples {i} and {i + 1} "
            f"(at most {max_gap!r} s is interpolated across); {wide.size} frame(s) do")
