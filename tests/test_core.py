"""BeaconMap, Measurements, Estimate and wrap_angle: validation, immutability, conventions."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import azgym
from azgym import BeaconMap, Estimate, InvalidInputError, Measurements, wrap_angle

XYZ3 = np.array([[0.0, 0.0, 2.5], [1.0, 0.0, 2.5], [0.0, 1.0, 2.5]])


# --------------------------------------------------------------------------- BeaconMap


def test_beacon_map_stores_copies_and_broadcasts_scalar_width():
    ids = [7, 3, 5]
    xyz = XYZ3.copy()
    beacons = BeaconMap(ids, xyz, width=0.05)
    xyz[0, 0] = 99.0  # the map must not alias the caller's array
    assert beacons.ids.tolist() == [7, 3, 5]
    assert beacons.ids.dtype == np.int64
    assert beacons.xyz[0, 0] == 0.0
    assert beacons.width.tolist() == [0.05, 0.05, 0.05]
    assert beacons.xy.shape == (3, 2)
    assert len(beacons) == 3
    assert beacons.bounds() == (0.0, 0.0, 1.0, 1.0)


def test_beacon_map_accepts_integral_floats_as_ids():
    assert BeaconMap([1.0, 2.0, 3.0], XYZ3).ids.tolist() == [1, 2, 3]


@pytest.mark.parametrize("attribute", ["ids", "xyz", "width"])
def test_beacon_map_arrays_are_read_only(attribute):
    beacons = BeaconMap([1, 2, 3], XYZ3)
    array = getattr(beacons, attribute)
    with pytest.raises(ValueError, match="read-only"):
        array[0] = 0
    with pytest.raises(ValueError, match="read-only"):
        beacons.xy[0, 0] = 5.0


def test_beacon_map_is_frozen():
    beacons = BeaconMap([1, 2, 3], XYZ3)
    with pytest.raises(AttributeError):
        beacons.ids = np.array([4, 5, 6])


@pytest.mark.parametrize(
    ("ids", "xyz", "width", "field"),
    [
        pytest.param([[1, 2, 3]], XYZ3, 0.03, "BeaconMap.ids must be 1-D", id="ids-2d"),
        pytest.param([1, 2, 2], XYZ3, 0.03, "BeaconMap.ids must be unique", id="duplicate-ids"),
        pytest.param([1, 2.5, 3], XYZ3, 0.03, "BeaconMap.ids must hold integers",
                     id="fractional-ids"),
        pytest.param([1, np.nan, 3], XYZ3, 0.03, "BeaconMap.ids must hold integers",
                     id="nan-id"),
        pytest.param(["a", "b", "c"], XYZ3, 0.03, "BeaconMap.ids must hold integers",
                     id="string-ids"),
        pytest.param([1, 2, 3], XYZ3[:, :2], 0.03, "BeaconMap.xyz must have shape (3, 3)",
                     id="xy-instead-of-xyz"),
        pytest.param([1, 2, 3], XYZ3[:2], 0.03, "BeaconMap.xyz must have shape (3, 3)",
                     id="too-few-rows"),
        pytest.param([1, 2, 3], [[0, 0, 0], [1, 0, np.nan], [0, 1, 0]], 0.03,
                     "BeaconMap.xyz must be finite", id="nan-xyz"),
        pytest.param([1, 2, 3], [[0, 0, 0], [1, 0, 0], [0, -np.inf, 0]], 0.03,
                     "BeaconMap.xyz must be finite", id="inf-xyz"),
        pytest.param([1, 2, 3], [["a", 0, 0], [1, 0, 0], [0, 1, 0]], 0.03,
                     "BeaconMap.xyz must be numeric", id="text-xyz"),
        pytest.param([1, 2, 3], XYZ3, -0.01, "BeaconMap.width must be >= 0", id="negative-width"),
        pytest.param([1, 2, 3], XYZ3, [0.03, -0.5, 0.03], "BeaconMap.width must be >= 0",
                     id="one-negative-width"),
        pytest.param([1, 2, 3], XYZ3, np.inf, "BeaconMap.width must be finite", id="inf-width"),
        pytest.param([1, 2, 3], XYZ3, [0.03, np.nan, 0.03], "BeaconMap.width must be finite",
                     id="nan-width"),
    ],
)
def test_beacon_map_rejects_bad_input_naming_the_field(ids, xyz, width, field):
    with pytest.raises(InvalidInputError, match=re.escape(field)):
        BeaconMap(ids, xyz, width)


def test_beacon_map_nan_error_says_where():
    with pytest.raises(InvalidInputError, match=re.escape("at index (1, 2)")):
        BeaconMap([1, 2, 3], [[0, 0, 0], [1, 0, np.nan], [0, 1, 0]])


def test_nan_error_names_field_and_value():
    with pytest.raises(InvalidInputError, match=re.escape("BeaconMap.xyz must be finite, got nan")):
        BeaconMap([1, 2, 3], [[0, 0, 0], [1, 0, np.nan], [0, 1, 0]])


def test_duplicate_id_error_names_the_duplicate():
    with pytest.raises(InvalidInputError, match=re.escape("duplicated: [4]")):
        BeaconMap([4, 1, 4], XYZ3)


def test_invalid_input_error_is_a_value_error():
    # So that `except ValueError` in user code keeps working.
    with pytest.raises(ValueError):
        BeaconMap([1, 1, 2], XYZ3)


def test_beacon_map_width_of_wrong_length_names_the_field():
    with pytest.raises(InvalidInputError, match=re.escape("BeaconMap.width")):
        BeaconMap([1, 2, 3], XYZ3, width=[0.03, 0.03])


def test_beacon_map_non_numeric_width_names_the_field():
    with pytest.raises(InvalidInputError, match=re.escape("BeaconMap.width")):
        BeaconMap([1, 2, 3], XYZ3, width=["a", "b", "c"])


@pytest.mark.parametrize(("ids", "shown"), [
    ([1, -1, 3], "got -1 at index 1"),
    (np.array([1, 2, 2**63], dtype=np.uint64), "got 9223372036854775808 at index 2"),  # wraps
])
def test_beacon_map_refuses_negative_ids_which_would_read_as_padding(ids, shown):
    # An environment's observation pads its id slots with -1: a beacon -1 would look empty.
    with pytest.raises(InvalidInputError, match=re.escape(
            f"BeaconMap.ids must be >= 0 (-1 marks an empty slot in observations), {shown}")):
        BeaconMap(ids, XYZ3)


@pytest.mark.filterwarnings("ignore:invalid value encountered in cast:RuntimeWarning")
@pytest.mark.parametrize("bad_id", [np.inf, 1e30])
def test_beacon_map_rejects_non_representable_ids(bad_id):
    with pytest.raises(InvalidInputError, match=re.escape("BeaconMap.ids")):
        BeaconMap([1.0, bad_id, 3.0], XYZ3)


# --------------------------------------------------------------------------- index_of


def test_index_of_maps_ids_to_rows_and_unknown_ids_to_minus_one():
    beacons = BeaconMap([50, 10, 30], np.zeros((3, 3)))
    # below, between, above every known id, and negative
    query = [30, 50, 10, 0, 20, 40, 60, -1]
    assert beacons.index_of(query).tolist() == [2, 0, 1, -1, -1, -1, -1, -1]


def test_index_of_keeps_the_query_shape():
    beacons = BeaconMap([50, 10, 30], np.zeros((3, 3)))
    assert beacons.index_of([[10, 99], [50, 30]]).tolist() == [[1, -1], [0, 2]]


def test_index_of_on_an_empty_map_is_all_unknown():
    beacons = BeaconMap(np.array([], dtype=int), np.zeros((0, 3)))
    assert len(beacons) == 0
    assert beacons.index_of([1, 2]).tolist() == [-1, -1]


@settings(max_examples=50, deadline=None)
@given(st.sets(st.integers(0, 1000), min_size=1, max_size=30),
       st.lists(st.integers(-1100, 1100), max_size=30))
def test_index_of_agrees_with_a_dictionary(ids, query):
    ids = sorted(ids, key=lambda v: (v * 7919) % 1009)  # an arbitrary, unsorted order
    beacons = BeaconMap(ids, np.zeros((len(ids), 3)))
    row = {beacon_id: k for k, beacon_id in enumerate(ids)}
    expected = [row.get(q, -1) for q in query]
    assert beacons.index_of(np.array(query, dtype=np.int64)).tolist() == expected


# --------------------------------------------------------------------------- Measurements


def test_measurements_hold_copies_read_only():
    azimuth = np.array([0.1, -0.2, 3.0])
    frame = Measurements([3, 1, 2], azimuth, quality=[1.0, 2.0, 3.0])
    azimuth[0] = 1.0
    assert frame.azimuth.tolist() == [0.1, -0.2, 3.0]
    assert len(frame) == 3
    for array in (frame.ids, frame.azimuth, frame.quality):
        with pytest.raises(ValueError, match="read-only"):
            array[0] = 0


def test_measurements_may_be_empty_and_hold_duplicates():
    assert len(Measurements([], [])) == 0
    ghost = Measurements([4, 4, 9], [0.1, 0.5, -1.0])
    assert ghost.ids.tolist() == [4, 4, 9]


def test_measurements_accept_two_dimensional_quality():
    frame = Measurements([1, 2], [0.0, 1.0], quality=np.ones((2, 3)))
    assert frame.quality.shape == (2, 3)


@pytest.mark.parametrize(
    ("ids", "azimuth", "quality", "field"),
    [
        pytest.param(5, 0.3, None, "Measurements.ids must be 1-D", id="scalar"),
        pytest.param([[1, 2]], [0.1, 0.2], None, "Measurements.ids must be 1-D", id="ids-2d"),
        pytest.param([1, 2], [0.1, 0.2, 0.3], None, "Measurements.azimuth must have shape (2,)",
                     id="azimuth-too-long"),
        pytest.param([1, 2], [[0.1, 0.2]], None, "Measurements.azimuth must have shape (2,)",
                     id="azimuth-2d"),
        pytest.param([1, 2], [0.1, np.nan], None, "Measurements.azimuth must be finite",
                     id="nan-azimuth"),
        pytest.param([1, 2], [np.inf, 0.1], None, "Measurements.azimuth must be finite",
                     id="inf-azimuth"),
        pytest.param([1, 2], ["a", "b"], None, "Measurements.azimuth must be numeric",
                     id="text-azimuth"),
        pytest.param([1.5, 2], [0.1, 0.2], None, "Measurements.ids must hold integers",
                     id="fractional-id"),
        pytest.param([True, False], [0.1, 0.2], None, "Measurements.ids must hold integers",
                     id="bool-ids"),
        pytest.param([1, 2], [0.1, 0.2], [1.0, 2.0, 3.0], "Measurements.quality must have shape",
                     id="quality-too-long"),
        pytest.param([1, 2], [0.1, 0.2], np.ones((2, 2, 2)),
                     "Measurements.quality must have shape", id="quality-3d"),
    ],
)
def test_measurements_reject_bad_input_naming_the_field(ids, azimuth, quality, field):
    with pytest.raises(InvalidInputError, match=re.escape(field)):
        Measurements(ids, azimuth, quality)


def test_negative_measured_ids_read_as_unknown_ids():
    # A detector's "undecoded" (-1), or an observation's padding passed on unmasked, is in no
    # map: it never becomes a beacon, and a localizer leaves it out as it would any unknown id.
    beacons = BeaconMap([10, 11, 12, 13], [[5.0, 0.0, 2.5], [0.0, 5.0, 2.5], [-5.0, 0.0, 2.5],
                                           [0.0, -5.0, 2.5]])
    azimuth = np.arctan2(beacons.xy[:, 1] - 1.0, beacons.xy[:, 0] - 0.5)
    clean = Measurements(beacons.ids, azimuth)
    padded = Measurements([*beacons.ids, -1, -1], [*azimuth, 0.0, 0.0])
    assert beacons.index_of(padded.ids).tolist() == [0, 1, 2, 3, -1, -1]
    localizer = azgym.make_localizer("lsq")
    expected, got = localizer.localize(clean, beacons), localizer.localize(padded, beacons)
    assert got.ok and got.pose == pytest.approx(expected.pose)
    assert got.pose == pytest.approx((0.5, 1.0, 0.0), abs=1e-6)
    assert got.inliers.tolist() == [True] * 4 + [False] * 2


@pytest.mark.filterwarnings("ignore:invalid value encountered in cast:RuntimeWarning")
def test_measurements_reject_infinite_id():
    with pytest.raises(InvalidInputError, match=re.escape("Measurements.ids")):
        Measurements([1.0, np.inf], [0.1, 0.2])


# --------------------------------------------------------------------------- Estimate


def test_failed_estimate_has_nan_pose_reason_and_no_inliers():
    failed = Estimate.failure("too few beacons", 4, {"n": 1})
    assert not failed.ok
    assert failed.reason == "too few beacons"
    assert math.isnan(failed.x) and math.isnan(failed.y) and math.isnan(failed.heading)
    assert failed.inliers.tolist() == [False] * 4
    assert failed.inliers.dtype == bool
    assert failed.n_inliers == 0
    assert failed.diagnostics == {"n": 1}
    assert np.isnan(failed.position).all()


def test_estimate_position_and_inlier_count():
    estimate = Estimate(x=1.5, y=-2.0, heading=0.3, inliers=np.array([True, False, True]))
    assert estimate.ok and estimate.reason == ""
    assert estimate.position.tolist() == [1.5, -2.0]
    assert estimate.n_inliers == 2
    with pytest.raises(AttributeError):
        estimate.x = 0.0


def test_the_fast_answer_is_the_estimate_the_dataclass_builds_field_for_field():
    inliers, covariance, diagnostics = np.array([True, False]), np.eye(3), {"n_triplets": 1}
    fast = Estimate._filled(1.5, -2.0, 0.3, inliers, True, "", covariance, diagnostics)
    built = Estimate(x=1.5, y=-2.0, heading=0.3, inliers=inliers, covariance=covariance,
                     diagnostics=diagnostics)
    for field in dataclasses.fields(Estimate):  # a field added later must be set by both
        mine, theirs = getattr(fast, field.name), getattr(built, field.name)
        assert mine is theirs or (isinstance(mine, float | bool | str) and mine == theirs), \
            field.name
    assert repr(fast) == repr(built)
    with pytest.raises(AttributeError):
        fast.x = 0.0


def test_a_failure_is_the_estimate_the_dataclass_builds_field_for_field():
    failed = Estimate.failure("no fix yet", 2, {"fix": "none"})
    built = Estimate(x=math.nan, y=math.nan, heading=math.nan, inliers=np.zeros(2, bool),
                     ok=False, reason="no fix yet", diagnostics={"fix": "none"})
    assert repr(failed) == repr(built)
    assert failed.inliers.dtype == bool and failed.covariance is None
    assert all(math.isnan(value) for value in failed.pose)


def test_failure_diagnostics_are_copied():
    extra = {"n": 1}
    failed = Estimate.failure("x", 1, extra)
    extra["n"] = 2
    assert failed.diagnostics["n"] == 1


# --------------------------------------------------------------------------- wrap_angle


@pytest.mark.parametrize(
    ("angle", "expected"),
    [
        (0.0, 0.0),
        (math.pi, math.pi),  # the closed end stays
        (-math.pi, math.pi),  # the open end goes to the closed one
        (3 * math.pi, math.pi),
        (-3 * math.pi, math.pi),
        (2 * math.pi, 0.0),
        (1.5 * math.pi, -0.5 * math.pi),
        (-1.5 * math.pi, 0.5 * math.pi),
        (math.radians(190), math.radians(-170)),
        (math.radians(-350), math.radians(10)),
    ],
)
def test_wrap_angle_hand_values(angle, expected):
    assert wrap_angle(angle) == pytest.approx(expected, abs=1e-12)


def test_wrap_angle_returns_float_for_scalar_and_array_for_array():
    assert isinstance(wrap_angle(1.0), float)
    wrapped = wrap_angle([[-math.pi, 4.0], [0.5, 7.0]])
    assert isinstance(wrapped, np.ndarray) and wrapped.shape == (2, 2)
    assert wrapped[0, 0] == math.pi
    assert wrapped[0, 1] == pytest.approx(4.0 - 2 * math.pi, abs=1e-15)


@settings(max_examples=300, deadline=None)
@given(st.floats(min_value=-1e4, max_value=1e4, allow_nan=False))
def test_wrap_angle_range_and_congruence(angle):
    wrapped = wrap_angle(angle)
    assert -math.pi < wrapped <= math.pi
    # Same direction: the difference is a whole number of turns.
    turns = (angle - wrapped) / (2 * math.pi)
    assert abs(turns - round(turns)) < 1e-9
    # Angles already inside the range are returned unchanged.
    if -math.pi < angle <= math.pi:
        assert wrapped == pytest.approx(angle, abs=1e-15)


@settings(max_examples=200, deadline=None)
@given(st.floats(min_value=-1e4, max_value=1e4, allow_nan=False))
def test_wrap_angle_is_idempotent(angle):
    once = wrap_angle(angle)
    assert wrap_angle(once) == once


def test_wrap_angle_just_above_pi():
    wrapped = wrap_angle(np.nextafter(math.pi, 4.0))
    assert wrapped != -math.pi
    assert wrap_angle(wrapped) == wrapped


def test_an_estimate_gives_a_pose_only_when_ok_is_true_and_the_pose_finite():
    from azgym.core import estimated_pose

    mask = np.zeros(3, dtype=bool)
    assert estimated_pose(Estimate(1.0, 2.0, 0.5, mask)) == (1.0, 2.0, 0.5)
    assert estimated_pose(Estimate(1.0, math.nan, 0.5, mask)) is None  # ok=True, NaN part
    assert estimated_pose(Estimate.failure("none", 3)) is None
    with pytest.raises(InvalidInputError, match=re.escape("Estimate.ok must be True or False, "
                                                          "got 'False'")):
        estimated_pose(Estimate(1.0, 2.0, 0.5, mask, ok="False"))


def test_azimuths_in_degrees_are_refused_with_a_hint():
    with pytest.raises(InvalidInputError, match=re.escape(
            "Measurements.azimuth must be radians in [-π, π], got 45.0 at index 1 (degrees? "
            "convert with np.radians")):
        Measurements([1, 2, 3], [0.0, 45.0, -90.0])
    edge = np.float32(np.pi).astype(np.float64)  # an agent's float32 observation of π
    assert Measurements([1], [edge]).azimuth[0] == edge
