"""The geometry sensor: compiled line-of-sight kernels, and the camera frame they make.

``occluders`` the segment arithmetic (crossing, blocked rays, the range sensor's rays);
``detections`` the rows of a frame's detection list; ``direct`` beacons seen directly, with
partial occlusion; ``mirrors`` their mirror images (ghosts); ``frame`` the two kernels that
collect a frame and finish it into measurements; ``sensor`` the ``GeometrySensor`` that calls
them.
"""

__all__ = ["detections", "direct", "frame", "mirrors", "occluders", "ordering", "sensor"]
