"""The geometry sensor: one camera frame of a scenario, seen from a pose, with ground truth beside.

Faults come from the scene: racks hide beacons (2.5-D line of sight), rack edges cover part of a
beacon (its azimuth moves to the visible part's centroid), reflective faces show mirror ghosts
with the real beacon's id, and beacons moved after the map was made appear where they really
are. Decoding faults (a misread id) come from a rate. On top of all of this, every detection gets
the centre-detection error of eq. 1, uniform on ±Δα_d; the coverage error of eq. 2 is not drawn,
since partial occlusion now produces it. The kernels are in :mod:`azgym.sensing.geometry.frame`
(which calls :mod:`~azgym.sensing.geometry.direct` and :mod:`~azgym.sensing.geometry.mirrors`).

A forward camera (``Camera.field_of_view`` under 2π) keeps the detections whose measured azimuth
is within half its view of the heading: the image's edge cuts where the blob is found. Markers
whose codes the map lacks (``Scenario.unmapped``) are seen like beacons and reported with their
codes; their truth is a distractor's (no map beacon, label DISTRACTOR).
"""

from __future__ import annotations

import numpy as np

from azgym.core import Pose
from azgym.sensing.geometry.detections import FOUND_FLOAT_ROWS, FOUND_INT_ROWS
from azgym.sensing.geometry.frame import (
    FRAME_AZIMUTH,
    FRAME_BEACON,
    FRAME_ELEVATION,
    FRAME_FLOAT_ROWS,
    FRAME_HALF_WIDTH,
    FRAME_ID,
    FRAME_INT_ROWS,
    FRAME_LABEL,
    FRAME_MIRRORED,
    FRAME_QUALITY,
    FRAME_TRUE_AZIMUTH,
    FRAME_VISIBLE,
    collect,
    finish_frame,
)
from azgym.sensing.labels import DISTRACTOR
from azgym.sensing.protocol import (
    LEVEL,
    Observation,
    Seed,
    Tilt,
    check_pose,
)
from azgym.site import Scenario
from azgym.site.elements import SEG_REFLECTIVITY, occluder_table

__all__ = ["FrameBuffers", "GeometrySensor"]


class GeometrySensor:
    """Frames of one scenario's camera, computed from the geometry (a :class:`Sensor`).

    ``Measurements.quality`` is log10 of each detection's brightness over the detection threshold.

    Args:
        scenario: The site (racks, walls, beacons, camera, faults, error model).
    """

    quality_names = ("log_brightness",)
    quality_high = (10.0,)

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        self.frame_rate_hz = scenario.camera.rate_hz
        self._segments = occluder_table(scenario.racks, scenario.walls)
        unmapped = scenario.unmapped
        self._mapped = len(scenario.beacons)
        seen = scenario.beacon_positions if unmapped is None else np.vstack(
            [scenario.beacon_positions, unmapped.xyz])
        self._xyz = np.array(seen, dtype=np.float64, order="C")
        self._xyz.setflags(write=False)  # as the map's: one compiled kernel for every scenario
        self._width = scenario.beacons.width if unmapped is None else np.concatenate(
            [scenario.beacons.width, unmapped.width])
        self._codes = scenario.beacons.ids if unmapped is None else np.concatenate(
            [scenario.beacons.ids, unmapped.ids])
        self._moved = np.zeros(len(self._xyz), dtype=bool)
        self._moved[:self._mapped] = np.any(self._xyz[:self._mapped] != scenario.beacons.xyz,
                                            axis=1)
        camera = scenario.camera
        self._lens = (float(camera.min_elevation), float(camera.max_range))
        self._half_view = None if camera.all_round else 0.5 * camera.field_of_view
        n = len(self._xyz)
        self._capacity = n * (1 + int(np.count_nonzero(self._segments[:, SEG_REFLECTIVITY] > 0)))
        # The detections of a frame before noise, filled by collect (rows FOUND_*).
        self._found = np.empty((FOUND_FLOAT_ROWS, self._capacity))
        self._found_ints = np.empty((FOUND_INT_ROWS, self._capacity), dtype=np.int64)
        self._buffers = FrameBuffers(self._capacity)

    @property
    def capacity(self) -> int:
        """The most detections a frame can have: every beacon, and its mirror in every mirror."""
        return self._capacity

    def new_buffers(self, size: int | None = None) -> FrameBuffers:
        """Arrays for :meth:`observe_into`, ``size`` long (default: :attr:`capacity`)."""
        return FrameBuffers(self.capacity if size is None else size)

    def reset(self, seed: Seed = None) -> None:
        """Nothing to forget or seed: every frame's draws come from ``observe``'s generator."""

    def observe_into(
        self, pose: Pose, rng: np.random.Generator, out: FrameBuffers, tilt: Tilt = LEVEL,
        camera_height: float | None = None, misdecode_rate: float | None = None,
    ) -> int:
        """Like :meth:`observe`, into preallocated arrays; returns the number of detections M.

        Entries past M are padded (id −1). If a frame has more detections than ``out`` holds,
        the ones with the largest azimuths are dropped — size the buffers with :attr:`capacity`
        to keep them all. ``misdecode_rate`` overrides the scenario's (the image path's blinking
        ids set it to 0: their misreads come from decoding). A forward camera's frame holds
        only what is in its view; an unmapped marker's entry has beacon −1, label DISTRACTOR.
        """
        if misdecode_rate is None:
            misdecode_rate = self.scenario.faults.misdecode_rate
        x, y, heading = pose
        cz = self.scenario.camera.height if camera_height is None else camera_height
        found, found_ints = self._found, self._found_ints
        count = collect((float(x), float(y), float(cz)), self._lens, self._xyz, self._width,
                        self._moved, self._segments, found, found_ints)
        finish_frame(found, found_ints, count, float(heading), (float(tilt[0]), float(tilt[1])),
                     rng.random((3, count)), self.scenario.error_model.delta_alpha_d,
                     misdecode_rate, self._codes, out.floats, out.ints)
        count = min(count, out.size)
        if self._mapped < len(self._xyz):
            _unmapped_as_distractors(out, count, self._mapped)
        if self._half_view is not None:
            count = _crop_to_view(out, count, self._half_view)
        return count

    def observe(self, pose: Pose, rng: np.random.Generator, tilt: Tilt = LEVEL,
                camera_height: float | None = None) -> Observation:
        """One frame from the camera at ``pose`` = (x, y, heading).

        Args:
            pose: Camera position east and north [m] and heading φ [rad].
            rng: The generator every random draw of the frame comes from (3 uniforms per
                detection: its noise, whether its id is misread, and as which).
            tilt: (pitch, roll) of the camera's axis from the vertical [rad], e.g. on a bump.
            camera_height: Lens height [m]; default the scenario's camera height.

        Returns:
            The measurements (sorted by azimuth, as a detector scanning the image would list
            them) and the ground truth of each.

        Raises:
            InvalidInputError: A pose that is not three finite numbers.
        """
        out = self._buffers
        count = self.observe_into(check_pose(pose), rng, out, tilt, camera_height)
        return out.observation(count)


def _unmapped_as_distractors(out: FrameBuffers, count: int, mapped: int) -> None:
    """Give an unmapped marker's entries (row >= ``mapped``) a distractor's truth.

    Among the first ``count`` entries: no map beacon (−1), label DISTRACTOR; their ids stay the
    codes read.
    """
    beacon = out.ints[FRAME_BEACON, :count]
    unmapped = beacon >= mapped
    out.ints[FRAME_LABEL, :count][unmapped] = DISTRACTOR
    beacon[unmapped] = -1


def _crop_to_view(out: FrameBuffers, count: int, half_view: float) -> int:
    """Keep the first ``count`` entries whose measured azimuth is within ±``half_view``.

    The kept entries move to the front in their order (by azimuth), the rest is padded as
    ``finish_frame`` pads; returns how many are kept.
    """
    keep = np.flatnonzero(np.abs(out.floats[FRAME_AZIMUTH, :count]) <= half_view)
    if keep.size == count:
        return count
    out.floats[:, :keep.size] = out.floats[:, keep]
    out.ints[:, :keep.size] = out.ints[:, keep]
    out.floats[:, keep.size:count] = 0.0
    out.ints[:, keep.size:count] = -1
    out.ints[FRAME_MIRRORED, keep.size:count] = 0
    return int(keep.size)


class FrameBuffers:
    """Fixed-size arrays one frame is written into (see :meth:`GeometrySensor.observe_into`).

    Two packed arrays, ``floats`` (6, size) and ``ints`` (4, size), which the compiled kernel
    fills in one call; the named rows are views of them (rows ``FRAME_*`` of
    :mod:`~azgym.sensing.geometry.frame`).

    Attributes:
        ids, azimuth, quality: What the camera reports (quality: log10 of the blob's brightness
            over the detection threshold, >= 0).
        true_azimuth, beacon, label, mirrored, visible, elevation, half_width: The ground truth
            beside it (the last two are what an image renderer needs).
    """

    def __init__(self, size: int) -> None:
        self.size = size
        self.floats = np.zeros((FRAME_FLOAT_ROWS, size))
        self.ints = np.full((FRAME_INT_ROWS, size), -1, dtype=np.int64)

    # Views made on access (stored views would turn into copies when the object is pickled).
    azimuth = property(lambda self: self.floats[FRAME_AZIMUTH], doc="Measured azimuths [rad].")
    quality = property(lambda self: self.floats[FRAME_QUALITY],
                       doc="log10 of the blob's brightness over the detection threshold (>= 0).")
    true_azimuth = property(lambda self: self.floats[FRAME_TRUE_AZIMUTH],
                            doc="Noise-free azimuths [rad].")
    visible = property(lambda self: self.floats[FRAME_VISIBLE],
                       doc="Visible share of each beacon.")
    elevation = property(lambda self: self.floats[FRAME_ELEVATION],
                         doc="Elevation above the horizon [rad].")
    half_width = property(lambda self: self.floats[FRAME_HALF_WIDTH],
                          doc="Angular half-width of the whole beacon [rad].")
    ids = property(lambda self: self.ints[FRAME_ID], doc="Decoded ids, -1 for padding.")
    beacon = property(lambda self: self.ints[FRAME_BEACON], doc="Map row of the true beacon.")
    label = property(lambda self: self.ints[FRAME_LABEL], doc="Cause of each detection.")
    mirrored = property(lambda self: self.ints[FRAME_MIRRORED],
                        doc="1 for a mirror image, else 0.")

    def observation(self, count: int) -> Observation:
        """The first ``count`` entries as an :class:`Observation` (one copy of each array).

        The buffers' rows are laid out as the observation's (see the kernels' ``FRAME_*``).
        """
        return Observation(self.floats[FRAME_AZIMUTH:FRAME_QUALITY + 1, :count].copy(),
                           self.floats[FRAME_TRUE_AZIMUTH:FRAME_VISIBLE + 1, :count].copy(),
                           self.ints[:, :count].copy())
