"""truth_at: truth on its own clock put onto the frames, interpolated and never extrapolated."""

from __future__ import annotations

import math

import numpy as np
import pytest

from azgym.errors import InvalidInputError
from azgym.logs.truth import MAX_GAP, truth_at

STAMPS = np.array([0.0, 0.1, 0.2, 0.3])
X, Y = np.array([0.0, 1.0, 2.0, 3.0]), np.array([5.0, 5.0, 6.0, 6.0])
HEADING = np.array([3.0, -3.0, 0.25, 0.5])


def test_a_frame_at_a_sample_gets_it_bit_for_bit_and_others_lie_between():
    frames = np.array([0.0, 0.05, 0.1, 0.2, 0.25, 0.3])
    x, y, heading = truth_at(frames, STAMPS, X, Y, HEADING, source="s")
    assert x[[0, 2, 3, 5]].tolist() == [0.0, 1.0, 2.0, 3.0]
    assert math.isclose(x[1], 0.5) and math.isclose(y[4], 6.0) and math.isclose(x[4], 2.5)
    assert heading[0] == 3.0 and heading[2] == -3.0 and heading[5] == 0.5
    assert math.isclose(abs(heading[1]), math.pi)  # 3.0 to -3.0: across ±π, the shorter arc
    assert math.isclose(heading[4], 0.375)


def test_position_only_truth_gives_no_heading():
    x, y, heading = truth_at(np.array([0.15]), STAMPS, X, Y, None, source="s")
    assert heading is None and math.isclose(x[0], 1.5) and math.isclose(y[0], 5.5)


@pytest.mark.parametrize(("frames", "stamps", "problem"), [
    ([-0.01], STAMPS, r"frame 0 \(time -0.01 s\) lies outside the truth samples' span"),
    ([0.31], STAMPS, "lies outside"),
    ([0.5], np.array([0.0, 0.2, 0.9, 1.0]), "lies in a 0.700 s gap between truth samples 1 and 2"),
    ([0.1], np.array([0.0, 0.2, 0.2, 0.3]), r"sample 2: time 0.2 s is not after"),
    ([0.1], np.array([0.0, math.nan, 0.2, 0.3]), "sample 1: time nan is not finite"),
])
def test_frames_the_samples_do_not_cover_are_refused_naming_source_and_frame(frames, stamps,
                                                                            problem):
    with pytest.raises(InvalidInputError, match=problem) as refused:
        truth_at(np.array(frames), stamps, X, Y, HEADING, source="topic /mocap")
    assert str(refused.value).startswith("topic /mocap: ")


def test_frame_numbers_name_the_frames_and_the_gap_is_an_option():
    assert MAX_GAP == 0.5
    with pytest.raises(InvalidInputError, match="frame 42 "):
        truth_at(np.array([0.5]), np.array([0.0, 1.0]), X[:2], Y[:2], None, source="s",
                 numbers=np.array([42]))
    x, _, _ = truth_at(np.array([0.5]), np.array([0.0, 1.0]), X[:2], Y[:2], None, source="s",
                       max_gap=1.0)
    assert x[0] == 0.5
    with pytest.raises(InvalidInputError, match="max_gap"):
        truth_at(np.array([0.5]), np.array([0.0, 1.0]), X[:2], Y[:2], None, source="s",
                 max_gap=-1.0)
    with pytest.raises(InvalidInputError, match="sample 1: x inf is not finite"):
        truth_at(np.array([0.0]), STAMPS, np.array([0.0, math.inf, 0.0, 0.0]), Y, None,
                 source="s")
