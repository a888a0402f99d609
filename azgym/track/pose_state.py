"""The trackers' pose state ``[x, y, φ, b, k]`` and its compiled covariance step.

The state of :mod:`azgym.track.unicycle`'s motion model (and of the trackers built on it): the
camera position [m], heading [rad], the turn rate's bias b [rad/s] and the odometry's scale
correction k [1] (the true speed is (1 + k) times the read). A tracker may keep more entries after
these (the beacons :mod:`azgym.track.repair` keeps in its state). :func:`move_covariance` moves
the covariance through one step's Jacobian in place.
"""

from __future__ import annotations

from azgym.jit import jit

__all__ = ["IBIAS", "IPHI", "ISCALE", "IX", "IY", "STATE_SIZE", "move_covariance"]

STATE_SIZE = 5
"""Length of the state ``[x, y, φ, b, k]``: camera position [m], heading [rad], gyro bias
[rad/s] and the odometry's scale correction k [1] (the true speed is (1 + k) times the read)."""
IX, IY, IPHI, IBIAS, ISCALE = range(STATE_SIZE)
"""Positions of x, y, heading, gyro bias and odometry scale correction in the state."""


@jit
def move_covariance(cov, x_phi, y_phi, x_bias, y_bias, phi_bias, x_scale, y_scale):
    """Set cov ← J cov Jᵀ in place, J the step's Jacobian: the identity and seven entries given.

    J's other entries are those of the identity (beacons kept in the state stand still), so
    only the rows, then the columns, of x, y and φ change: a few hundred operations, not a
    dense product of (5 + 2m)² matrices.
    """
    n = cov.shape[0]
    for j in range(n):  # J cov: rows x and y take the old row φ, so φ's row changes last
        phi, bias, scale = cov[IPHI, j], cov[IBIAS, j], cov[ISCALE, j]
        cov[IX, j] = cov[IX, j] + x_phi * phi + x_bias * bias + x_scale * scale
        cov[IY, j] = cov[IY, j] + y_phi * phi + y_bias * bias + y_scale * scale
        cov[IPHI, j] = cov[IPHI, j] + phi_bias * bias
    for i in range(n):  # then (J cov) Jᵀ, by columns alike
        phi, bias, scale = cov[i, IPHI], cov[i, IBIAS], cov[i, ISCALE]
        cov[i, IX] = cov[i, IX] + x_phi * phi + x_bias * bias + x_scale * scale
        cov[i, IY] = cov[i, IY] + y_phi * phi + y_bias * bias + y_scale * scale
        cov[i, IPHI] = cov[i, IPHI] + phi_bias * bias
