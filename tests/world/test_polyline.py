"""The drivers' polyline kernels: hand-worked cases, and the expressions they replace to the bit."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from azgym.world._polyline import nearest_on_legs, point_at

L_ROUTE = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 3.0]])
"""Two legs: 4 m east, then 3 m north."""
L_LENGTHS = np.array([4.0, 3.0])


def numpy_nearest(points: np.ndarray, lengths: np.ndarray, first: int, stop: int, x: float,
                  y: float) -> tuple[int, float]:
    """The expression the drivers computed with numpy before the kernel (its reference)."""
    a = points[first:stop]
    ab = points[first + 1:stop + 1] - a
    p = np.array([x, y])
    t = np.clip(np.einsum("ij,ij->i", p - a, ab) / np.maximum(lengths[first:stop] ** 2, 1e-300),
                0.0, 1.0)
    nearest = int(np.argmin(np.hypot(*(a + t[:, None] * ab - p).T)))
    return first + nearest, float(t[nearest])


def test_a_point_beside_a_leg_projects_onto_it_and_one_past_the_end_clamps():
    assert nearest_on_legs(L_ROUTE, L_LENGTHS, 0, 2, 1.0, -2.0) == (0, 0.25)
    assert nearest_on_legs(L_ROUTE, L_LENGTHS, 0, 2, 5.0, 1.5) == (1, 0.5)
    assert nearest_on_legs(L_ROUTE, L_LENGTHS, 0, 2, 4.0, 9.0) == (1, 1.0)  # beyond the end
    assert nearest_on_legs(L_ROUTE, L_LENGTHS, 0, 2, -1.0, -1.0) == (0, 0.0)  # before the start


def test_a_tie_goes_to_the_first_leg_and_only_the_window_is_searched():
    # (5, -1) is 1 m from the corner (4, 0) on both legs: the first leg wins, as argmin's.
    assert nearest_on_legs(L_ROUTE, L_LENGTHS, 0, 2, 5.0, -1.0) == (0, 1.0)
    # Searching the second leg alone finds its start, though the first leg is nearer.
    assert nearest_on_legs(L_ROUTE, L_LENGTHS, 1, 2, 2.0, -1.0) == (1, 0.0)
    leg, t = nearest_on_legs(L_ROUTE, L_LENGTHS, 1, 1, 2.0, -1.0)  # no leg to search
    assert leg == -1 and math.isnan(t)


def test_a_leg_of_no_length_is_its_point():
    points = np.array([[1.0, 1.0], [1.0, 1.0], [3.0, 1.0]])
    assert nearest_on_legs(points, np.array([0.0, 2.0]), 0, 2, 1.0, 5.0) == (0, 0.0)


coordinate = st.floats(-1e3, 1e3, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(coordinate, coordinate), min_size=2, max_size=12), coordinate,
       coordinate, st.data())
def test_the_kernel_is_numpys_expression_to_the_last_bit(waypoints, x, y, data):
    points = np.array(waypoints)
    lengths = np.hypot(*np.diff(points, axis=0).T)
    first = data.draw(st.integers(0, lengths.size - 1))
    stop = data.draw(st.integers(first + 1, lengths.size))
    leg, t = nearest_on_legs(points, lengths, first, stop, x, y)
    expected_leg, expected_t = numpy_nearest(points, lengths, first, stop, x, y)
    assert (leg, t) == (expected_leg, expected_t)  # (numpy's clip gives 0 either sign)
    # ... and the arc length the forklift's driver makes of it, to the bit
    arc, expected_arc = (lengths[:k].sum() + fraction * lengths[k]
                         for k, fraction in ((leg, t), (expected_leg, expected_t)))
    assert arc.tobytes() == expected_arc.tobytes()


def python_point_at(points: np.ndarray, lengths: np.ndarray, s: float) -> np.ndarray:
    """The loop the drivers ran in Python before the kernel (its reference)."""
    for k, length in enumerate(lengths):
        if s <= length or k == len(lengths) - 1:
            t = 0.0 if length == 0 else min(s / length, 1.0)
            return points[k] + t * (points[k + 1] - points[k])
        s -= length
    return points[-1]


def test_the_point_at_a_distance_along_the_route():
    assert point_at(L_ROUTE, L_LENGTHS, 1.0) == (1.0, 0.0)
    assert point_at(L_ROUTE, L_LENGTHS, 5.5) == (4.0, 1.5)  # 1.5 m into the second leg
    assert point_at(L_ROUTE, L_LENGTHS, 9.0) == (4.0, 3.0)  # past the end: the end
    assert point_at(L_ROUTE, L_LENGTHS, 4.0) == (4.0, 0.0)  # the corner, from the first leg


@settings(max_examples=300, deadline=None)
@given(st.lists(st.tuples(coordinate, coordinate), min_size=2, max_size=12),
       st.floats(-10.0, 3e3, allow_nan=False))
def test_point_at_is_the_python_loop_to_the_last_bit(waypoints, s):
    points = np.array(waypoints)
    lengths = np.hypot(*np.diff(points, axis=0).T)
    assert np.array(point_at(points, lengths, s)).tobytes() == \
        python_point_at(points, lengths, s).tobytes()
