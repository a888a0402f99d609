"""The physical sensor: one camera frame of a scenario, seen from a pose, with ground truth beside.

Faults come from the scene: racks hide beacons (2.5-D line of sight), rack edges cover part of a
beacon (its azimuth moves to the visible part's centroid), reflective faces show mirror ghosts
with the real beacon's id, and beacons moved after the map was made appear where they really
are. Decoding faults (a misread id) come from a rate. On top of all of this, every detection gets
the centre-detection error of eq. 1, uniform on ±Δα_d; the coverage error of eq. 2 is not drawn,
since partial occlusion now produces it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from azgym.core import FloatArray, IntArray, Measurements
from azgym.layout import occluder_table
from azgym.scenario import Scenario
from azgym.sensing import geometry as G


@dataclass(frozen=True, eq=False)
class DetectionTruth:
    """What really produced each detection of a frame, index for index with its Measurements.

    Attributes:
        label: Cause of each detection, one of ``geometry.DIRECT, PARTIAL, GHOST, MISIDENTIFIED,
            MOVED`` (the most specific applies; names in ``geometry.LABEL_NAMES``), shape (M,).
        beacon: Map row of the beacon whose light it is, shape (M,).
        azimuth: Its noise-free azimuth in the camera frame [rad]: the visible centroid for a
            partly covered beacon, the mirror direction for a ghost, shape (M,).
        visible: Visible share of the beacon's width (1 for a ghost), shape (M,).
    """

    label: IntArray
    beacon: IntArray
    azimuth: FloatArray
    visible: FloatArray

    def label_names(self) -> list[str]:
        """The labels as words."""
        return [G.LABEL_NAMES[k] for k in self.label]


class Sensor:
    """Frames of one scenario's camera.

    Args:
        scenario: The site (racks, walls, beacons, camera, faults, error model).
    """

    def __init__(self, scenario: Scenario) -> None:
        self.scenario = scenario
        self._segments = occluder_table(scenario.racks, scenario.walls)
        self._xyz = np.ascontiguousarray(scenario.beacon_positions)
        self._width = scenario.beacons.width
        self._moved = np.any(self._xyz != scenario.beacons.xyz, axis=1)
        n = len(scenario.beacons)
        self._capacity = n * (1 + int(np.count_nonzero(self._segments[:, 5] > 0)))
        most = self._capacity
        self._ghosts = np.empty((most, 6))
        self._scratch = (np.empty(n), np.empty(n, dtype=np.int64), np.empty(n))
        self._collected = (np.empty(most), np.empty(most), np.empty(most, dtype=np.int64),
                           np.empty(most, dtype=np.int64), np.empty(most), np.empty(most),
                           np.empty(most))
        self._buffers = FrameBuffers(most)

    @property
    def capacity(self) -> int:
        """The most detections a frame can have: every beacon, and its mirror in every mirror."""
        return self._capacity

    def new_buffers(self, size: int | None = None) -> FrameBuffers:
        """Arrays for :meth:`observe_into`, ``size`` long (default: :attr:`capacity`)."""
        return FrameBuffers(self.capacity if size is None else size)

    def observe_into(
        self, x: float, y: float, heading: float, rng: np.random.Generator, out: FrameBuffers,
        camera_height: float | None = None, tilt: tuple[float, float] = (0.0, 0.0),
        misdecode_rate: float | None = None,
    ) -> int:
        """Like :meth:`observe`, into preallocated arrays; returns the number of detections M.

        Entries past M are padded (id −1). If a frame has more detections than ``out`` holds,
        the ones with the largest azimuths are dropped — size the buffers with :attr:`capacity`
        to keep them all. ``misdecode_rate`` overrides the scenario's (the image path's blinking
        ids set it to 0: their misreads come from decoding).
        """
        if misdecode_rate is None:
            misdecode_rate = self.scenario.faults.misdecode_rate
        camera = self.scenario.camera
        cz = camera.height if camera_height is None else camera_height
        world, elevation, beacon, label, visible, brightness, halfwidth = self._collected
        count = G.collect(float(x), float(y), float(cz), self._xyz, self._width, self._moved,
                          self._segments, camera.min_elevation, camera.max_range, world,
                          elevation, beacon, label, visible, brightness, halfwidth,
                          *self._scratch, self._ghosts)
        G.finish(world[:count], elevation[:count], beacon[:count], label[:count],
                 visible[:count], brightness[:count], halfwidth[:count], float(heading),
                 float(tilt[0]),
                 float(tilt[1]), rng.random((3, count)), self.scenario.error_model.delta_alpha_d,
                 misdecode_rate, self.scenario.beacons.ids, out.floats,
                 out.ints)
        return min(count, out.size)

    def observe(
        self, x: float, y: float, heading: float, rng: np.random.Generator,
        camera_height: float | None = None, tilt: tuple[float, float] = (0.0, 0.0),
    ) -> tuple[Measurements, DetectionTruth]:
        """One frame from the camera at (x, y) with the given heading.

        Args:
            x: Camera position, east [m].
            y: Camera position, north [m].
            heading: Camera heading φ [rad].
            rng: The generator every random draw of the frame comes from (3 uniforms per
                detection: its noise, whether its id is misread, and as which).
            camera_height: Lens height [m]; default the scenario's camera height.
            tilt: (pitch, roll) of the camera's axis from the vertical [rad], e.g. on a bump.

        Returns:
            The measurements (sorted by azimuth, as a detector scanning the image would list
            them; ``quality`` is log10 of each blob's brightness over the detection threshold)
            and the ground truth of each.
        """
        out = self._buffers
        count = self.observe_into(x, y, heading, rng, out, camera_height, tilt)
        truth = DetectionTruth(label=out.label[:count].copy(), beacon=out.beacon[:count].copy(),
                               azimuth=out.true_azimuth[:count].copy(),
                               visible=out.visible[:count].copy())
        return Measurements._from_valid_arrays(out.ids[:count], out.azimuth[:count],
                                               out.quality[:count]), truth


class FrameBuffers:
    """Fixed-size arrays one frame is written into (see :meth:`Sensor.observe_into`).

    Two packed arrays, ``floats`` (4, size) and ``ints`` (3, size), which the compiled kernel
    fills in one call; the named rows are views of them.

    Attributes:
        ids, azimuth, quality: What the camera reports (quality: log10 of the blob's brightness
            over the detection threshold, >= 0).
        true_azimuth, beacon, label, visible, elevation, half_width: The ground truth beside it
            (the last two are what an image renderer needs).
    """

    def __init__(self, size: int) -> None:
        self.size = size
        self.floats = np.zeros((6, size))
        self.ints = np.full((3, size), -1, dtype=np.int64)

    # Views made on access (stored views would turn into copies when the object is pickled).
    azimuth = property(lambda self: self.floats[0], doc="Measured azimuths [rad].")
    quality = property(lambda self: self.floats[1],
                       doc="log10 of the blob's brightness over the detection threshold (>= 0).")
    true_azimuth = property(lambda self: self.floats[2], doc="Noise-free azimuths [rad].")
    visible = property(lambda self: self.floats[3], doc="Visible share of each beacon.")
    elevation = property(lambda self: self.floats[4], doc="Elevation above the horizon [rad].")
    half_width = property(lambda self: self.floats[5],
                          doc="Angular half-width of the whole beacon [rad].")
    ids = property(lambda self: self.ints[0], doc="Decoded ids, -1 for padding.")
    beacon = property(lambda self: self.ints[1], doc="Map row of the true beacon.")
    label = property(lambda self: self.ints[2], doc="Cause of each detection.")
