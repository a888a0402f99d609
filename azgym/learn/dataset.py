"""Training frames for learned localizers: generated warehouses seen from random free poses.

Each layout is a generated warehouse (:func:`azgym.site.generate` of a generator seed). Its
frames are what the physical :class:`~azgym.sensing.geometry.sensor.GeometrySensor` sees from
random free poses (:func:`~azgym.site.sampling.random_free_pose`) at a fault level drawn per
frame, uniformly: clean (no mirrors, misreads or moved beacons), as generated, or heavy (mirrors
× 2.5 and 5 % misreads: :func:`~azgym.bench.suites.warehouse.fault_levels`, the levels of
warehouse-static, heavy being stress's). On a share of the frames (``outlier_share``) the
paper's outlier injection (Sec. 3.1, :func:`~azgym.sensing.synthetic.inject_outliers`) then
corrupts K = 1-5 azimuths, K uniform, as the paper suite's K = 1, 3, 5; the frame is listed by
azimuth again afterwards, as a detector lists it. Frames with fewer than three distinct usable
beacons, which every localizer refuses, are drawn again.

A measurement is an inlier when it is a direct or partly covered view (DIRECT, PARTIAL) of the
beacon its id names, not corrupted by the injection. A moved beacon's view (MOVED) is not: it is
the right beacon, but the map puts it 1-2.5 m from where the camera sees it, a few degrees off
at the usual distances, and a pose fitted to it is off by as much. Ghosts and misreads are not
either.

Measured (200 training layouts × 50 frames, ``outlier_share`` 0.25): about 7,500 frames/s on
one core; of the usable measurements 84 % are inliers, 7.2 % ghosts, 2.1 % misreads, 1.0 %
moved views and 5.7 % injected; 5-50-95 % of the frames have 4, 12 and 24 usable measurements
(warehouse-static's frames 3, 6-8 and 9-13; stress's 3, 12 and 22).

Every layout draws from its own stream, ``default_rng([seed, layout_seed])``, so the same
arguments give the same arrays bit for bit, and adding layouts leaves the others' frames alone.
"""

from __future__ import annotations

import io
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass, fields
from pathlib import Path

import numpy as np

from azgym.arguments import whole_number
from azgym.bench.suites.warehouse import fault_levels
from azgym.core import BeaconMap, BoolArray, IntArray, Measurements, Pose
from azgym.errors import InvalidInputError, ScenarioError
from azgym.files import write_file
from azgym.localize.base import FLOAT_ROWS, MIN_MEASUREMENTS, Problem
from azgym.localize.learned.features import (
    FEATURE_LAYOUT,
    N_FEATURES,
    first_quality_column,
    measurement_features,
)
from azgym.progress import Progress, counter
from azgym.sensing.geometry.sensor import GeometrySensor
from azgym.sensing.labels import DIRECT, PARTIAL
from azgym.sensing.protocol import Observation
from azgym.sensing.synthetic import inject_outliers
from azgym.site import generate
from azgym.site.sampling import random_free_pose

__all__ = ["FRAMES_FORMAT", "FrameBatch", "HELD_OUT_LAYOUTS", "LEVELS", "TRAIN_LAYOUTS",
           "TrainingFrame", "inlier_truth", "layout_frames", "layout_seeds", "make_frames",
           "observed_frame"]

TRAIN_LAYOUTS = range(0, 100_000)
"""The generator seeds trained on."""
HELD_OUT_LAYOUTS = tuple(range(1_000_000, 1_000_020))
"""Twenty generator seeds never trained on (far from ``TRAIN_LAYOUTS``): the held-out split."""
LEVELS = ("clean", "as generated", "heavy")
"""The fault levels, in the order of :attr:`FrameBatch.level`'s codes."""
MAX_OUTLIERS = 5
"""The largest K injected (the paper suite's largest)."""
DEFAULT_OUTLIER_SHARE = 0.25
"""Share of frames with injected outliers, unless told otherwise."""
DRAWS_PER_FRAME = 50
"""Poses drawn per frame wanted before a layout is given up (its frames see < 3 beacons)."""
FRAMES_FORMAT = "azgym-frames-1"
"""The format of a saved :class:`FrameBatch`; bumped whenever its arrays change."""


@dataclass(frozen=True, eq=False)
class FrameBatch:
    """N frames, each padded to M_max measurements (the usable ones of its :class:`Problem`).

    Attributes:
        features: (N, M_max, N_FEATURES) float32, :func:`measurement_features`, 0 padded.
        floats: (N, FLOAT_ROWS, M_max) float64, each frame's ``Problem.floats``, 0 padded.
        beacon_index: (N, M_max) int64, ``Problem.ints[ROW_BEACON_INDEX]``, −1 padded.
        mask: (N, M_max) bool, a real (usable) measurement.
        inlier: (N, M_max) bool, truth: a direct or partly covered view of the right beacon at
            its mapped position, not injected.
        pose: (N, 3) float64, the true camera pose (x, y, heading).
        layout: (N,) int64, the generator seed of the frame's warehouse.
        label: (N, M_max) int64, the sensor's label of each (:mod:`azgym.sensing.labels`), −1
            padded; an injected measurement keeps the label of what it was before.
        injected: (N, M_max) bool, corrupted by the outlier injection.
        level: (N,) int64, the fault level (index into ``LEVELS``).
        outliers: (N,) int64, K injected in the frame (0: none).
        quality: (N, M_max) float64, the first quality column of each measurement, 0 padded:
            with ``floats`` and ``beacon_index``, what the features are computed from.
    """

    features: np.ndarray
    floats: np.ndarray
    beacon_index: np.ndarray
    mask: np.ndarray
    inlier: np.ndarray
    pose: np.ndarray
    layout: np.ndarray
    label: np.ndarray
    injected: np.ndarray
    level: np.ndarray
    outliers: np.ndarray
    quality: np.ndarray

    def __len__(self) -> int:
        return int(self.layout.size)

    def save(self, path: Path | str) -> Path:
        """Write the batch to ``path`` (.npz, with its format and feature layout), atomically."""
        buffer = io.BytesIO()
        np.savez_compressed(buffer, format=np.array(FRAMES_FORMAT),
                            feature_layout=np.array(FEATURE_LAYOUT),
                            **{f.name: getattr(self, f.name) for f in fields(self)})
        return write_file(Path(path), buffer.getvalue())

    @classmethod
    def load(cls, path: Path | str) -> FrameBatch:
        """Read a batch :meth:`save` wrote.

        Raises:
            InvalidInputError: The file is missing or not an npz, of another format or feature
                layout, or its arrays are missing or of the wrong shape or type; the message
                names the file.
        """
        path = Path(path)
        arrays = _read_npz(path)
        for name in ("format", "feature_layout"):
            value = arrays.get(name)
            if value is None or value.shape != () or value.dtype.kind != "U":
                raise InvalidInputError(f"{path}: not a frame batch (no {name} entry)")
        if str(arrays["format"]) != FRAMES_FORMAT:
            raise InvalidInputError(f"{path}: frame format {str(arrays['format'])!r}, this azgym "
                                    f"reads {FRAMES_FORMAT!r}")
        if str(arrays["feature_layout"]) != FEATURE_LAYOUT:
            raise InvalidInputError(
                f"{path}: features of layout {str(arrays['feature_layout'])!r}, this azgym "
                f"computes {FEATURE_LAYOUT!r}; draw the frames again")
        batch = cls(**{f.name: _entry(path, arrays, f.name) for f in fields(cls)})
        _check_shapes(path, batch)
        return batch


_DTYPES = {"features": np.float32, "floats": np.float64, "beacon_index": np.int64,
           "mask": np.bool_, "inlier": np.bool_, "pose": np.float64, "layout": np.int64,
           "label": np.int64, "injected": np.bool_, "level": np.int64, "outliers": np.int64,
           "quality": np.float64}
"""The dtype of each array of a :class:`FrameBatch`."""


def _read_npz(path: Path) -> dict[str, np.ndarray]:
    """Every array of an npz file, read without pickles; a bad file is named."""
    if not path.is_file():
        raise InvalidInputError(f"{path}: no such file")
    try:
        with np.load(path, allow_pickle=False) as archive:
            return {name: archive[name] for name in archive.files}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise InvalidInputError(f"{path}: not a readable .npz file ({exc})") from None


def _entry(path: Path, arrays: dict[str, np.ndarray], name: str) -> np.ndarray:
    """One array of the batch, of its dtype."""
    if name not in arrays:
        raise InvalidInputError(f"{path}: the frame batch has no {name!r} array")
    array = arrays[name]
    if array.dtype != _DTYPES[name]:
        raise InvalidInputError(f"{path}: {name} must be {np.dtype(_DTYPES[name])}, got "
                                f"{array.dtype}")
    return array


def _check_shapes(path: Path, batch: FrameBatch) -> None:
    """Every array of the batch agrees on N and M_max, and the features on N_FEATURES."""
    n, m = batch.mask.shape if batch.mask.ndim == 2 else (-1, -1)
    expected = {"features": (n, m, N_FEATURES), "floats": (n, FLOAT_ROWS, m),
                "beacon_index": (n, m), "mask": (n, m), "inlier": (n, m), "pose": (n, 3),
                "layout": (n,), "label": (n, m), "injected": (n, m), "level": (n,),
                "outliers": (n,), "quality": (n, m)}
    for name, shape in expected.items():
        if getattr(batch, name).shape != shape:
            raise InvalidInputError(f"{path}: {name} has shape {getattr(batch, name).shape}, "
                                    f"expected {shape}")


@dataclass(frozen=True, eq=False)
class TrainingFrame:
    """One frame before padding: its usable measurements, their features and their truth.

    Attributes:
        problem: The usable measurements (listed by azimuth).
        quality: (K,) their first quality column.
        features: (K, N_FEATURES) float64.
        label: (K,) the sensor's label of each.
        injected: (K,) corrupted by the outlier injection.
        pose: The true camera pose.
        level: The fault level (index into ``LEVELS``).
        outliers: K injected.
    """

    problem: Problem
    quality: np.ndarray
    features: np.ndarray
    label: np.ndarray
    injected: np.ndarray
    pose: tuple[float, float, float]
    level: int
    outliers: int

    @property
    def inlier(self) -> BoolArray:
        """(K,) the truth the model learns (:func:`inlier_truth`)."""
        return inlier_truth(self.label, self.injected)


def inlier_truth(label: IntArray, injected: BoolArray) -> BoolArray:
    """Which measurements are inliers: a direct or partly covered view, not injected.

    A ghost (its mirror direction), a misread (another beacon's position) and a moved beacon's
    view (seen where it is, not where the map puts it) disagree with the map; so does an
    injected azimuth, whatever its label was. Padding (label −1) is no inlier.
    """
    label = np.asarray(label)
    return ((label == DIRECT) | (label == PARTIAL)) & ~np.asarray(injected, dtype=bool)


def layout_seeds(layouts: int | Sequence[int]) -> list[int]:
    """The generator seeds to train on, never a held-out one.

    Args:
        layouts: How many of :data:`~azgym.learn.dataset.TRAIN_LAYOUTS` (the first ones), or
            the seeds themselves.
    """
    if isinstance(layouts, int):
        whole_number("layouts", layouts)
        if layouts > len(TRAIN_LAYOUTS):
            raise InvalidInputError(f"layouts must be at most {len(TRAIN_LAYOUTS)} (the "
                                    f"training layouts there are), got {layouts}")
        return [int(x) for x in list(TRAIN_LAYOUTS)[:layouts]]
    overlap = set(layouts) & set(HELD_OUT_LAYOUTS)
    if overlap:
        raise InvalidInputError(f"layouts: {sorted(overlap)} are held-out layouts")
    return [int(x) for x in layouts]


def make_frames(layout_seeds: Sequence[int], frames_per_layout: int, seed: int, *,
                outlier_share: float = DEFAULT_OUTLIER_SHARE,
                progress: Progress | None = None) -> FrameBatch:
    """``frames_per_layout`` frames of each generated layout, padded into one batch.

    Args:
        layout_seeds: Generator seeds of the warehouses (e.g. ``TRAIN_LAYOUTS[:200]``).
        frames_per_layout: Frames drawn in each.
        seed: Seed of every draw (with each layout's seed, its stream).
        outlier_share: Share of frames, in [0, 1], given K = 1-5 injected outliers.
        progress: Hears the count of layouts drawn.

    Raises:
        InvalidInputError: A bad argument, named.
        ScenarioError: A layout whose random poses almost never see three beacons.
    """
    layouts = _layout_seeds(layout_seeds)
    count = whole_number("frames_per_layout", frames_per_layout)
    seed = whole_number("seed", seed, minimum=0)
    if isinstance(outlier_share, bool) or not isinstance(outlier_share, (int, float)) or not (
            0.0 <= outlier_share <= 1.0):
        raise InvalidInputError(f"outlier_share must be a number in [0, 1], got "
                                f"{outlier_share!r}")
    frames, owners = [], []
    with counter(progress, "drawing frames", len(layouts), "layouts") as counted:
        for done, layout in enumerate(layouts, 1):
            drawn = layout_frames(layout, count, seed, float(outlier_share))
            frames += drawn
            owners += [layout] * len(drawn)
            counted(done)
    return _pack(frames, owners)


def _layout_seeds(layout_seeds: Sequence[int]) -> list[int]:
    """The layout seeds as ints >= 0; at least one."""
    if isinstance(layout_seeds, (str, bytes)) or not isinstance(layout_seeds,
                                                                 (Sequence, np.ndarray)):
        raise InvalidInputError(f"layout_seeds must be a sequence of integers >= 0, got "
                                f"{layout_seeds!r}")
    if len(layout_seeds) == 0:
        raise InvalidInputError("layout_seeds must hold at least one generator seed, got none")
    return [whole_number("layout_seeds entry", value, minimum=0) for value in layout_seeds]


def layout_frames(layout_seed: int, count: int, seed: int,
                  outlier_share: float) -> list[TrainingFrame]:
    """``count`` frames of one generated layout, from its own stream of ``seed``."""
    scenario = generate(layout_seed)
    levels = [(scenario_at, GeometrySensor(scenario_at))
              for scenario_at in fault_levels(scenario).values()]
    rng = np.random.default_rng([seed, layout_seed])
    frames: list[TrainingFrame] = []
    for _ in range(count * DRAWS_PER_FRAME):
        frame = _draw_frame(levels, scenario.beacons, rng, outlier_share)
        if frame is not None:
            frames.append(frame)
            if len(frames) == count:
                return frames
    raise ScenarioError(f"generated layout {layout_seed}: fewer than {MIN_MEASUREMENTS} beacons "
                        f"seen from {count * DRAWS_PER_FRAME} random poses; {len(frames)} "
                        f"frames of {count} drawn")


def _draw_frame(levels: list[tuple], beacons: BeaconMap, rng: np.random.Generator,
                outlier_share: float) -> TrainingFrame | None:
    """One frame at a random level and pose, outliers injected; None if it sees < 3 beacons."""
    level = int(rng.integers(len(levels)))
    scenario, sensor = levels[level]
    pose = random_free_pose(scenario, rng)
    observation = sensor.observe(pose, rng)
    outliers = 0
    if len(observation) and rng.random() < outlier_share:
        outliers = min(int(rng.integers(1, MAX_OUTLIERS + 1)), len(observation))
    return observed_frame(observation, beacons, pose, level, outliers, rng)


def observed_frame(observation: Observation, beacons: BeaconMap, pose: Pose, level: int,
                   outliers: int, rng: np.random.Generator) -> TrainingFrame | None:
    """A sensor's frame as training data, with ``outliers`` azimuths injected (Sec. 3.1).

    Returns None when the frame sees fewer than three distinct beacons of the map.
    """
    measured = observation.measurements
    azimuth, injected = inject_outliers(measured.azimuth, outliers, rng)
    order = np.argsort(azimuth, kind="stable")  # listed by azimuth again, as a detector lists
    quality = None if measured.quality is None else measured.quality[order]
    measurements = Measurements(measured.ids[order], azimuth[order], quality)
    problem = Problem.from_frame(measurements, beacons)
    if problem.n_distinct < MIN_MEASUREMENTS:
        return None
    source = order[problem.source]
    first = first_quality_column(quality, problem.n_measurements)[0][problem.source]
    return TrainingFrame(problem, first, measurement_features(problem, quality),
                         observation.truth.label[source], injected[source], pose, level, outliers)


def _pack(frames: list[TrainingFrame], owners: list[int]) -> FrameBatch:
    """The frames padded to the longest one's usable measurements."""
    n = len(frames)
    width = max(frame.problem.size for frame in frames)
    features = np.zeros((n, width, N_FEATURES), dtype=np.float32)
    floats = np.zeros((n, FLOAT_ROWS, width))
    beacon_index = np.full((n, width), -1, dtype=np.int64)
    label = np.full((n, width), -1, dtype=np.int64)
    injected = np.zeros((n, width), dtype=bool)
    quality = np.zeros((n, width))
    for f, frame in enumerate(frames):
        k = frame.problem.size
        features[f, :k] = frame.features
        floats[f, :, :k] = frame.problem.floats
        beacon_index[f, :k] = frame.problem.beacon_index
        label[f, :k] = frame.label
        injected[f, :k] = frame.injected
        quality[f, :k] = frame.quality
    mask = beacon_index >= 0
    inlier = mask & inlier_truth(label, injected)
    return FrameBatch(
        features=features, floats=floats, beacon_index=beacon_index, mask=mask, inlier=inlier,
        pose=np.array([frame.pose for frame in frames], dtype=np.float64).reshape(n, 3),
        layout=np.array(owners, dtype=np.int64), label=label, injected=injected,
        level=np.array([frame.level for frame in frames], dtype=np.int64),
        outliers=np.array([frame.outliers for frame in frames], dtype=np.int64), quality=quality)
