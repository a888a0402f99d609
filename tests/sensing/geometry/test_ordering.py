"""The sensor's insertion sort orders exactly as numpy's stable sort."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from azgym.sensing.geometry.ordering import stable_order


@settings(derandomize=True, max_examples=300, deadline=None)  # (the first call may compile)
@given(st.lists(st.sampled_from([-1.5, -0.0, 0.0, 0.25, 3.0, np.pi]) | st.floats(-4, 4),
                max_size=40), st.integers(0, 40))
def test_stable_order_is_numpys_stable_argsort(values, count):
    values = np.array(values + [9.0] * 40)  # values past count must not matter
    count = min(count, len(values))
    expected = np.argsort(values[:count], kind="stable")
    assert np.array_equal(stable_order(values, count), expected)
