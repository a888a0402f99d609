"""The geometry sensor: compiled line-of-sight kernels, and the camera frame they make."""
