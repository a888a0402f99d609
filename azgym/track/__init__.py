"""Trackers: estimators with memory, fusing odometry and the IMU with each frame's azimuths.

The interface is :class:`SupportsTrack` (any object with ``reset``, ``predict`` and ``update``)
and its validating base class :class:`Tracker`; :func:`make_tracker` builds one by name (a
localizer comes wrapped in :class:`FrameByFrame`), and :func:`check_tracker` checks a plug-in.
The built-in trackers are in the modules: ``dead_reckoning``, ``inertial_kalman`` (``tkf``,
``lpkf``), ``gated_ekf`` and ``robust``.
"""

from azgym.track.base import FrameByFrame, SupportsTrack, Tracker, make_tracker
from azgym.track.checks import check_tracker

__all__ = ["FrameByFrame", "SupportsTrack", "Tracker", "check_tracker", "make_tracker"]
