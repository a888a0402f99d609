"""Frames that used to get a confident wrong answer, and now get ``ok=False`` with a reason.

Each was found by a search over random scenes with the paper's azimuth errors (uniform within
Δα_d = 0.4°); the mex cases are in test_mex.py, the noise-free ones in test_properties.py.
"""

from __future__ import annotations

import numpy as np
import pytest
from helpers import beacon_map, pose_error_of

from azgym import Measurements
from azgym.localize.lsq import LeastSquares
from azgym.localize.ransac import Ransac
from azgym.localize.triplet import DEGENERACY_TOL, Triplet

# Three beacons seen from 12 m with azimuth errors of at most 0.4°: the triplet's normalised
# determinant is 1e-3 (conditioning 1e-6), and its answer 10 m off.
ILL_CONDITIONED = (
    beacon_map([(4.2439581324563616, 6.546869023848803), (-5.583003550770952, 6.934710276918857),
                (-7.917138146953086, 4.047640057564063)]),
    [1.3282145697327268, 1.9666686985246276, 2.1816644979121818],
    (4.968429285075922, -5.8117751753186955, 0.3),
)


def test_an_ill_conditioned_triplet_is_refused():
    beacons, azimuth, pose = ILL_CONDITIONED
    frame = Measurements(beacons.ids, azimuth)
    old = Triplet(degeneracy_tol=1e-9).localize(frame, beacons)  # the old default
    assert old.ok and pose_error_of(old, *pose)[0] > 10.0
    assert old.diagnostics["conditioning"] < DEGENERACY_TOL**2
    estimate = Triplet().localize(frame, beacons)
    assert not estimate.ok
    assert "every triplet is degenerate or ill-conditioned" in estimate.reason
    assert "degeneracy_tol=0.01" in estimate.reason


# Four beacons, the camera on the circle through three of them, azimuth errors of a few mrad:
# Levenberg-Marquardt crawls along the valley the danger circle leaves in the cost.
DANGER_CIRCLE = (
    beacon_map([(0.5711091883043631, 3.266542406227309),
                (4.047860193011928, -3.6872587041641847),
                (-3.7656686228615466, -2.382956706839361),
                (3.4328687526771446, -4.061495858603257)]),
    [0.6225761194780662, -0.45111948585291056, 1.571397508680659, -0.51763999616806],
    (-3.7293101515140794, -2.5000823548117745, 0.3),
)


@pytest.mark.parametrize("cls", [LeastSquares, Ransac])
def test_a_refinement_that_did_not_converge_is_refused(cls):
    beacons, azimuth, pose = DANGER_CIRCLE
    frame = Measurements(beacons.ids, azimuth)
    estimate = cls().localize(frame, beacons)
    assert not estimate.ok
    assert "the refinement did not converge in 50 iterations" in estimate.reason
    assert estimate.diagnostics["converged"] is False
    assert np.isnan(estimate.x)
    # Given the iterations it needs, the same refinement converges and is answered.
    patient = cls(max_iter=1000).localize(frame, beacons)
    assert patient.ok and patient.diagnostics["converged"]
    assert pose_error_of(patient, *pose)[0] < 0.02
