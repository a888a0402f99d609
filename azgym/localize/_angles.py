"""Angle arithmetic for the compiled loops: atan2 without libm, and small angles in one division.

The localizers measure every residual as the angle between two direction vectors, ``atan2(cross,
dot)``, which needs no wrapping: the residual ε_i of eq. 23/30 is the signed angle from the
predicted world direction of beacon i to its measured world direction α_i + φ. These are the
hottest calls in ransac's scoring, the refinement and mex's grid, so they get their own cheaper
forms here: :func:`fast_atan2` (Cephes' rational approximation, a few ulp) and
:func:`small_angle` (atan's Taylor series for the residuals of inliers, a few degrees at most).
Both are inlined into their callers (``inline="always"``).
"""

from __future__ import annotations

import math

import numpy as np

from azgym.jit import jit

HALF_PI = 0.5 * math.pi
QUARTER_PI = 0.25 * math.pi
TAN_PI_8 = math.tan(math.pi / 8.0)

SMALL_ANGLE_TAN = 0.1
"""|tan ε| up to which :func:`small_angle` sums atan's Taylor series instead of calling atan2.

At |u| = 0.1 (5.7°) the series to u¹⁷ is exact to 1e-18 rad: as accurate as
:func:`fast_atan2`, and cheaper (one division). Residuals of inliers are far inside this range.
"""


@jit(inline="always")
def fast_atan2(y: float, x: float) -> float:
    """atan2 accurate to a few ulp (Cephes' rational approximation), cheaper than libm's.

    The argument is reduced to [0, tan(π/8)] with at most one division; the remaining rational
    P(z)/Q(z) is Cephes' ``atan.c`` minimax fit. Max error against numpy: 4.5e-16 rad.
    """
    ax = abs(x)
    ay = abs(y)
    mx = max(ax, ay)
    mn = min(ax, ay)
    big = mn > TAN_PI_8 * mx
    num = mn - mx if big else mn
    den = mn + mx if big else mx
    if den == 0.0:
        den = 1.0
    t = num / den
    z = t * t
    p = (
        (
            ((-8.750608600031904122785e-1 * z - 1.615753718733365076637e1) * z
             - 7.500855792314704667340e1) * z
            - 1.228866684490136173410e2
        ) * z
        - 6.485021904942025371773e1
    )
    q = (
        (
            (((z + 2.485846490142306297962e1) * z + 1.650270098316988542046e2) * z
             + 4.328810604912902668951e2) * z
            + 4.853903996359136964868e2
        ) * z
        + 1.945506571482613964425e2
    )
    r = t + t * z * p / q
    if big:
        r += QUARTER_PI
    if ay > ax:
        r = HALF_PI - r
    if x < 0.0:
        r = math.pi - r
    return -r if y < 0.0 else r


@jit(inline="always")
def small_angle(cross: float, dot: float) -> float:
    """atan2(cross, dot) for a direction within a few degrees of ``dot``'s: one division.

    For |u| = |cross/dot| <= SMALL_ANGLE_TAN (5.7°) the Taylor series of atan to u¹⁷ is exact to
    1e-18; wider angles go through :func:`fast_atan2`.
    """
    if dot > 0.0 and abs(cross) <= SMALL_ANGLE_TAN * dot:
        u = cross / dot
        z = u * u
        return u * (1.0 + z * (-1.0 / 3.0 + z * (1.0 / 5.0 + z * (-1.0 / 7.0 + z * (
            1.0 / 9.0 + z * (-1.0 / 11.0 + z * (1.0 / 13.0 + z * (-1.0 / 15.0 + z / 17.0))))))))
    return fast_atan2(cross, dot)


@jit
def azimuth_spread(azimuth):
    """The narrowest arc holding every azimuth [rad]: 2π minus the widest gap between them.

    A camera sees beacons on every side (a spread of π or more) only from inside their convex
    hull; a narrower spread is a view to one side, from inside or outside it.
    """
    k = azimuth.size
    if k < 2:
        return 0.0
    wrapped = np.sort(np.mod(azimuth, 2.0 * math.pi))
    widest = wrapped[0] + 2.0 * math.pi - wrapped[k - 1]
    for u in range(1, k):
        widest = max(widest, wrapped[u] - wrapped[u - 1])
    return 2.0 * math.pi - widest
