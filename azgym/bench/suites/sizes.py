"""How many frames each built-in suite draws, quick and full: for listings, without drawing them.

Drawing a suite's full size takes seconds (the image path renders every frame), too long for
``azgym suites``; the counts are kept here by suite and version (a new version draws other
cases, and must give its counts), and tests/bench/test_suite_sizes.py draws every quick size and
reads every full size off the reference entries, which are checked against the frames drawn.
"""

from __future__ import annotations

from azgym.bench.suites.catalog import SUITES

__all__ = ["FRAMES", "frames"]

FRAMES: dict[tuple[str, int], tuple[int, int]] = {
    ("paper", 1): (1152, 42320),
    ("warehouse-static", 1): (240, 2400),
    ("warehouse-routes", 3): (268, 1517),
    ("image-routes", 3): (268, 1514),
    ("route-events", 1): (809, 809),
    ("stress", 1): (60, 600),
    ("robot-routes", 1): (396, 3148),
}
"""(suite name, version) → frames of its dev split, quick and full."""


def frames(name: str) -> tuple[int, int] | None:
    """The frames a built-in suite draws, quick and full (None: a suite of unknown size)."""
    return FRAMES.get((name, SUITES[name].version))
