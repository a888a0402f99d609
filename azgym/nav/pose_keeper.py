"""The navigator's pose: the localizer's answers, gated for jumps, dead-reckoned between them.

An AGV's navigation stack keeps a pose at all times. Between the localizer's answers it moves
the last one by the drive's own speed and steering angle (wheel odometry, here without noise:
the bicycle model of :mod:`azgym.world.forklift` integrated by
:func:`azgym.track.kinematics.advance`), and it does not jump after a ghost: an answer farther
from the dead-reckoned pose than :data:`JUMP_MARGIN` plus :data:`DRIFT_RATE` times the time
since the last accepted answer is rejected. Once the last accepted answer is older than
:data:`LOST_AFTER`, the next answer is accepted whatever it is (the forklift relocalizes), so a
wrong first answer cannot lock the gate. The localizer is what is scored: every answer's error
is reported, accepted or not.
"""

from __future__ import annotations

import math

from azgym.core import Pose
from azgym.track.kinematics import advance
from azgym.world.forklift import ForkliftSpec

__all__ = ["JUMP_MARGIN", "LOST_AFTER", "PoseKeeper"]

JUMP_MARGIN = 1.0
"""Distance an answer may lie from the dead-reckoned pose right after a fix [m]."""
DRIFT_RATE = 0.5
"""How fast that allowance grows with the time since the last fix [m/s]: dead reckoning's
drift, with room to spare."""
LOST_AFTER = 5.0
"""After this long without an accepted answer [s], the next one is accepted whatever it is."""


class PoseKeeper:
    """The camera pose the navigator believes, its age and its support (module docstring).

    Args:
        spec: The forklift's dimensions (the camera's place relative to the reference axle).
    """

    def __init__(self, spec: ForkliftSpec) -> None:
        self.spec = spec
        centre = -0.5 * spec.wheelbase if spec.rear_steer else 0.5 * spec.wheelbase
        self._camera_ahead = centre + spec.camera_offset[0]
        self.reset()

    def reset(self) -> None:
        """No pose yet: a new episode."""
        self.pose: Pose | None = None
        self.age = math.inf
        self.support = 0
        self.rejected = 0

    def body_pose(self) -> Pose | None:
        """The pose of the body's centre, behind the camera (None before the first answer)."""
        if self.pose is None:
            return None
        x, y, heading = self.pose
        forward, left = self.spec.camera_offset
        c, s = math.cos(heading), math.sin(heading)
        return (x - forward * c + left * s, y - forward * s - left * c, heading)

    def coast(self, speed: float, steer: float, dt: float) -> None:
        """Move the pose by the drive's speed [m/s] and steering angle [rad] for ``dt`` [s]."""
        self.age += dt
        if self.pose is not None:
            yaw_rate = speed * math.tan(steer) / self.spec.wheelbase
            self.pose = advance(self.pose, speed, yaw_rate, self._camera_ahead, dt)

    def offer(self, answer: Pose | None, support: int) -> bool:
        """Take the localizer's answer if it passes the gate; whether it did."""
        if answer is None:
            return False
        if self.pose is not None and self.age <= LOST_AFTER and math.hypot(
                answer[0] - self.pose[0], answer[1] - self.pose[1]) > (
                JUMP_MARGIN + DRIFT_RATE * self.age):
            self.rejected += 1
            return False
        self.pose, self.age, self.support = answer, 0.0, support
        return True
