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

from azgym.core import FloatArray, IntArray, Measurements, wrap_angle
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
        reflective = int(np.count_nonzero(self._segments[:, 5] > 0))
        self._ghosts = np.empty((reflective * len(scenario.beacons), 4))
        n = len(scenario.beacons)
        self._azimuth = np.empty(n)
        self._label = np.empty(n, dtype=np.int64)
        self._visible = np.empty(n)

    def observe(
        self, x: float, y: float, heading: float, rng: np.random.Generator,
        camera_height: float | None = None,
    ) -> tuple[Measurements, DetectionTruth]:
        """One frame from the camera at (x, y) with the given heading.

        Args:
            x: Camera position, east [m].
            y: Camera position, north [m].
            heading: Camera heading φ [rad].
            rng: The generator every random draw of the frame comes from.
            camera_height: Lens height [m]; default the scenario's camera height.

        Returns:
            The measurements (sorted by azimuth, as a detector scanning the image would list
            them) and the ground truth of each.
        """
        camera = self.scenario.camera
        cz = camera.height if camera_height is None else camera_height
        G.direct_view(x, y, cz, self._xyz, self._width, self._segments, camera.min_elevation,
                      camera.max_range, self._azimuth, self._label, self._visible)
        seen = np.flatnonzero(self._visible > 0.0)
        n_ghosts = G.mirror_view(x, y, cz, self._xyz, self._segments, camera.min_elevation,
                                 camera.max_range, self._ghosts)
        ghosts = self._ghosts[:n_ghosts]
        beacon = np.concatenate([seen, ghosts[:, 1].astype(np.int64)])
        world = np.concatenate([self._azimuth[seen], ghosts[:, 0]])
        label = np.concatenate([self._label[seen], np.full(n_ghosts, G.GHOST)])
        visible = np.concatenate([self._visible[seen], np.ones(n_ghosts)])
        label[(label != G.GHOST) & self._moved[beacon]] = G.MOVED

        count = beacon.size
        true_azimuth = wrap_angle(world - heading)
        noise = rng.uniform(-1.0, 1.0, count) * self.scenario.error_model.delta_alpha_d
        ids = self.scenario.beacons.ids[beacon].copy()
        misread = rng.random(count) < self.scenario.faults.misdecode_rate
        if misread.any():
            n_map = len(self.scenario.beacons)
            # Another map beacon's id, uniformly: shift the row by 1..N-1.
            rows = (beacon[misread] + rng.integers(1, max(n_map, 2), misread.sum())) % n_map
            ids[misread] = self.scenario.beacons.ids[rows]
            label[misread] = G.MISIDENTIFIED
        measured = wrap_angle(true_azimuth + noise)
        order = np.argsort(measured, kind="stable")
        truth = DetectionTruth(label=label[order], beacon=beacon[order],
                               azimuth=true_azimuth[order], visible=visible[order])
        return Measurements(ids[order], measured[order]), truth
