"""The Monte Carlo check agrees with the prediction where the localizer is efficient."""

from __future__ import annotations

import numpy as np

from azgym.layout.analysis import agreement, predict
from azgym.layout.floor import floor_grid
from azgym.layout.monte_carlo import monte_carlo


def test_ransac_matches_the_predicted_sigma_on_the_paper_room(paper_room):
    floor = floor_grid(paper_room, 7.0)  # 4 x 4 cells, from a corner to the middle
    prediction = predict(paper_room, floor)
    checked = monte_carlo(paper_room, floor.points, prediction.seen, "ransac", 400, seed=5)
    ratio = checked.rms / prediction.sigma
    assert np.all(np.abs(ratio - 1) < 0.1), ratio  # 400 frames: ~3 % sampling error
    assert np.all(checked.bias < 0.3 * checked.rms)
    figures = agreement(prediction.sigma, checked)
    assert figures["cells_compared"] == 16 and figures["failed_share"] == 0.0


def test_cells_seeing_under_three_beacons_are_not_run(paper_room):
    floor = floor_grid(paper_room, 7.0)
    seen = np.zeros((len(floor.points), 12), dtype=bool)
    seen[:, :2] = True
    checked = monte_carlo(paper_room, floor.points, seen, "ransac", 3)
    assert np.isnan(checked.rms).all() and (checked.failed == 1.0).all()


def test_the_draws_are_the_seeds(paper_room):
    floor = floor_grid(paper_room, 10.0)
    seen = predict(paper_room, floor).seen
    first = monte_carlo(paper_room, floor.points, seen, "lsq", 5, seed=1)
    again = monte_carlo(paper_room, floor.points, seen, "lsq", 5, seed=1)
    other = monte_carlo(paper_room, floor.points, seen, "lsq", 5, seed=2)
    np.testing.assert_array_equal(first.rms, again.rms)
    assert not np.allclose(first.rms, other.rms)
