"""A camera frame from the geometry: every detection collected, then finished into measurements.

A frame passes through two kernels, each writing packed arrays (one float and one integer array,
so that the sensor hands them over whole). :func:`collect` lists the frame's detections — the
direct views with partial occlusion (:mod:`azgym.sensing.geometry.direct`), then the mirror
images (:mod:`azgym.sensing.geometry.mirrors`) — in the rows ``FOUND_*`` of
:mod:`azgym.sensing.geometry.detections`. :func:`finish_frame` turns them into the camera's
measurements: camera-frame azimuths, noise and misread ids, sorted by azimuth and padded, in the
rows ``FRAME_*`` defined here, which :class:`~azgym.sensing.geometry.sensor.FrameBuffers` reads.
"""

from __future__ import annotations

import math

import numpy as np

from azgym.jit import jit, wrap_compiled
from azgym.sensing.geometry.detections import (
    FOUND_AZIMUTH,
    FOUND_BEACON,
    FOUND_BRIGHTNESS,
    FOUND_ELEVATION,
    FOUND_HALF_WIDTH,
    FOUND_LABEL,
    FOUND_VISIBLE,
)
from azgym.sensing.geometry.direct import direct_view
from azgym.sensing.geometry.mirrors import mirror_view
from azgym.sensing.geometry.ordering import stable_order
from azgym.sensing.identities import misread_row
from azgym.sensing.labels import GHOST, MISIDENTIFIED
from azgym.sensing.protocol import AZIMUTH, BEACON, ID, LABEL, MIRRORED, TRUE_AZIMUTH, VISIBLE

__all__ = ["FRAME_AZIMUTH", "FRAME_BEACON", "FRAME_ELEVATION", "FRAME_FLOAT_ROWS",
           "FRAME_HALF_WIDTH", "FRAME_ID", "FRAME_INT_ROWS", "FRAME_LABEL", "FRAME_MIRRORED",
           "FRAME_QUALITY", "FRAME_TRUE_AZIMUTH", "FRAME_VISIBLE", "collect", "finish_frame"]

# Rows of a finished frame, sorted by measured azimuth (``FrameBuffers.floats`` and ``.ints``).
# They are laid out as an Observation's packed arrays (azgym.sensing.protocol): rows 0-1 are its
# ``measured``, rows 2-3 its ``true``, and the int rows its ``ints``, so that a frame becomes an
# observation by copying row blocks, not by rearranging them.
FRAME_AZIMUTH = AZIMUTH
"""Measured azimuth in the camera frame [rad]."""
FRAME_QUALITY = AZIMUTH + 1
"""log10 of the brightness over the detection threshold (>= 0)."""
FRAME_TRUE_AZIMUTH = 2 + TRUE_AZIMUTH
"""Noise-free azimuth in the camera frame [rad]."""
FRAME_VISIBLE = 2 + VISIBLE
"""Visible share of the beacon's width."""
FRAME_ELEVATION = 4
"""Elevation above the horizon [rad]."""
FRAME_HALF_WIDTH = 5
"""Angular half-width of the whole beacon [rad]."""
FRAME_FLOAT_ROWS = 6
"""Rows of ``FrameBuffers.floats``."""
FRAME_ID = ID
"""Decoded id, −1 for padding."""
FRAME_BEACON = BEACON
"""Map row of the true beacon."""
FRAME_LABEL = LABEL
"""Cause of the detection."""
FRAME_MIRRORED = MIRRORED
"""1 for a mirror image, else 0."""
FRAME_INT_ROWS = 4
"""Rows of ``FrameBuffers.ints``."""


@jit
def collect(eye, lens, beacon_xyz, beacon_width, moved, seg, found, found_ints):
    """Every detection of a frame before noise: direct (or partial, or moved) views, then ghosts.

    Args:
        eye: The camera's position (x, y, z) [m].
        lens: (min_elevation [rad], max_range [m]): the lowest and farthest light it sees.
        beacon_xyz: Where each beacon really is, shape (N, 3) [m].
        beacon_width: Each beacon's width W, shape (N,) [m].
        moved: Whether each beacon was moved after the map was made (label MOVED), shape (N,).
        seg: The occluders, rows of ``SEG_*`` columns (see ``occluder_table``).
        found: Filled with the detections' rows ``FOUND_*``: the azimuth in the world frame,
            elevation, visible share, brightness (received flux over the detection threshold,
            >= 1: the visible share over the squared 3-D distance, times the reflectivity for a
            ghost) and the beacon's angular half-width; shape (FOUND_FLOAT_ROWS, capacity).
        found_ints: Filled with the map row and label of each, shape (FOUND_INT_ROWS, capacity).

    Returns:
        The number of detections M: the direct views (:func:`direct_view`) in map order, then
        the ghosts (:func:`mirror_view`).
    """
    count = direct_view(eye, lens, beacon_xyz, beacon_width, moved, seg, found, found_ints)
    return mirror_view(eye, lens, beacon_xyz, beacon_width, seg, found, found_ints, count)


@jit(inline="always")
def _level_azimuth(azimuth, elevation, pitch, roll):
    """The azimuth a camera tilted by (pitch, roll) sees the direction (elevation, azimuth) at.

    Pitch and roll are right-handed rotations of the camera about its y- and x-axes: the camera
    sees R_y(pitch)ᵀ R_x(roll)ᵀ d for d = (cos e cos α, cos e sin α, sin e).
    """
    cp, sp = math.cos(pitch), math.sin(pitch)
    cr, sr = math.cos(roll), math.sin(roll)
    ce = math.cos(elevation)
    dx, dy, dz = ce * math.cos(azimuth), ce * math.sin(azimuth), math.sin(elevation)
    dy, dz = cr * dy + sr * dz, -sr * dy + cr * dz  # undo the roll
    dx = cp * dx - sp * dz  # undo the pitch (only x matters for the azimuth)
    return math.atan2(dy, dx)


@jit(inline="always")
def _write_frame(out_floats, out_ints, order, measured, true_azimuth, ids, mirrored, found,
                 found_ints):
    """Write the detections of ``found`` into the frame (rows ``FRAME_*``) in ``order``.

    Entry k of the frame is detection ``order[k]``, as far as the frame reaches. ``measured``,
    ``true_azimuth``, ``ids`` and ``mirrored`` are per detection, like ``found``.
    """
    for k in range(min(order.size, out_floats.shape[1])):
        m = order[k]
        out_floats[FRAME_AZIMUTH, k] = measured[m]
        out_floats[FRAME_QUALITY, k] = math.log10(found[FOUND_BRIGHTNESS, m])
        out_floats[FRAME_TRUE_AZIMUTH, k] = true_azimuth[m]
        out_floats[FRAME_VISIBLE, k] = found[FOUND_VISIBLE, m]
        out_floats[FRAME_ELEVATION, k] = found[FOUND_ELEVATION, m]
        out_floats[FRAME_HALF_WIDTH, k] = found[FOUND_HALF_WIDTH, m]
        out_ints[FRAME_ID, k] = ids[m]
        out_ints[FRAME_BEACON, k] = found_ints[FOUND_BEACON, m]
        out_ints[FRAME_LABEL, k] = found_ints[FOUND_LABEL, m]
        out_ints[FRAME_MIRRORED, k] = mirrored[m]


@jit(inline="always")
def _pad_frame(out_floats, out_ints, start):
    """Pad the frame from entry ``start`` on: id, beacon and label −1, everything else 0."""
    for k in range(start, out_floats.shape[1]):
        for row in range(FRAME_FLOAT_ROWS):
            out_floats[row, k] = 0.0
        out_ints[FRAME_ID, k] = -1
        out_ints[FRAME_BEACON, k] = -1
        out_ints[FRAME_LABEL, k] = -1
        out_ints[FRAME_MIRRORED, k] = 0


@jit
def finish_frame(found, found_ints, count, heading, tilt, uniforms, delta_d, misdecode_rate,
                 map_ids, out_floats, out_ints):
    """Camera-frame azimuths, eq. 1 noise and misread ids, listed by measured azimuth.

    Takes the first ``count`` detections :func:`collect` listed in ``found`` and ``found_ints``
    and writes them into ``out_floats`` and ``out_ints`` (rows ``FRAME_*``), sorted by measured
    azimuth. The outputs may be longer than M = ``count`` (fixed-size observations): the rest is
    padded with id −1, beacon −1, label −1 and zeros; if they are shorter, the detections with the
    largest azimuths are left out. A misread detection's label becomes MISIDENTIFIED in
    ``found_ints`` too.

    A tilted camera (``tilt`` = (pitch, roll)) sees each direction rotated
    (:func:`_level_azimuth`) — the perturbation the paper describes on its bumpy stretch.
    ``uniforms`` (3, M) in [0, 1): the noise (uniform on ±``delta_d``), whether the id is
    misread (at ``misdecode_rate``), and which other map id it is read as (:func:`misread_row`).
    """
    n_map = map_ids.size
    pitch, roll = tilt
    tilted = pitch != 0.0 or roll != 0.0
    beacon, label = found_ints[FOUND_BEACON], found_ints[FOUND_LABEL]
    true_azimuth = np.empty(count)
    measured = np.empty(count)
    ids = np.empty(count, dtype=np.int64)
    mirrored = np.empty(count, dtype=np.int64)
    for m in range(count):
        a = found[FOUND_AZIMUTH, m] - heading
        if tilted:
            a = _level_azimuth(a, found[FOUND_ELEVATION, m], pitch, roll)
        true_azimuth[m] = wrap_compiled(a)
        measured[m] = wrap_compiled(true_azimuth[m] + (2.0 * uniforms[0, m] - 1.0) * delta_d)
        ids[m] = map_ids[beacon[m]]
        mirrored[m] = label[m] == GHOST
        if uniforms[1, m] < misdecode_rate and n_map > 1:
            ids[m] = map_ids[misread_row(beacon[m], uniforms[2, m], n_map)]
            label[m] = MISIDENTIFIED
    order = stable_order(measured, measured.size)
    _write_frame(out_floats, out_ints, order, measured, true_azimuth, ids, mirrored, found,
                 found_ints)
    _pad_frame(out_floats, out_ints, count)
