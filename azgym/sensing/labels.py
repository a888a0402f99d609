"""What really produced a detection: the ground-truth labels kept beside every measurement.

Plain integers, so that compiled kernels and arrays carry them; the most specific label applies
(a misread ghost is still a ghost in the geometry, and is relabelled MISIDENTIFIED only where
its decoded id is wrong).
"""

__all__ = ["DIRECT", "DISTRACTOR", "GHOST", "LABEL_NAMES", "MISIDENTIFIED", "MOVED", "PARTIAL"]

DIRECT = 0
"""A beacon in full view."""
PARTIAL = 1
"""A beacon partly covered by an occluder: its azimuth is the visible part's centroid."""
GHOST = 2
"""A mirror image of a beacon in a reflective wall or rack face, carrying the beacon's id."""
MISIDENTIFIED = 3
"""A detection whose decoded id is not its light's."""
MOVED = 4
"""A beacon seen where it really is, after it was moved without the map being updated."""
DISTRACTOR = 5
"""Image path only: a blob no beacon explains (a lamp, a window, their mirrors, noise)."""
LABEL_NAMES = ("direct", "partial", "ghost", "misidentified", "moved", "distractor")
"""The labels as words, indexed by label."""
