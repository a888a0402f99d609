"""MapAnswer: every malformed answer refused by its field, and the updated map's rule."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from azgym.core import BeaconMap
from azgym.errors import InvalidInputError
from azgym.mapping.base import MapAnswer, map_answer

COV = np.eye(2) * 1e-4


def _answer(**change):
    given = {"ids": np.array([3, 1]), "xy": np.array([[1.0, 2.0], [3.0, 4.0]]),
             "covariances": np.stack([COV, COV]), "moved": (3,)}
    return MapAnswer(**{**given, **change})


@pytest.mark.parametrize(("change", "message"), [
    ({"ids": np.array([[3, 1]])}, "ids must be a 1-D array"),
    ({"ids": np.array([3.0, 1.0])}, "ids must be a 1-D array"),
    ({"ids": np.array([3, 3]), "moved": ()}, "repeat an id"),
    ({"xy": np.zeros((3, 2))}, "xy must have shape (2, 2)"),
    ({"xy": np.array([[np.nan, 0.0], [0.0, 0.0]])}, "NaN or infinite"),
    ({"covariances": np.stack([COV])}, "covariances must have shape (2, 2, 2)"),
    ({"covariances": np.stack([COV, [[1e-4, 1e-5], [0.0, 1e-4]]])}, "finite and symmetric"),
    ({"covariances": np.stack([COV, -COV])}, "positive definite"),
    ({"covariances": np.stack([COV, np.zeros((2, 2))])}, "positive definite"),
    ({"moved": (7,)}, "does not place: [7]"),
    ({"moved": itertools.count()}, "tuple or list of at most 2"),
    ({"moved": (1, 3, 3)}, "tuple or list of at most 2"),
    ({"moved": ("3",)}, "integer ids"),
    ({"moved": (True,)}, "integer ids"),
])
def test_a_malformed_answer_is_refused_by_its_field(change, message):
    with pytest.raises(InvalidInputError, match="MapAnswer") as caught:
        _answer(**change)
    assert message in str(caught.value)


def test_an_answer_is_stored_as_float_arrays_with_moved_sorted():
    answer = map_answer([3, 1, 2], [[0, 0], [1, 1], [2, 2]], np.stack([COV] * 3), [3, np.int64(1)])
    assert answer.moved == (1, 3) and answer.ids.dtype == np.int64
    assert answer.xy.dtype == np.float64 and answer.covariances.shape == (3, 2, 2)


def test_the_updated_map_is_the_prior_where_nothing_is_placed_and_the_answer_where_it_is():
    prior = BeaconMap(np.array([1, 2]), np.array([[0.0, 0.0, 2.5], [5.0, 0.0, 3.0]]),
                      np.array([0.05, 0.07]))
    updated = _answer().updated(prior)
    assert updated.ids.tolist() == [1, 2, 3]
    # 1 placed: its new x, y, the prior's height and width; 2 kept; 3 new: z 0, default width
    np.testing.assert_array_equal(updated.xyz, [[3.0, 4.0, 2.5], [5.0, 0.0, 3.0],
                                                [1.0, 2.0, 0.0]])
    np.testing.assert_array_equal(updated.width, [0.05, 0.07, 0.03])
    nothing = map_answer([], np.zeros((0, 2)), np.zeros((0, 2, 2)))
    assert nothing.updated(prior).ids.tolist() == [1, 2]
    np.testing.assert_array_equal(nothing.updated(prior).xyz, prior.xyz)
    assert _answer().updated(None).ids.tolist() == [1, 3]
