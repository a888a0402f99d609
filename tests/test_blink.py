"""Blinking ids: the code, its decoder, the blob tracker, and the image path on a route."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from azgym.errors import InvalidInputError
from azgym.sensing.blink import MARKER, BlinkCode, BlobTracker

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


def test_the_image_path_decodes_ids_on_a_warehouse_route():
    from azgym.study.identification import measure_identification

    stats = measure_identification("warehouse-small", camera_rate_hz=30.0,
                                   routes=["pick-and-back"])
    assert stats.eligible > 1000
    assert stats.correct_share >= 0.99
    assert stats.misdecode_rate <= 0.01
