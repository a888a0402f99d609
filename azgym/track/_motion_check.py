"""The compiled check of a tracker's motion samples (:func:`azgym.track.base.check_motion`).

The check runs on every frame of every route; as numpy calls it cost about 15 µs a frame, more
than a per-frame localizer itself, so it is a compiled loop, in a module of its own so that the
kernel cache depends on nothing else.
"""

from __future__ import annotations

import numpy as np

from azgym.jit import jit

OUT_OF_ORDER, NOT_FINITE = 1, 2
"""What :func:`stream_fault` finds wrong (0: nothing)."""


@jit
def stream_fault(after, until, time, first, second, third):
    """0, or what is wrong with one stream of samples: OUT_OF_ORDER or NOT_FINITE.

    Sample times must increase within (after, until]; every value must be finite.
    """
    previous = after
    for k in range(time.size):
        if not (time[k] > previous and time[k] <= until):
            return NOT_FINITE if not np.isfinite(time[k]) else OUT_OF_ORDER
        previous = time[k]
        if not (np.isfinite(first[k]) and np.isfinite(second[k]) and np.isfinite(third[k])):
            return NOT_FINITE
    return 0
