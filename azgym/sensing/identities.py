"""How a detection gets its id, and the misread rule every sensor applies.

Two modes (``ids=``): ``"oracle"``, the id of the light that made the detection, misread at the
scenario's ``faults.misdecode_rate``; and ``"blink"``, decoded from the beacons' on-off codes over
frames (the image sensor only; see :mod:`azgym.sensing.image.blob_tracker`).

A misread detection of the beacon in map row ``b`` is read as one of the other N − 1 map
beacons, uniformly: row ``(b + shift) % N`` with ``shift`` = 1 + ⌊u (N − 1)⌋ for a uniform u in
[0, 1), clipped to N − 1 against rounding. Compiled, so the geometry kernels call it in their
loop; Python code calls it the same way.
"""

from __future__ import annotations

from azgym.jit import jit

__all__ = ["ID_MODES", "misread_row"]

ID_MODES = ("oracle", "blink")
"""How detections are identified: by the light that made them, or by decoding its blinking."""


@jit(inline="always")
def misread_row(row: int, uniform: float, n_map: int) -> int:
    """The map row a misread of map row ``row`` is read as (needs ``n_map`` >= 2)."""
    shift = 1 + int(uniform * (n_map - 1))
    return (row + min(shift, n_map - 1)) % n_map
