"""The physical sensor: hand-worked occlusion, partial cover and mirrors; fault labels."""

from __future__ import annotations

import math
import re

import numpy as np
import pytest

from azgym import ScenarioError
from azgym.sensing.geometry import detections, frame
from azgym.sensing.geometry.sensor import FrameBuffers, GeometrySensor
from azgym.sensing.labels import LABEL_NAMES
from azgym.site import parse_scenario

CAMERA_Z = 2.0


def site(beacons, racks=(), walls=(), **extra):
    """A scenario around the given beacons (dicts), racks and walls, no centre-detection noise."""
    data = {
        "name": "test-site", "description": "hand-worked geometry", "version": 1,
        "room": {"bounds": [-20.0, -20.0, 20.0, 20.0]},
        "error_model": {"delta_alpha_d_deg": 0.0},
        "camera": {"height": CAMERA_Z, "min_elevation_deg": 0.0, "max_range": 100.0},
        "beacons": list(beacons), "racks": list(racks), "walls": list(walls),
    }
    data.update(extra)
    return parse_scenario(data, "test-site.toml")


def far_beacons(first_id=100):
    """Three beacons out of the way, so that every scenario has the three it must have."""
    return [{"id": first_id + k, "xyz": [-15.0, -15.0 + k, 4.0]} for k in range(3)]


def seen(scenario, x=0.0, y=0.0, heading=0.0, seed=0):
    observation = GeometrySensor(scenario).observe((x, y, heading), np.random.default_rng(seed))
    return observation.measurements, observation.truth


def _pair(observation):
    return observation.measurements, observation.truth


def detections_of(measurements, truth, beacon_id):
    rows = [k for k in range(len(measurements)) if measurements.ids[k] == beacon_id]
    return [(measurements.azimuth[k], LABEL_NAMES[truth.label[k]], truth.visible[k])
            for k in rows]


@pytest.mark.parametrize(("rack_height", "visible"), [(6.0, False), (3.0, False), (2.5, True)])
def test_a_rack_hides_a_beacon_only_if_the_ray_passes_below_its_top(rack_height, visible):
    # Camera at height 2, beacon 10 m east at height 4: the ray rises 0.2 m per metre, so it
    # enters the rack's near face (x = 4.5) at 2.9 m and leaves its far face (x = 5.5) at 3.1 m.
    scenario = site([{"id": 1, "xyz": [10.0, 0.0, 4.0]}, *far_beacons()],
                    racks=[{"center": [5.0, 0.0], "size": [1.0, 1.0], "height": rack_height}])
    measurements, truth = seen(scenario)
    assert bool(detections_of(measurements, truth, 1)) is visible


def test_a_half_covered_beacon_is_measured_at_its_visible_halfs_centroid():
    # A 0.2 m wide beacon 10 m east spans ±h, h = atan(0.1 / 10). A wall from (5, 0) to (5, -1)
    # ends exactly on the centre ray and covers the southern half, so the visible half [0, h] has
    # its centroid at h / 2.
    scenario = site([{"id": 1, "xyz": [10.0, 0.0, 4.0], "width": 0.2}, *far_beacons()],
                    walls=[{"start": [5.0, 0.0], "end": [5.0, -1.0], "height": 10.0}])
    measurements, truth = seen(scenario)
    [(azimuth, label, share)] = detections_of(measurements, truth, 1)
    half = math.atan2(0.1, 10.0)
    assert azimuth == pytest.approx(half / 2, abs=1e-9)
    assert label == "partial"
    assert share == pytest.approx(0.5, abs=1e-9)


def test_a_beacon_on_its_own_wall_is_visible_and_a_wall_in_front_hides_it():
    beacon = {"id": 1, "xyz": [10.0, 0.0, 4.0]}
    own_wall = {"start": [10.0, -5.0], "end": [10.0, 5.0], "height": 8.0}
    measurements, truth = seen(site([beacon, *far_beacons()], walls=[own_wall]))
    [(azimuth, label, _)] = detections_of(measurements, truth, 1)
    assert azimuth == pytest.approx(0.0, abs=1e-12) and label == "direct"
    front_wall = {"start": [8.0, -5.0], "end": [8.0, 5.0], "height": 8.0}
    measurements, truth = seen(site([beacon, *far_beacons()], walls=[own_wall, front_wall]))
    assert detections_of(measurements, truth, 1) == []


def test_a_ghost_appears_in_the_hand_computed_mirror_direction():
    # A mirror along y = 2; the camera at the origin, a beacon at (4, 0) at the camera's height.
    # Its image is (4, 4), so the ghost is seen at 45°, via the reflection point (2, 2).
    mirror = {"start": [-10.0, 2.0], "end": [10.0, 2.0], "height": 10.0, "reflectivity": 0.5}
    scenario = site([{"id": 1, "xyz": [4.0, 0.0, 2.5]}, *far_beacons()], walls=[mirror])
    measurements, truth = seen(scenario, heading=0.3)
    found = sorted(detections_of(measurements, truth, 1), key=lambda row: row[1])
    assert [label for _, label, _ in found] == ["direct", "ghost"]
    assert found[0][0] == pytest.approx(-0.3, abs=1e-12)
    assert found[1][0] == pytest.approx(math.pi / 4 - 0.3, abs=1e-12)


def test_no_reflection_off_a_segments_extension():
    # The same mirror line, but the segment starts at x = 5: the reflection point (2, 2) is on
    # its extension, not on the segment.
    mirror = {"start": [5.0, 2.0], "end": [10.0, 2.0], "height": 10.0, "reflectivity": 0.5}
    scenario = site([{"id": 1, "xyz": [4.0, 0.0, 2.5]}, *far_beacons()], walls=[mirror])
    measurements, truth = seen(scenario)
    assert [label for _, label, _ in detections_of(measurements, truth, 1)] == ["direct"]


@pytest.mark.parametrize("case", ["blocked leg", "over the top", "too faint"])
def test_ghosts_need_a_clear_path_a_tall_enough_mirror_and_enough_light(case):
    mirror = {"start": [-10.0, 2.0], "end": [10.0, 2.0], "height": 10.0, "reflectivity": 0.5}
    racks = []
    beacon = {"id": 1, "xyz": [4.0, 0.0, 2.5]}
    extra = {}
    if case == "blocked leg":  # a tall rack across the leg from (2, 2) to the beacon
        racks = [{"center": [3.0, 1.0], "size": [0.2, 0.2], "height": 5.0}]
    elif case == "over the top":  # the mirror ends below the ray's height at (2, 2)
        mirror["height"] = 2.1
    else:  # reflectivity 0.5 over a path of 5.7 m needs a range of at least 8 m
        extra["camera"] = {"height": CAMERA_Z, "min_elevation_deg": 0.0, "max_range": 7.0}
    scenario = site([beacon, *far_beacons()], racks=racks, walls=[mirror], **extra)
    measurements, truth = seen(scenario)
    assert "ghost" not in [label for _, label, _ in detections_of(measurements, truth, 1)]


def test_field_of_view_and_range():
    below = {"id": 1, "xyz": [5.0, 0.0, 1.5]}  # under the camera's horizon
    distant = {"id": 2, "xyz": [0.0, 10.0, 4.0]}
    scenario = site([below, distant, *far_beacons()],
                    camera={"height": CAMERA_Z, "min_elevation_deg": 0.0, "max_range": 9.0})
    measurements, truth = seen(scenario)
    assert detections_of(measurements, truth, 1) == []
    assert detections_of(measurements, truth, 2) == []


def test_a_moved_beacon_is_seen_where_it_is_and_labelled():
    moved = {"id": 1, "xyz": [10.0, 0.0, 4.0], "moved_to": [10.0, 10.0]}
    scenario = site([moved, *far_beacons()])
    assert scenario.beacons.xyz[0].tolist() == [10.0, 0.0, 4.0]  # the map was not updated
    measurements, truth = seen(scenario)
    [(azimuth, label, _)] = detections_of(measurements, truth, 1)
    assert azimuth == pytest.approx(math.pi / 4, abs=1e-12) and label == "moved"


def test_misdecoded_ids_name_another_map_beacon_and_are_labelled():
    beacons = [{"id": 10 + k, "xyz": [5.0 * math.cos(k), 5.0 * math.sin(k), 4.0]}
               for k in range(6)]
    scenario = site(beacons, faults={"misdecode_rate": 1.0})
    measurements, truth = seen(scenario)
    assert len(measurements) == 6
    assert set(truth.label_names()) == {"misidentified"}
    true_ids = scenario.beacons.ids[truth.beacon]
    assert (measurements.ids != true_ids).all()
    assert set(measurements.ids) <= set(scenario.beacons.ids)


def test_noise_is_eq1_uniform_and_frames_are_repeatable():
    beacons = [{"id": 10 + k, "xyz": [5.0 * math.cos(k), 5.0 * math.sin(k), 4.0]}
               for k in range(6)]
    scenario = site(beacons, error_model={"delta_alpha_d_deg": 0.4})
    first = seen(scenario, seed=3)
    again = seen(scenario, seed=3)
    assert np.array_equal(first[0].azimuth, again[0].azimuth)
    assert np.array_equal(first[0].ids, again[0].ids)
    error = np.angle(np.exp(1j * (first[0].azimuth - first[1].azimuth)))
    assert np.abs(error).max() <= math.radians(0.4)
    assert np.abs(error).max() > 0.0
    assert np.all(np.diff(first[0].azimuth) >= 0)  # listed by azimuth


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"racks": [{"center": [10.0, 0.0], "size": [2.0, 2.0], "height": 4.0}]},
         "beacons[0]: beacon 1 at (10, 0) is inside racks[0]"),
        ({"racks": [{"center": [0.0, 0.0], "size": [0.0, 2.0], "height": 4.0}]},
         "racks[0].size: must be positive"),
        ({"racks": [{"centre": [0.0, 0.0], "size": [1.0, 2.0], "height": 4.0}]},
         "racks[0]: unknown key 'centre'. Did you mean 'center'?"),
        ({"racks": [{"center": [0.0, 0.0], "size": [1.0, 2.0], "height": -1.0}]},
         "racks[0].height: must be > 0"),
        ({"walls": [{"start": [0.0, 0.0], "end": [0.0, 0.0], "height": 4.0}]},
         "walls[0].end: must differ from start"),
        ({"walls": [{"start": [0.0, 0.0], "end": [1.0, 0.0], "height": 4.0,
                     "reflectivity": 1.5}]},
         "walls[0].reflectivity: must be in [0, 1]"),
        ({"camera": {"min_elevation_deg": 95.0}}, "camera.min_elevation_deg: must be in"),
        ({"faults": {"misdecode_rate": 2.0}}, "faults.misdecode_rate: must be in [0, 1]"),
        ({"racks": {"center": [0.0, 0.0]}}, "racks: must be an array of [[racks]] tables"),
    ],
)
def test_malformed_layouts_are_reported_with_the_field(change, message):
    beacons = [{"id": 1, "xyz": [10.0, 0.0, 4.0]}, *far_beacons()]
    with pytest.raises(ScenarioError, match=re.escape(f"test-site.toml: {message}")):
        site(beacons, **change)


def test_a_rolled_camera_sees_a_beacon_ahead_shifted_by_atan_sin_roll_tan_elevation():
    # A beacon straight ahead at 45° elevation; the camera rolled by 5° about its forward axis
    # sees it at azimuth atan(sin 5° · tan 45°).
    scenario = site([{"id": 1, "xyz": [4.0, 0.0, CAMERA_Z + 4.0]}, *far_beacons()])
    sensor = GeometrySensor(scenario)
    level, level_truth = _pair(sensor.observe((0.0, 0.0, 0.0), np.random.default_rng(0)))
    rolled, truth = _pair(sensor.observe((0.0, 0.0, 0.0), np.random.default_rng(0),
                                         tilt=(0.0, math.radians(5.0))))
    [(azimuth, _, _)] = detections_of(rolled, truth, 1)
    assert [row[0] for row in detections_of(level, level_truth, 1)] == [0.0]
    assert azimuth == pytest.approx(math.atan(math.sin(math.radians(5.0))), abs=1e-12)
    # Pitch moves a beacon on the side: at 90° left and 45° elevation, by atan(sin p · tan e).
    side = site([{"id": 1, "xyz": [0.0, 4.0, CAMERA_Z + 4.0]}, *far_beacons()])
    pitched, truth = _pair(GeometrySensor(side).observe((0.0, 0.0, 0.0),
                                                        np.random.default_rng(0),
                                                        tilt=(math.radians(5.0), 0.0)))
    [(azimuth, _, _)] = detections_of(pitched, truth, 1)
    assert azimuth == pytest.approx(math.pi / 2 + math.atan(math.sin(math.radians(5.0))),
                                    abs=1e-12)


def test_a_beacon_behind_more_than_16_occluders_counts_every_one():
    # A 0.2 m wide beacon 10 m east spans ±h, h = atan(0.01); at x = 5 the extent is y in
    # [-0.05, 0.05]. Twenty short walls at x = 5 tile y from -0.06 to 0.03, listed top first, so
    # that the bottom ones come last: only [0.03, 0.05] stays visible, between atan(0.006) and h.
    edges = [-0.06] + [-0.05 + 0.004 * k for k in range(1, 21)]
    tiles = [{"start": [5.0, lo], "end": [5.0, hi], "height": 10.0}
             for lo, hi in zip(edges, edges[1:], strict=False)]
    scenario = site([{"id": 1, "xyz": [10.0, 0.0, 4.0], "width": 0.2}, *far_beacons()],
                    walls=tiles[::-1])
    measurements, truth = seen(scenario)
    [(azimuth, label, share)] = detections_of(measurements, truth, 1)
    half, edge = math.atan(0.01), math.atan(0.006)
    assert label == "partial"
    assert share == pytest.approx((half - edge) / (2 * half), abs=1e-9)
    assert azimuth == pytest.approx((half + edge) / 2, abs=1e-12)
    # Without the last wall listed, [-0.05, -0.046] at x = 5 shows too: every wall counts.
    measurements, truth = seen(site([{"id": 1, "xyz": [10.0, 0.0, 4.0], "width": 0.2},
                                     *far_beacons()], walls=tiles[:0:-1]))
    [(_, _, more)] = detections_of(measurements, truth, 1)
    assert more == pytest.approx(share + (half - math.atan(0.0092)) / (2 * half), abs=1e-9)


def test_the_frame_buffers_rows_are_the_rows_the_kernels_write():
    float_rows = {"azimuth": frame.FRAME_AZIMUTH, "quality": frame.FRAME_QUALITY,
                  "true_azimuth": frame.FRAME_TRUE_AZIMUTH, "visible": frame.FRAME_VISIBLE,
                  "elevation": frame.FRAME_ELEVATION, "half_width": frame.FRAME_HALF_WIDTH}
    int_rows = {"ids": frame.FRAME_ID, "beacon": frame.FRAME_BEACON, "label": frame.FRAME_LABEL,
                "mirrored": frame.FRAME_MIRRORED}
    assert sorted(float_rows.values()) == list(range(frame.FRAME_FLOAT_ROWS))
    assert sorted(int_rows.values()) == list(range(frame.FRAME_INT_ROWS))
    found_rows = [detections.FOUND_AZIMUTH, detections.FOUND_ELEVATION,
                  detections.FOUND_VISIBLE, detections.FOUND_BRIGHTNESS,
                  detections.FOUND_HALF_WIDTH]
    assert sorted(found_rows) == list(range(detections.FOUND_FLOAT_ROWS))
    int_rows_found = [detections.FOUND_BEACON, detections.FOUND_LABEL]
    assert sorted(int_rows_found) == list(range(detections.FOUND_INT_ROWS))
    buffers = FrameBuffers(3)
    buffers.floats[:] = np.arange(frame.FRAME_FLOAT_ROWS)[:, None]
    buffers.ints[:] = np.arange(frame.FRAME_INT_ROWS)[:, None]
    for name, row in (float_rows | int_rows).items():
        assert getattr(buffers, name).tolist() == [row] * 3, name


def test_each_row_of_a_frame_holds_its_own_hand_worked_value():
    # One beacon 10 m east, 2 m above the camera, 0.2 m wide, seen with the heading 0.25.
    beacon = {"id": 7, "xyz": [10.0, 0.0, CAMERA_Z + 2.0], "width": 0.2}
    sensor = GeometrySensor(site([beacon, *far_beacons()]))
    out = sensor.new_buffers(sensor.capacity + 2)
    count = sensor.observe_into((0.0, 0.0, 0.25), np.random.default_rng(0), out)
    assert count == 4 == sensor.capacity
    [k] = np.flatnonzero(out.ids == 7)
    assert out.azimuth[k] == out.true_azimuth[k] == pytest.approx(-0.25, abs=1e-15)
    assert out.quality[k] == pytest.approx(math.log10(100.0**2 / 104.0), abs=1e-12)
    assert out.visible[k] == 1.0
    assert out.elevation[k] == pytest.approx(math.atan2(2.0, 10.0), abs=1e-15)
    assert out.half_width[k] == pytest.approx(math.atan2(0.1, 10.0), abs=1e-15)
    assert (out.beacon[k], LABEL_NAMES[out.label[k]], out.mirrored[k]) == (0, "direct", 0)
    assert out.ids[count:].tolist() == out.beacon[count:].tolist() == [-1, -1]
    assert out.label[count:].tolist() == [-1, -1] and out.mirrored[count:].tolist() == [0, 0]
    assert not out.floats[:, count:].any()
