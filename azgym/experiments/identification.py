"""How well blinking ids decode on the image path: ``azgym study ids``.

Drives a scenario's routes with the camera at a given frame rate, through
``ImageSensor(ids="blink")``, and scores every blob of a beacon in direct view against the
truth. A beacon is *eligible* in a frame when it has been in view (lit or dark) without a break
since the start of a codeword that has completed by that frame: a decoder had the chance to
read its id. Of eligible blobs we count the correctly identified, the unidentified and the
misidentified; over all blobs with an id, the share whose id is wrong (ghosts carry their
beacon's id, which counts as right: the mirror light really blinks it).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from azgym.progress import Progress, counter
from azgym.sensing.image.blink_code import BLINK_CAMERA_RATE_HZ
from azgym.sensing.image.sensor import ImageSensor
from azgym.site import Scenario, load_scenario
from azgym.world.drive import simulate

__all__ = ["IdentificationStats", "measure_identification"]


@dataclass(frozen=True)
class IdentificationStats:
    """Identification figures of one run (counts of blobs over all frames).

    Attributes:
        scenario: Scenario name.
        camera_rate_hz: Frames per second.
        noise_sigma: Sensor noise [grey levels].
        frames: Frames rendered.
        eligible: Direct blobs of beacons in view for a whole codeword.
        correct: Eligible blobs with the right id.
        unidentified: Eligible blobs with no id.
        misidentified: Eligible blobs with a wrong id.
        with_id: Blobs with an id (any blob, eligible or not, ghosts and distractors too).
        wrong_id: Blobs with an id that is not their light's.
    """

    scenario: str
    camera_rate_hz: float
    noise_sigma: float
    frames: int
    eligible: int
    correct: int
    unidentified: int
    misidentified: int
    with_id: int
    wrong_id: int

    @property
    def correct_share(self) -> float:
        """Share of eligible blobs with the right id."""
        return self.correct / max(1, self.eligible)

    @property
    def misdecode_rate(self) -> float:
        """Share of blobs with an id whose id is wrong."""
        return self.wrong_id / max(1, self.with_id)

    def as_dict(self) -> dict[str, float]:
        """The figures, with the two rates."""
        return {**asdict(self), "correct_share": self.correct_share,
                "misdecode_rate": self.misdecode_rate}


def measure_identification(scenario: Scenario | str, camera_rate_hz: float = BLINK_CAMERA_RATE_HZ,
                           noise_sigma: float = 2.0, seed: int = 0,
                           routes: list[str] | None = None,
                           progress: Progress | None = None) -> IdentificationStats:
    """Drive the routes (all, or those named) and score the decoded ids (see the module).

    ``progress`` hears the count of routes driven.
    """
    scenario = load_scenario(scenario)
    chosen = [r for r in scenario.routes if routes is None or r.name in routes]
    counts = np.zeros(7, dtype=np.int64)  # frames, eligible, correct, none, wrong, with id, bad
    ids = scenario.beacons.ids
    with counter(progress, "routes", len(chosen), "routes") as driven:
        for k, route in enumerate(chosen):
            sensor = ImageSensor(scenario, ids="blink", noise_sigma=noise_sigma)
            rows = np.arange(len(ids))
            streak = np.zeros(len(ids), dtype=np.int64)
            for frame in simulate(scenario, route, [seed, k], sensor=sensor,
                                  camera_rate_hz=camera_rate_hz):
                # Frames a beacon must have been in view to have shown a whole codeword by now: a
                # period, plus this frame's position in its codeword (the coming frame's is one on).
                needed = sensor.code_position(rows) + sensor.code.period
                in_view = np.zeros(len(ids), dtype=bool)
                in_view[frame.observation.in_view] = True
                streak = np.where(in_view, streak + 1, 0)
                decoded = frame.measurements.ids
                truth = frame.truth
                row = np.maximum(truth.beacon, 0)  # blobs of no beacon are masked out below
                true_ids = np.where(truth.beacon >= 0, ids[row], -1)
                direct = (truth.beacon >= 0) & ~truth.mirrored
                is_eligible = direct & (streak[row] >= needed[row])
                counts += [1, is_eligible.sum(), (is_eligible & (decoded == true_ids)).sum(),
                           (is_eligible & (decoded < 0)).sum(),
                           (is_eligible & (decoded >= 0) & (decoded != true_ids)).sum(),
                           (decoded >= 0).sum(), ((decoded >= 0) & (decoded != true_ids)).sum()]
            driven(k + 1)
    frames, eligible, correct, none, wrong, with_id, bad = (int(c) for c in counts)
    return IdentificationStats(scenario.name, camera_rate_hz, noise_sigma, frames, eligible,
                               correct, none, wrong, with_id, bad)
