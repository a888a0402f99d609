"""robust:repair=true against a beacon made to be suspected over and over, at a high frame rate.

Every suspicion re-runs the track from before the suspect's stretch of sightings
(:mod:`azgym.track.repair_lag`); a beacon in view all along whose azimuths swing between wrong
(a run of rejections: suspected) and right (agreeing again: cleared) would, unchecked, re-run the
whole lag at every swing. The re-runs must stay within the frames tracked, the lag within its
seconds and frames, whatever the frame rate. The attack runs in a child process with a time
limit.
"""

from __future__ import annotations

import json
import subprocess
import sys

from azgym.track.repair_lag import LAG_FRAMES, LAG_S

TIME_LIMIT = 240.0
"""The child's time [s]: the attack takes a few seconds."""

CHILD = r"""
import json, sys
import numpy as np
import azgym
from azgym import Measurements
from azgym.sensing.motion import ImuSamples, Motion, OdometrySamples
from azgym.world.drive import simulate

rate = float(sys.argv[1])
scenario = azgym.load_scenario("warehouse-paper")
start = max(simulate(scenario, "A-B-C-D", seed=3), key=lambda f: len(f.measurements))
ids, counts = np.unique(start.measurements.ids, return_counts=True)
victim = int(ids[counts == 1][0])  # a beacon detected once (no ghost of it agreeing)
tracker = azgym.make_tracker("robust", repair=True)
tracker.reset(seed=0, initial=start.pose)
rng = np.random.default_rng(0)
frames = int(90.0 * rate)
period = round(3.0 * rate)  # two thirds of each 3 s wrong, one third right
replayed = suspicions = most_kept = 0
longest = 0.0
for k in range(frames):
    t = start.time + (k + 1) / rate
    motion = Motion(time=t, odometry=OdometrySamples(np.array([t]), np.zeros(1), np.zeros(1),
                                                     np.zeros(1)), imu=ImuSamples.none())
    azimuth = start.measurements.azimuth + rng.normal(0.0, 0.001, len(start.measurements))
    if k % period < 2 * period // 3:
        azimuth = azimuth + 0.2 * (start.measurements.ids == victim)
    tracker.predict(motion)
    estimate = tracker.update(Measurements(start.measurements.ids, azgym.wrap_angle(azimuth)),
                              scenario.beacons)
    if "suspected" in estimate.diagnostics:
        suspicions += 1
        replayed += estimate.diagnostics["replayed"]
    kept = tracker._lag.frames
    most_kept = max(most_kept, len(kept))
    longest = max(longest, kept[-1][1] - kept[0][1])  # (steps, time, measurements)
print(json.dumps({"frames": frames, "suspicions": suspicions, "replayed": replayed,
                  "most_kept": most_kept, "longest": longest,
                  "repaired": [r.beacon for r in tracker.repairs]}))
"""


def attack(rate: float) -> dict:
    """Run the attack at ``rate`` frames a second in a child with a time limit; its figures."""
    done = subprocess.run([sys.executable, "-c", CHILD, str(rate)], capture_output=True,
                          text=True, timeout=TIME_LIMIT, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_suspicions_over_and_over_re_run_no_more_frames_than_were_tracked():
    found = attack(10.0)
    assert found["suspicions"] >= 10, found  # suspected at (nearly) every swing
    assert found["replayed"] <= found["frames"], found
    # its rays, wrong and right, all from one standing camera: they meet there, not at a beacon
    assert found["repaired"] == [], found
    assert found["most_kept"] <= LAG_FRAMES and found["longest"] <= LAG_S, found


def test_at_a_high_frame_rate_the_lag_keeps_at_most_its_frames():
    found = attack(60.0)
    assert found["most_kept"] == LAG_FRAMES, found  # 30 s at 60 frames a second: capped
    assert found["replayed"] <= found["frames"], found
