"""The camera through pixels: the geometry's lights rendered on the fisheye, detected, identified.

Per frame, :class:`ImageSensor`

1. asks the geometry (:class:`~azgym.sensing.geometry.sensor.GeometrySensor`) what it sees:
   beacons, partly covered beacons, mirror ghosts, moved beacons; and the same for the
   scenario's other ``lights`` (lamps, windows), which racks hide and mirrors reflect like any
   light;
2. renders them (:mod:`~azgym.sensing.image.render`): beacons as LED blobs cut to their visible
   part, lights as patches, with noise from a bank of precomputed frames;
3. detects blobs (:mod:`~azgym.sensing.image.detect`) and turns each centroid into an azimuth;
4. identifies each blob, in one of two modes:

   * ``ids="oracle"``: the id of the light whose projected centre is nearest (within
     ``match_px``), misread at the scenario's ``faults.misdecode_rate`` as another map id — fast,
     for single frames;
   * ``ids="blink"``: every beacon blinks its id's on-off code (``blink_code.BlinkCode``) from
     its own phase, and a ``blob_tracker.BlobTracker`` decodes ids from the blobs' lit/dark
     histories over frames. Frames must then be successive (call :meth:`ImageSensor.reset`
     between episodes); dark beacons give no blob, and misidentifications come from tracking
     and decoding.

The ground truth of every blob — which light made it and its noise-free azimuth — travels beside
the measurements, found by the same nearest-centre matching.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from azgym.core import BeaconMap, FloatArray, IntArray, Pose
from azgym.errors import InvalidInputError, unknown_name
from azgym.sensing.geometry.sensor import FrameBuffers, GeometrySensor
from azgym.sensing.identities import ID_MODES, misread_row
from azgym.sensing.image._match import nearest_lights
from azgym.sensing.image.blink_code import BLINK_CAMERA_RATE_HZ, BlinkCode
from azgym.sensing.image.blob_tracker import BlobTracker
from azgym.sensing.image.detect import detect
from azgym.sensing.image.render import render
from azgym.sensing.labels import DISTRACTOR, MISIDENTIFIED
from azgym.sensing.protocol import (
    CAMERA_RATE_HZ,
    LEVEL,
    DetectionTruth,
    Observation,
    Seed,
    Tilt,
    check_pose,
)
from azgym.site import Scenario
from azgym.site.elements import Faults

__all__ = ["ImageSensor"]


class ImageSensor:
    """A scenario's fisheye camera, measuring beacons from rendered pixels.

    Args:
        scenario: The site; its ``fisheye`` is the camera and its ``lights`` the distractors.
        ids: "oracle" or "blink" (see the module's docstring).
        noise_sigma: Sensor noise [grey levels].
        noise_frames: Size of the bank of precomputed noise frames (drawn from ``seed``).
        threshold: Detection threshold [grey level].
        match_px: Largest blob-to-light distance for identifying (oracle) and for the ground
            truth [px].

    Call :meth:`reset` with a seed before the first frame: it draws the bank of noise frames and
    the beacons' blinking phases.
    """

    quality_names = ("area_px", "peak", "elongation")
    elongation_cap = 1e6
    """The elongation reported for a one-pixel-wide blob (whose minor axis is 0)."""

    def __init__(self, scenario: Scenario, ids: str = "oracle", noise_sigma: float = 2.0,
                 noise_frames: int = 8, threshold: int = 25, match_px: float = 3.0) -> None:
        if ids not in ID_MODES:
            raise unknown_name("ids", ids, ID_MODES)
        if not (math.isfinite(noise_sigma) and noise_sigma >= 0):
            raise InvalidInputError(f"noise_sigma must be >= 0, got {noise_sigma!r}")
        if not 0 < threshold < 255:
            raise InvalidInputError(f"threshold must be in (0, 255), got {threshold!r}")
        if noise_frames < 1:
            raise InvalidInputError(f"noise_frames must be >= 1, got {noise_frames!r}")
        if not scenario.camera.all_round:
            raise InvalidInputError(
                f"the image sensor renders an upward fisheye, but scenario {scenario.name!r} has "
                f"a forward camera (field of view {scenario.camera.field_of_view:.3g} rad): use "
                f'sensor="geometry"')
        self.scenario = scenario
        self.camera = scenario.fisheye
        self._distortion = np.array(self.camera.distortion, dtype=np.float64)
        self.ids = ids
        self.threshold = threshold
        self.match_px = match_px
        self.noise_sigma = noise_sigma
        self.noise_frames = noise_frames
        self.frame_rate_hz = BLINK_CAMERA_RATE_HZ if ids == "blink" else CAMERA_RATE_HZ
        self._geometry = GeometrySensor(scenario)
        self._buffers = self._geometry.new_buffers()
        self._noise: list[np.ndarray | None] = []
        self._lights = _LightSource(scenario)
        self._frame = 0
        if ids == "blink":
            self.code = BlinkCode.for_ids(scenario.beacons.ids)
            self._codes = np.array([self.code.frames(int(i)) for i in scenario.beacons.ids])
            self.phases = np.zeros(len(scenario.beacons), dtype=np.int64)
            self.tracker = BlobTracker(self.code, self.camera.principal_point)

    def reset(self, seed: Seed = None) -> None:
        """Start a new sequence of frames: draw the noise bank and blinking phases from ``seed``.

        In blinking mode the tracks are forgotten too.
        """
        bank = np.random.default_rng(seed)
        width, height = self.camera.image_size
        self._noise = ([bank.normal(0.0, self.noise_sigma, (height, width)).astype(np.float32)
                        for _ in range(self.noise_frames)] if self.noise_sigma > 0 else [None])
        self._frame = 0
        if self.ids == "blink":
            self.phases = bank.integers(0, self.code.period, len(self.scenario.beacons))
            self.tracker.reset()

    @property
    def quality_high(self) -> tuple[float, float, float]:
        """The largest blob: the whole image, saturated, a one-pixel-wide line."""
        width, height = self.camera.image_size
        return float(width * height), 255.0, self.elongation_cap

    def code_position(self, rows: IntArray) -> IntArray:
        """Where in its codeword each beacon (map rows) is at the coming frame (blinking mode)."""
        return (self._frame + self.phases[rows]) % self.code.period

    def observe(self, pose: Pose, rng: np.random.Generator, tilt: Tilt = LEVEL) -> Observation:
        """Render the frame at ``pose`` = (x, y, heading), detect its blobs and identify them.

        Args:
            pose: Camera position east and north [m] and heading [rad].
            rng: The frame's random draws (misreads in oracle mode, the noise frame).
            tilt: (pitch, roll) of the camera's axis [rad].

        Raises:
            InvalidInputError: :meth:`reset` was never called, or a pose that is not three
                finite numbers.

        Returns:
            The blobs' ids (-1: not identified), azimuths and quality (columns: area [px], peak
            grey level, elongation), their ground truth (DISTRACTOR for a blob no beacon
            explains — a lamp, a window, their mirrors, noise; MISIDENTIFIED for a beacon's
            blob with a wrong id, or a distractor with an id), the image and the blobs.
        """
        if not self._noise:
            raise InvalidInputError("ImageSensor: call reset(seed) before the first observe")
        pose = check_pose(pose)
        lights, in_view = self._lights_in_view(pose, rng, tilt)
        noise = self._noise[int(rng.integers(len(self._noise)))]
        image = render(self.camera, lights.azimuth - lights.half_width,
                       lights.azimuth + lights.half_width, lights.elevation, lights.flux, noise,
                       lights.half_tall)
        blobs = detect(image, self.camera, self.threshold)
        pixels = np.array([(b.u, b.v) for b in blobs], dtype=np.float64).reshape(-1, 2)
        quality = np.array([(b.area, b.peak, b.elongation) for b in blobs],
                           dtype=np.float64).reshape(-1, 3)
        source = self._match(pixels, lights)
        truth = _truth(source, lights)
        ids = self._identify(pixels, quality[:, 0], source, lights, truth, rng)
        self._frame += 1
        quality[~np.isfinite(quality)] = self.elongation_cap  # a one-pixel-wide blob
        return Observation._from_valid_columns(
            ids=ids, azimuth=np.array([b.azimuth for b in blobs]).reshape(-1), quality=quality,
            label=truth.label, beacon=truth.beacon, true_azimuth=truth.azimuth,
            visible=truth.visible, mirrored=truth.mirrored, in_view=in_view, image=image,
            blobs=tuple(blobs))

    def _lights_in_view(self, pose: Pose, rng: np.random.Generator,
                        tilt: Tilt) -> tuple[_Lights, IntArray]:
        """The lights the frame shows, and the map rows of the beacons in direct view.

        The lights are the lit beacons (all of them in oracle mode), then the lamps and windows;
        the beacons in direct view count whether lit or not. Misreads are drawn per blob (oracle
        mode) or come from decoding (blink mode), so the geometry draws none: its labels keep
        what each light is (a misread ghost is still a ghost).
        """
        out = self._buffers
        count = self._geometry.observe_into(pose, rng, out, tilt=tilt, misdecode_rate=0.0)
        rows = out.beacon[:count]
        lit = (self._codes[rows, self.code_position(rows)] if self.ids == "blink"
               else np.ones(count, dtype=bool))
        beacons = _Lights.from_buffers(out, count, lit)
        in_view = rows[out.mirrored[:count] == 0].copy()
        return beacons.join(self._lights.observe(pose, rng, tilt)), in_view

    def _identify(self, pixels: FloatArray, areas: FloatArray, source: IntArray,
                  lights: _Lights, truth: DetectionTruth, rng: np.random.Generator) -> IntArray:
        """Each blob's id (see the module's docstring); -1 for none.

        Blink mode decodes them (the tracker takes the blobs' centroids and areas), oracle mode
        gives each blob its light's id (``source``: its row in ``lights``), misread at the
        scenario's rate. Blobs whose id is not their beacon's are relabelled MISIDENTIFIED in
        ``truth.label``.
        """
        if self.ids == "blink":
            ids = self.tracker.update(pixels, areas)
            beacon = truth.beacon
            true_ids = np.where(beacon >= 0, self.scenario.beacons.ids[np.maximum(beacon, 0)],
                                -1)
            truth.label[(ids >= 0) & (ids != true_ids)] = MISIDENTIFIED
            return ids
        ids = np.full(len(pixels), -1, dtype=np.int64)
        matched = source >= 0
        ids[matched] = lights.ids[source[matched]]  # -1 for a lamp or a window
        self._misread(ids, truth.label, truth.beacon, rng)
        return ids

    def _misread(self, ids: IntArray, labels: IntArray, beacon: IntArray,
                 rng: np.random.Generator) -> None:
        """Oracle mode: misread identified blobs' ids at the scenario's rate.

        A misread id is one of the other map ids, uniformly (as the geometry sensor does).
        """
        rate = self.scenario.faults.misdecode_rate
        map_ids = self.scenario.beacons.ids
        draws = rng.random((2, len(ids)))
        if len(map_ids) < 2:
            return
        for k in np.flatnonzero((beacon >= 0) & (draws[0] < rate)):
            ids[k] = map_ids[misread_row(int(beacon[k]), float(draws[1, k]), len(map_ids))]
            labels[k] = MISIDENTIFIED

    def _match(self, pixels: FloatArray, lights: _Lights) -> IntArray:
        """For each blob, the light whose projected centre is nearest within its reach, or -1.

        A light's reach is ``match_px`` plus its own half-size on the image (a window's blob
        is as big as the window).
        """
        source = np.full(len(pixels), -1, dtype=np.int64)
        if len(pixels) and len(lights.azimuth):
            cx, cy = self.camera.principal_point
            nearest_lights(pixels, lights.azimuth, lights.elevation, lights.half_width,
                           lights.half_tall, float(cx), float(cy), float(self.camera.focal_px),
                           self._distortion, float(self.match_px), source)
        return source


def _truth(source: IntArray, lights: _Lights) -> DetectionTruth:
    """The ground truth of each blob, from the light that made it.

    ``source`` holds each blob's row in ``lights``, -1 for none (noise). A blob takes its light's
    label, beacon, azimuth, visible share and mirroring; a blob of noise is a DISTRACTOR of no
    beacon, with azimuth NaN.
    """
    count = len(source)
    matched = np.flatnonzero(source >= 0)
    rows = source[matched]
    label = np.full(count, DISTRACTOR, dtype=np.int64)
    label[matched] = lights.label[rows]
    beacon = np.full(count, -1, dtype=np.int64)
    beacon[matched] = lights.beacon[rows]
    azimuth = np.full(count, np.nan)
    azimuth[matched] = lights.azimuth[rows]
    visible = np.zeros(count)
    visible[matched] = lights.visible[rows]
    mirrored = np.zeros(count, dtype=bool)
    mirrored[matched] = lights.mirrored[rows]
    return DetectionTruth(label=label, beacon=beacon, azimuth=azimuth, visible=visible,
                          mirrored=mirrored)


@dataclass(frozen=True)
class _Lights:
    """The lights of one frame as the renderer takes them (camera-frame angles)."""

    azimuth: FloatArray
    half_width: FloatArray
    elevation: FloatArray
    half_tall: FloatArray
    flux: FloatArray
    ids: IntArray
    beacon: IntArray
    label: IntArray
    mirrored: np.ndarray
    visible: FloatArray

    @classmethod
    def from_buffers(cls, out: FrameBuffers, count: int, keep: np.ndarray,
                     flux: FloatArray | None = None,
                     tall_ratio: FloatArray | None = None) -> _Lights:
        """The kept detections of a frame the geometry wrote into ``out``.

        Args:
            out: The geometry's buffers.
            count: Detections in them.
            keep: Which of the ``count`` to keep.
            flux: Each detection's flux, if not the one the buffers hold.
            tall_ratio: Height over width of each detection's light (None: LEDs, no height).
        """
        visible = out.visible[:count]
        half_width = visible * out.half_width[:count]
        half_tall = (np.zeros(count) if tall_ratio is None
                     else out.half_width[:count] * tall_ratio)
        return cls(azimuth=out.true_azimuth[:count][keep], half_width=half_width[keep],
                   elevation=out.elevation[:count][keep], half_tall=half_tall[keep],
                   flux=(10.0 ** out.quality[:count] if flux is None else flux)[keep],
                   ids=out.ids[:count][keep], beacon=out.beacon[:count][keep],
                   label=out.label[:count][keep],
                   mirrored=out.mirrored[:count][keep] == 1, visible=visible[keep])

    def as_distractors(self) -> _Lights:
        """The same lights as blobs no beacon explains: no id, no beacon, label DISTRACTOR."""
        none = np.full(self.azimuth.size, -1, dtype=np.int64)
        return dataclasses.replace(self, ids=none, beacon=none,
                                   label=np.full(self.azimuth.size, DISTRACTOR,
                                                 dtype=np.int64))

    def join(self, other: _Lights) -> _Lights:
        """These lights, then the other's."""
        return _Lights(*(np.concatenate([getattr(self, f.name), getattr(other, f.name)])
                         for f in dataclasses.fields(self)))


class _LightSource:
    """The scenario's lamps and windows through the same geometry as the beacons.

    The geometry sees them as beacons of a private map, with the range stretched to the
    brightest light's (a light of power P reaches the threshold at sqrt(P) times a beacon's
    range); each light's flux is then scaled back by its own power.
    """

    def __init__(self, scenario: Scenario) -> None:
        lights = scenario.lights
        self._power = np.array([light.power for light in lights])
        self._tall = np.array([light.tall / light.width for light in lights])
        self._scale = self._power  # each light's flux over the strongest's (set below)
        self._sensor: GeometrySensor | None = None
        self._buffers = FrameBuffers(0)
        if not lights:
            return
        strongest = float(self._power.max())
        as_beacons = BeaconMap(np.arange(len(lights)), np.array([light.xyz for light in lights]),
                               np.array([light.width for light in lights]))
        camera = dataclasses.replace(scenario.camera,
                                     max_range=scenario.camera.max_range * math.sqrt(strongest))
        self._sensor = GeometrySensor(dataclasses.replace(
            scenario, beacons=as_beacons, camera=camera, faults=Faults(0.0), physical_xyz=None))
        self._buffers = self._sensor.new_buffers()
        self._scale = self._power / strongest

    def observe(self, pose: Pose, rng: np.random.Generator, tilt: Tilt) -> _Lights:
        """The lights the camera sees from this pose (flux >= the detection threshold)."""
        out = self._buffers
        count = (0 if self._sensor is None
                 else self._sensor.observe_into(pose, rng, out, tilt=tilt))
        rows = out.beacon[:count]
        flux = 10.0 ** out.quality[:count] * self._scale[rows]
        return _Lights.from_buffers(out, count, flux >= 1.0, flux,
                                    self._tall[rows]).as_distractors()
