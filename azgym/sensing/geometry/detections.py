"""The list of a frame's detections before noise: its rows and the one writer of an entry.

A frame passes through two kernels (:mod:`azgym.sensing.geometry.frame`). The first,
:func:`~azgym.sensing.geometry.frame.collect`, lists every detection — the direct views
(:mod:`azgym.sensing.geometry.direct`), then the mirror images
(:mod:`azgym.sensing.geometry.mirrors`) — into two packed arrays, one float and one integer, whose
rows are named here (``FOUND_*``); the second turns them into the camera's measurements. The rows
and :func:`list_detection` live apart from both views so that each view writes the same entries
without importing the other or the frame assembly.
"""

from __future__ import annotations

from azgym.jit import jit

__all__ = ["FOUND_AZIMUTH", "FOUND_BEACON", "FOUND_BRIGHTNESS", "FOUND_ELEVATION",
           "FOUND_FLOAT_ROWS", "FOUND_HALF_WIDTH", "FOUND_INT_ROWS", "FOUND_LABEL", "FOUND_VISIBLE",
           "list_detection"]

# Rows of the detections ``frame.collect`` lists, before noise (``found`` floats, ``found_ints``).
FOUND_AZIMUTH = 0
"""Azimuth in the world frame [rad]."""
FOUND_ELEVATION = 1
"""Elevation above the horizon [rad]."""
FOUND_VISIBLE = 2
"""Visible share of the beacon's width (1 for a ghost)."""
FOUND_BRIGHTNESS = 3
"""Received flux over the detection threshold (>= 1)."""
FOUND_HALF_WIDTH = 4
"""Angular half-width of the whole beacon [rad]."""
FOUND_FLOAT_ROWS = 5
"""Rows of ``found``."""
FOUND_BEACON = 0
"""Map row of the beacon."""
FOUND_LABEL = 1
"""Cause of the detection (:mod:`azgym.sensing.labels`)."""
FOUND_INT_ROWS = 2
"""Rows of ``found_ints``."""


@jit(inline="always")
def list_detection(found, found_ints, k, azimuth, elevation, visible, brightness, half_width,
                   beacon, label):
    """Write detection ``k`` into the packed arrays of ``collect`` (rows ``FOUND_*``)."""
    found[FOUND_AZIMUTH, k] = azimuth
    found[FOUND_ELEVATION, k] = elevation
    found[FOUND_VISIBLE, k] = visible
    found[FOUND_BRIGHTNESS, k] = brightness
    found[FOUND_HALF_WIDTH, k] = half_width
    found_ints[FOUND_BEACON, k] = beacon
    found_ints[FOUND_LABEL, k] = label
