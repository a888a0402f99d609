"""Training frames: repeatable by seed, the right truth on hand-built frames, a checked file."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest

from azgym.core import wrap_angle
from azgym.errors import InvalidInputError
from azgym.learn.dataset import (
    FRAMES_FORMAT,
    HELD_OUT_LAYOUTS,
    LEVELS,
    TRAIN_LAYOUTS,
    FrameBatch,
    inlier_truth,
    make_frames,
    observed_frame,
)
from azgym.localize.base import FLOAT_ROWS, ROW_AZIMUTH, ROW_BX, ROW_BY, Problem
from azgym.localize.learned.features import FEATURE_LAYOUT, N_FEATURES, measurement_features
from azgym.sensing.geometry.sensor import GeometrySensor
from azgym.sensing.labels import DIRECT, GHOST, MISIDENTIFIED, MOVED, PARTIAL
from azgym.site import parse_scenario


@pytest.fixture(scope="module")
def batch():
    return make_frames([5, 6], 40, seed=3, outlier_share=0.5)


def test_the_same_seed_gives_the_same_arrays_and_another_seed_others(batch):
    again = make_frames([5, 6], 40, seed=3, outlier_share=0.5)
    for field in dataclasses.fields(FrameBatch):
        assert np.array_equal(getattr(batch, field.name), getattr(again, field.name)), field.name
    other = make_frames([5, 6], 40, seed=4, outlier_share=0.5)
    assert not np.array_equal(batch.pose, other.pose)


def test_adding_a_layout_leaves_the_other_layouts_frames_alone(batch):
    alone = make_frames([6], 40, seed=3, outlier_share=0.5)
    rows = batch.layout == 6
    width = alone.mask.shape[1]
    assert np.array_equal(batch.pose[rows], alone.pose)
    assert np.array_equal(batch.features[rows][:, :width], alone.features)
    assert not batch.mask[rows][:, width:].any()


def test_the_batch_is_padded_and_consistent(batch):
    n, width = batch.mask.shape
    assert n == 80 and batch.features.shape == (n, width, N_FEATURES)
    assert batch.floats.shape == (n, FLOAT_ROWS, width)
    assert batch.features.dtype == np.float32
    assert (batch.mask == (batch.beacon_index >= 0)).all()
    assert not batch.inlier[~batch.mask].any() and not batch.features[~batch.mask].any()
    assert (batch.mask.sum(axis=1) >= 3).all()
    assert (batch.injected.sum(axis=1) == batch.outliers).all()  # every id is in the map
    assert set(np.unique(batch.level)) <= set(range(len(LEVELS)))
    assert set(np.unique(batch.outliers)) <= set(range(6))


def test_each_frame_s_features_are_the_compiled_function_of_its_measurements(batch):
    for f in range(len(batch)):
        k = int(batch.mask[f].sum())
        beacons = batch.beacon_index[f, :k]
        ints = np.stack([np.arange(k), beacons])
        problem = Problem(batch.floats[f, :, :k], ints, np.unique(beacons).size, k)
        expected = measurement_features(problem, batch.quality[f, :k]).astype(np.float32)
        assert np.array_equal(batch.features[f, :k], expected)


def test_inliers_agree_with_the_map_from_the_true_pose(batch):
    """The truth means what a localizer needs: an inlier's azimuth points at its mapped beacon."""
    x, y, heading = (batch.pose[:, k, None] for k in range(3))
    predicted = np.arctan2(batch.floats[:, ROW_BY] - y, batch.floats[:, ROW_BX] - x) - heading
    residual = np.abs(wrap_angle(batch.floats[:, ROW_AZIMUTH] - predicted))
    assert residual[batch.inlier].max() < math.radians(3.0)
    faulty = batch.mask & ~batch.inlier
    assert np.median(residual[faulty]) > math.radians(5.0)


def site(beacons, walls=(), misdecode_rate=0.0):
    """A 40 m room around the given beacons, the camera at the origin sees everything."""
    return parse_scenario({
        "name": "test-site", "description": "hand-built", "version": 1,
        "room": {"bounds": [-20.0, -20.0, 20.0, 20.0]},
        "error_model": {"delta_alpha_d_deg": 0.0},
        "camera": {"height": 2.0, "min_elevation_deg": 0.0, "max_range": 100.0},
        "faults": {"misdecode_rate": misdecode_rate},
        "beacons": beacons, "walls": list(walls)}, "test-site.toml")


RING = [{"id": 10 + k, "xyz": [8.0 * math.cos(k), 8.0 * math.sin(k), 4.0]} for k in range(5)]


def frame_of(scenario, outliers=0):
    observation = GeometrySensor(scenario).observe((0.0, 0.0, 0.0), np.random.default_rng(0))
    frame = observed_frame(observation, scenario.beacons, (0.0, 0.0, 0.0), 1, outliers,
                           np.random.default_rng(1))
    return frame, scenario.beacons.ids[frame.problem.beacon_index]


def test_a_ghost_is_no_inlier_but_its_beacon_is():
    mirror = {"start": [-10.0, 2.0], "end": [10.0, 2.0], "height": 10.0, "reflectivity": 0.5}
    frame, ids = frame_of(site([{"id": 1, "xyz": [4.0, 0.0, 2.5]}, *RING], [mirror]))
    ghosts = frame.label == GHOST
    assert 1 in ids[ghosts] and not frame.inlier[ghosts].any()
    assert frame.inlier[~ghosts].all()  # every beacon's own view


def test_a_moved_beacon_is_no_inlier():
    moved = {"id": 1, "xyz": [10.0, 0.0, 4.0], "moved_to": [10.0, 10.0]}
    frame, ids = frame_of(site([moved, *RING]))
    assert frame.label[ids == 1].tolist() == [MOVED]
    assert frame.inlier.tolist() == (ids != 1).tolist()


def test_misread_ids_are_no_inliers():
    frame, _ = frame_of(site(RING, misdecode_rate=1.0))
    assert set(frame.label.tolist()) == {MISIDENTIFIED} and not frame.inlier.any()


@pytest.mark.parametrize("outliers", [1, 3])
def test_injected_azimuths_are_no_inliers_and_the_frame_is_listed_by_azimuth(outliers):
    frame, _ = frame_of(site(RING), outliers)
    assert frame.injected.sum() == outliers and frame.outliers == outliers
    assert (frame.label == DIRECT).all()
    assert frame.inlier.tolist() == (~frame.injected).tolist()
    assert np.all(np.diff(frame.problem.azimuth) >= 0)


def test_the_inlier_rule():
    label = np.array([DIRECT, PARTIAL, GHOST, MISIDENTIFIED, MOVED, DIRECT, -1])
    injected = np.array([False, False, False, False, False, True, False])
    assert inlier_truth(label, injected).tolist() == [True, True] + [False] * 5


def test_a_frame_that_sees_fewer_than_three_beacons_is_none():
    frame, _ = frame_of(site(RING), 0)
    assert frame is not None
    wall = {"start": [12.0, -1.0], "end": [12.0, 1.0], "height": 10.0}
    hidden = site([RING[0], RING[1], {"id": 9, "xyz": [15.0, 0.0, 4.0]}], [wall])
    observation = GeometrySensor(hidden).observe((0.0, 0.0, 0.0), np.random.default_rng(0))
    assert observed_frame(observation, hidden.beacons, (0.0, 0.0, 0.0), 0, 0,
                          np.random.default_rng(0)) is None


def test_the_splits_are_disjoint_and_the_held_out_one_fixed():
    assert len(HELD_OUT_LAYOUTS) == 20
    assert not any(seed in TRAIN_LAYOUTS for seed in HELD_OUT_LAYOUTS)


def test_save_and_load_give_back_the_batch(batch, tmp_path):
    path = batch.save(tmp_path / "frames.npz")
    loaded = FrameBatch.load(path)
    for field in dataclasses.fields(FrameBatch):
        assert np.array_equal(getattr(batch, field.name), getattr(loaded, field.name))


@pytest.mark.parametrize(("arguments", "message"), [
    (([], 1, 0), "layout_seeds must hold at least one generator seed, got none"),
    (("12", 1, 0), "layout_seeds must be a sequence of integers >= 0, got '12'"),
    (([1, -2], 1, 0), "layout_seeds entry must be an integer >= 0, got -2"),
    (([1.5], 1, 0), "layout_seeds entry must be an integer >= 0, got 1.5"),
    (([1], 0, 0), "frames_per_layout must be an integer >= 1, got 0"),
    (([1], 2, -1), "seed must be an integer >= 0, got -1"),
])
def test_bad_arguments_are_refused_by_name(arguments, message):
    with pytest.raises(InvalidInputError, match=f"^{re.escape(message)}$"):
        make_frames(*arguments)


@pytest.mark.parametrize("share", [1.5, -0.1, float("nan"), True, "0.2"])
def test_an_outlier_share_outside_0_1_is_refused(share):
    with pytest.raises(InvalidInputError, match="outlier_share must be a number in \\[0, 1\\]"):
        make_frames([1], 1, 0, outlier_share=share)


def rewritten(batch, path, **changes):
    """The batch saved with some of its npz entries replaced (None: left out)."""
    arrays = {"format": np.array(FRAMES_FORMAT), "feature_layout": np.array(FEATURE_LAYOUT),
              **{f.name: getattr(batch, f.name) for f in dataclasses.fields(FrameBatch)}}
    arrays.update(changes)
    np.savez(path, **{name: value for name, value in arrays.items() if value is not None})
    return path


@pytest.mark.parametrize(("changes", "message"), [
    ({"format": np.array("azgym-frames-9")}, "frame format 'azgym-frames-9', this azgym reads"),
    ({"feature_layout": np.array("measurement-features-0")},
     "features of layout 'measurement-features-0', this azgym computes"),
    ({"format": None}, "not a frame batch \\(no format entry\\)"),
    ({"inlier": None}, "the frame batch has no 'inlier' array"),
    ({"pose": np.zeros((3, 3))}, "pose has shape \\(3, 3\\), expected \\(80, 3\\)"),
    ({"features": np.zeros((80, 2, N_FEATURES))}, "features must be float32, got float64"),
])
def test_a_bad_frame_file_is_refused_by_name(batch, tmp_path, changes, message):
    path = rewritten(batch, tmp_path / "frames.npz", **changes)
    with pytest.raises(InvalidInputError, match=re.escape(str(path)) + ": " + message):
        FrameBatch.load(path)


def test_a_missing_or_broken_file_is_refused_by_name(tmp_path):
    with pytest.raises(InvalidInputError, match="frames.npz: no such file"):
        FrameBatch.load(tmp_path / "frames.npz")
    broken = tmp_path / "broken.npz"
    broken.write_bytes(b"PK\x03\x04 not really a zip")
    with pytest.raises(InvalidInputError, match="broken.npz: not a readable .npz file"):
        FrameBatch.load(broken)
