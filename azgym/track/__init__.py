"""Trackers: estimators with memory, fusing odometry and the IMU with each frame's azimuths."""
