"""The blinking code: how a beacon sends its id by switching on and off from frame to frame.

The paper's beacons transmit their ids by visible light communication, sampled by the camera
frame by frame (RUPSOOK, its ref. [14]). azgym's code is an on-off keying at the frame rate:

* a start marker ``1 1 1 0`` (three lit frames, one dark),
* then the id's bits, most significant first, and an even-parity bit, each Manchester coded
  (1 → lit, dark; 0 → dark, lit).

Manchester pairs never hold three equal frames in a row, so a run of three or more lit frames
happens only at a marker, and a beacon is never dark for more than two frames running. The
decoder reads a codeword as it completes: a marker right before the last 2 (bits + 1) frames,
then the pairs; a pair ``1 1`` or ``0 0`` or a parity failure rejects the codeword.

This module holds the code alone (:class:`BlinkCode`: a codeword's frames and their decoding)
and the constants it fixes; following blobs on the image and reading their lit/dark histories
is :mod:`azgym.sensing.image.blob_tracker`'s job.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from azgym.errors import InvalidInputError

__all__ = ["BLINK_CAMERA_RATE_HZ", "MARKER", "MAX_DARK_RUN", "BlinkCode"]

MARKER = (1, 1, 1, 0)
"""The start marker: three lit frames and a dark one."""
BLINK_CAMERA_RATE_HZ = 30.0
"""The camera's frame rate for blinking ids [Hz]: the code changes every frame, and the tracker
needs blobs to move little between frames (see ``azgym study ids``)."""

MAX_BITS = 30
"""The longest ids a code sends, in bits: a codeword is then 66 frames long, over 2 s at 30 Hz."""
MAX_DARK_RUN = 2
"""The most frames in a row a blinking beacon is dark (pairs ``1 0 | 0 1``, or the marker's dark
frame and a ``0 1``): a tracker must keep a track through that many dark frames."""


@dataclass(frozen=True)
class BlinkCode:
    """The on-off code of ids of ``bits`` bits (see the module's docstring).

    Attributes:
        bits: Bits per id; ids 0 .. 2**bits - 1 can be sent.
    """

    bits: int

    def __post_init__(self) -> None:
        if not (isinstance(self.bits, int) and 1 <= self.bits <= MAX_BITS):
            raise InvalidInputError(f"BlinkCode.bits must be an integer in [1, {MAX_BITS}], got "
                                    f"{self.bits!r}")

    @classmethod
    def for_ids(cls, ids: ArrayLike) -> BlinkCode:
        """The shortest code that sends every one of ``ids`` (non-negative integers)."""
        values = np.asarray(ids)
        if values.size == 0 or values.min() < 0:
            raise InvalidInputError("ids: blinking codes send non-negative ids only, got "
                                    f"{values.min() if values.size else 'none'}")
        return cls(max(1, int(values.max()).bit_length()))

    @property
    def period(self) -> int:
        """Frames per codeword: the marker and two frames per data and parity bit."""
        return len(MARKER) + 2 * (self.bits + 1)

    def frames(self, beacon_id: int) -> np.ndarray:
        """The lit (True) and dark frames of one codeword of ``beacon_id``, shape (period,)."""
        if not 0 <= beacon_id < 2**self.bits:
            raise InvalidInputError(f"beacon_id: {beacon_id} does not fit in {self.bits} bits")
        data = [(beacon_id >> (self.bits - 1 - k)) & 1 for k in range(self.bits)]
        data.append(sum(data) % 2)  # even parity
        lit = list(MARKER)
        for bit in data:
            lit += [1, 0] if bit else [0, 1]
        return np.array(lit, dtype=bool)

    def decode(self, history: ArrayLike) -> int | None:
        """The id of the codeword that ends at the last frame of a lit/dark history, if one does.

        A tracker calls this every frame, so every codeword is read once, as it completes.

        Args:
            history: Lit (1) and dark (0) frames of one blob, oldest first.

        Returns:
            The id; -1 if the codeword is corrupt (a pair ``1 1`` or ``0 0``, or bad parity);
            None if no codeword ends at the last frame (no marker right before its data).
        """
        lit = np.asarray(history, dtype=bool)
        d = len(lit) - 1 - 2 * (self.bits + 1)  # where the marker's dark frame must be
        # The marker: three lit frames (``MARKER``), then the dark frame d.
        if d < 3 or lit[d] or not (lit[d - 1] and lit[d - 2] and lit[d - 3]):
            return None
        first, second = lit[d + 1::2], lit[d + 2::2]
        if np.any(first == second):
            return -1
        if np.count_nonzero(first) % 2:
            return -1
        value = 0
        for bit in first[:-1]:
            value = (value << 1) | int(bit)
        return value
