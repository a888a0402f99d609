"""Blinking ids: the code, its decoder, the blob tracker, and the image path on a route."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from azgym.core import wrap_angle
from azgym.errors import InvalidInputError
from azgym.sensing.image._turn import common_turn
from azgym.sensing.image.blink_code import MARKER, BlinkCode
from azgym.sensing.image.blob_tracker import (
    NEW_TRACK_GATES,
    TURN_SUPPORT,
    TURN_WINDOW,
    BlobTracker,
)

CODE = BlinkCode(6)


def test_the_code_is_a_marker_then_manchester_bits_and_even_parity():
    # id 5 = 000101: parity 0; Manchester 1 -> (1, 0), 0 -> (0, 1).
    expected = [1, 1, 1, 0] + [0, 1] * 3 + [1, 0, 0, 1, 1, 0] + [0, 1]
    assert BlinkCode(6).frames(5).astype(int).tolist() == expected
    assert BlinkCode(6).period == 4 + 2 * 7
    assert BlinkCode.for_ids([1, 15]).bits == 4 and BlinkCode.for_ids([64]).bits == 7


@given(st.integers(0, 63), st.integers(0, 63), st.integers(0, 17))
def test_three_lit_frames_in_a_row_happen_only_at_the_marker(first, second, shift):
    stream = np.concatenate([CODE.frames(first), CODE.frames(second)])[shift:]
    runs = [k for k in range(len(stream) - 2) if stream[k:k + 3].all()]
    marker_starts = {k for k in range(len(stream) - 3)
                     if stream[k:k + 4].astype(int).tolist() == list(MARKER)}
    # every run of three lit frames ends at (or one before) a marker's last lit frame
    assert all(any(0 <= start - k <= 1 for start in marker_starts) for k in runs)
    # and the beacon is never dark for three frames running
    assert not any((~stream[k:k + 3]).all() for k in range(len(stream) - 2))


@given(st.integers(0, 63), st.integers(0, 17))
def test_every_id_decodes_once_per_period_when_its_codeword_completes(beacon_id, phase):
    stream = np.tile(CODE.frames(beacon_id), 3)[phase:]
    decoded = [(k, CODE.decode(stream[:k + 1])) for k in range(len(stream))]
    reads = [(k, value) for k, value in decoded if value is not None]
    assert reads and all(value == beacon_id for _, value in reads)
    assert all(b - a == CODE.period for (a, _), (b, _) in zip(reads, reads[1:], strict=False))


@given(st.integers(0, 63), st.integers(0, 17))
def test_one_wrong_frame_never_gives_a_wrong_id(beacon_id, flipped):
    history = CODE.frames(beacon_id).copy()
    history[flipped] = not history[flipped]
    assert CODE.decode(history) in (None, -1)


def test_bad_codes_are_rejected():
    with pytest.raises(InvalidInputError, match="bits"):
        BlinkCode(0)
    with pytest.raises(InvalidInputError, match="non-negative"):
        BlinkCode.for_ids([-1, 3])
    with pytest.raises(InvalidInputError, match="does not fit"):
        CODE.frames(64)


def test_the_tracker_decodes_blinking_blobs_that_turn_and_drift():
    # Eight beacons on a ring of radius 200 px; the camera turns at up to 0.12 rad a frame (a
    # brisk turn at 10 Hz: 24 px a frame) and each blob drifts on its own as well.
    rng = np.random.default_rng(3)
    ids = rng.choice(64, 8, replace=False)
    phase = rng.integers(0, CODE.period, 8)
    base = np.linspace(0, 2 * math.pi, 8, endpoint=False)
    drift = rng.uniform(-0.01, 0.01, 8)
    tracker = BlobTracker(CODE, (240.0, 240.0))
    turn = 0.0
    for frame in range(4 * CODE.period):
        turn += 0.12 * math.sin(frame / 10.0)
        azimuth = base + turn + drift * frame
        lit = np.array([CODE.frames(int(i))[(frame + p) % CODE.period]
                        for i, p in zip(ids, phase, strict=True)])
        pixels = np.column_stack([240 + 200 * np.cos(azimuth[lit]),
                                  240 + 200 * np.sin(azimuth[lit])])
        decoded = tracker.update(pixels)
        if frame >= 2 * CODE.period:  # every beacon has shown a whole codeword
            assert decoded.tolist() == ids[lit].tolist()
    assert tracker.track_count == 8


def close_beacons_at_the_horizon(frames, areas=True, seed=0):
    """Eight beacons on a ring of radius 150 px and three more near the horizon, 4.7 and 6.9 px
    apart (as far rack-end beacons down a long aisle are), all drifting 0.07 px a frame. The
    third comes into view at a frame where it is lit and its neighbour dark, 10 px from it, and
    closes in to 4.7 px over two code periods. Within 5 px the two merge into one blob, at
    their centre and with both areas, when they are lit together: that blob has no id.
    Yields (frame, decoded ids, true ids)."""
    rng = np.random.default_rng(seed)
    ids = np.array([20, 21, 22, 23, 24, 25, 26, 27, 7, 8, 9])
    phase = np.array([3, 7, 1, 12, 9, 15, 4, 10, 0, 5, 11])
    ring = 240 + 150 * np.column_stack([np.cos(np.arange(8) * math.pi / 4),
                                        np.sin(np.arange(8) * math.pi / 4)])
    start = np.vstack([ring, [[450.2, 215.1], [455.4, 219.7], [458.8, 222.8]]])
    lit_at = np.array([[CODE.frames(int(i))[(frame + p) % CODE.period]
                        for i, p in zip(ids, phase, strict=True)] for frame in range(frames)])
    appears = next(f for f in range(frames) if lit_at[f, 10] and not lit_at[f, 9])
    tracker = BlobTracker(CODE, (240.0, 240.0))
    for frame, lit in enumerate(lit_at):
        lit = lit & (frame >= appears or np.arange(len(ids)) < 10)
        centres = start - 0.05 * frame + rng.normal(0.0, 0.1, start.shape)
        centres[10] += max(0.0, 1.0 - frame / 36) * np.array([4.0, 3.5])  # closing in
        merged = lit[9] and lit[10] and np.hypot(*(centres[10] - centres[9])) < 5.0
        blobs, truth = [], []
        for k in np.flatnonzero(lit):
            if k == 10 and merged:
                continue  # in beacon 8's blob
            blobs.append(((centres[9] + centres[10]) / 2, 20.0) if k == 9 and merged
                         else (centres[k], 10.0))
            truth.append(-1 if k == 9 and merged else ids[k])  # no one beacon's azimuth
        pixels = np.array([b[0] for b in blobs]).reshape(-1, 2)
        area = np.array([b[1] for b in blobs]) if areas else None
        yield frame, tracker.update(pixels, area), np.array(truth, dtype=np.int64)


def test_close_blinking_blobs_keep_their_tracks_and_merged_blobs_light_both():
    for frame, decoded, truth in close_beacons_at_the_horizon(6 * CODE.period):
        if frame >= 2 * CODE.period:
            assert decoded.tolist() == truth.tolist()
    # Without the areas a merged blob lights one track, and the other beacon's code breaks.
    late = [(decoded, truth) for frame, decoded, truth in
            close_beacons_at_the_horizon(6 * CODE.period, areas=False)
            if frame >= 2 * CODE.period]
    assert any(9 not in decoded for decoded, truth in late if 9 in truth)


def test_a_dark_track_leaves_its_neighbours_blob_when_a_new_blob_appears():
    # Tracks A and B 6.4 px apart (eight steady blobs on a ring pin the common turn). A goes
    # dark as a new blob C shows up 4.5 px past B. Pairing as many as possible would give
    # A -> B's blob (6.4 px) and B -> C (4.5 px); the best total margin inside the 8 px gates
    # keeps B -> B (0 px) and starts a track for C.
    ring = 240 + 150 * np.column_stack([np.cos(np.arange(8) * math.pi / 4),
                                        np.sin(np.arange(8) * math.pi / 4)])
    a, b = np.array([450.1, 215.0]), np.array([455.4, 218.6])
    c = b + 4.5 * (b - a) / np.hypot(*(b - a))
    tracker = BlobTracker(CODE, (240.0, 240.0))
    for _ in range(5):
        tracker.update(np.vstack([ring, a, b]))
    assert tracker.track_count == 10
    tracker.update(np.vstack([ring, b, c]))
    assert tracker.track_count == 11  # C has its own track, A waits for its next lit frame
    tracker.update(np.vstack([ring, a, b, c]))
    assert tracker.track_count == 11  # and A's blob returns to A


@pytest.mark.parametrize("step", [2.5, 3.5])
def test_a_new_track_takes_a_blob_within_three_gates_then_within_one(step):
    # One blob 200 px right of the centre moves outwards by `step` gates of 8 px: a track whose
    # drift is not yet measured keeps it within NEW_TRACK_GATES gates. Its drift then measured,
    # a blob 1.25 gates off the prediction starts a new track.
    gate = 8.0
    tracker = BlobTracker(CODE, (240.0, 240.0), gate_px=gate)
    tracker.update(np.array([[440.0, 240.0]]))
    tracker.update(np.array([[440.0 + step * gate, 240.0]]))
    assert tracker.track_count == (1 if step < NEW_TRACK_GATES else 2)
    if step < NEW_TRACK_GATES:
        predicted = 440.0 + 2 * step * gate
        tracker.update(np.array([[predicted + 1.25 * gate, 240.0]]))
        assert tracker.track_count == 2


def test_blob_areas_must_match_the_blobs():
    with pytest.raises(InvalidInputError, match="areas"):
        BlobTracker(CODE, (240.0, 240.0)).update(np.zeros((2, 2)), np.ones(3))


@pytest.mark.parametrize("scenario, route", [("warehouse-small", "pick-and-back"),
                                             ("warehouse-paper", "A-B-C-D")])  # over the bump
def test_the_image_path_decodes_ids_on_a_warehouse_route(scenario, route):
    from azgym.experiments.identification import measure_identification

    stats = measure_identification(scenario, camera_rate_hz=30.0, routes=[route])
    assert stats.eligible > 1000
    assert stats.correct_share >= 0.99
    assert stats.misdecode_rate <= 0.01


def numpy_common_turn(azimuth, radius, own_azimuth, own_radius, last_turn, gate, max_change):
    """The common turn as numpy calls: pairs at similar radii, their shifts' densest window."""
    close = np.abs(radius[None, :] - own_radius[:, None]) <= gate
    shift = wrap_angle((azimuth[None, :] - own_azimuth[:, None] - last_turn)[close])
    candidates = np.sort(shift[np.abs(shift) <= max_change])
    if candidates.size < TURN_SUPPORT:
        return last_turn
    support = np.searchsorted(candidates, candidates + TURN_WINDOW, side="right") - \
        np.arange(candidates.size)
    most = support.max()
    starts = np.flatnonzero(support == most)
    best = starts[np.argmin(np.abs(candidates[starts] + 0.5 * TURN_WINDOW))]
    return last_turn + float(np.median(candidates[best:best + most]))


@settings(deadline=None)  # the first example loads (or compiles) the kernel
@given(st.integers(0, 2**32 - 1), st.integers(0, 12), st.integers(0, 12),
       st.sampled_from([0.0, 0.05, -3.1, 3.14]))
def test_the_compiled_common_turn_is_the_numpy_one_bit_for_bit(seed, tracks, blobs, last_turn):
    rng = np.random.default_rng(seed)
    # blobs that are the tracks turned by a common shift, some noise blobs, a few repeated
    # shifts (ties between windows) and azimuths near ±π (wrapping)
    own_azimuth = rng.uniform(-math.pi, math.pi, tracks)
    own_radius = rng.uniform(50.0, 230.0, tracks)
    turn = last_turn + rng.uniform(-0.12, 0.12)
    moved = own_azimuth[:blobs] + turn + np.round(rng.normal(0.0, 0.004, min(blobs, tracks)), 3)
    azimuth = wrap_angle(np.concatenate([moved, rng.uniform(-math.pi, math.pi,
                                                            blobs - moved.size)]))
    radius = np.concatenate([own_radius[:moved.size] + rng.normal(0.0, 3.0, moved.size),
                             rng.uniform(50.0, 230.0, blobs - moved.size)])
    expected = numpy_common_turn(azimuth, radius, own_azimuth, own_radius, last_turn, 8.0, 0.1)
    found = common_turn(azimuth, radius, own_azimuth, own_radius, last_turn, 8.0, 0.1,
                        TURN_WINDOW, TURN_SUPPORT)
    assert found == expected


def test_a_shift_exactly_one_window_away_is_inside_the_window():
    # one track at azimuth 0, two blobs at shifts x and x + TURN_WINDOW: one window holds both
    # (its end is inclusive, as numpy's searchsorted(side="right") counts), so the turn is
    # their mean; an exclusive end would find no window of TURN_SUPPORT shifts
    x = 0.01
    azimuth = np.array([x, x + TURN_WINDOW])
    turn = common_turn(azimuth, np.full(2, 100.0), np.zeros(1), np.full(1, 100.0), 0.0, 8.0,
                       0.1, TURN_WINDOW, TURN_SUPPORT)
    assert turn == (x + (x + TURN_WINDOW)) / 2.0
    assert turn == numpy_common_turn(azimuth, np.full(2, 100.0), np.zeros(1), np.full(1, 100.0),
                                     0.0, 8.0, 0.1)
