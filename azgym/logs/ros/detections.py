"""Camera frames from a detections topic: azgym's own messages, or a user's type through a mapping.

azgym's :data:`~azgym.logs.ros.messages.DETECTIONS_TYPE` carries everything a log's frame and
its detections hold. A user's own type gives its ids and azimuths (and any quality values) at
the field paths a :class:`Mapping` names; its frame number is a field's, or the message's
index; its time its header's stamp, or the bag's time of the message when it has no header.
Each message is checked as it arrives, and a problem names the topic, the message and the
field: arrays of different lengths, an azimuth not finite or outside [−π, π], an id that is
not a whole number a log can hold, an unknown label or event.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

import numpy as np

from azgym.errors import InvalidInputError
from azgym.logs.contents import EVENTS
from azgym.logs.files import MAX_TABLE_CELLS, MAX_TABLE_COLUMNS
from azgym.logs.problems import shown
from azgym.logs.ros.bag import Bag
from azgym.logs.ros.decode import FieldPath, field_values, shown_path
from azgym.logs.ros.streams import Stream
from azgym.sensing.labels import LABEL_NAMES

__all__ = ["MAX_ID", "Detections", "Mapping"]

MAX_ID = 10**18 - 1
"""The largest |id| a log holds: its whole numbers have at most 18 digits (docs/logs.md)."""
_QUALITY_NAME = re.compile(r"[A-Za-z0-9_.-]{1,64}")


@dataclass(frozen=True)
class Mapping:
    """Where a user's detection type holds what azgym needs (field paths).

    Attributes:
        ids: The beacon ids (one per detection).
        azimuths: The azimuths [rad] (one per detection, in the camera frame).
        quality: Each quality value's name and path (one per detection).
        frame: The frame number, or None (the message's index).
    """

    ids: FieldPath
    azimuths: FieldPath
    quality: tuple[tuple[str, FieldPath], ...] = ()
    frame: FieldPath | None = None


class Detections(Stream):
    """Each message a frame: its number, time and annotations, and its detections."""

    def __init__(self, bag: Bag, topic: str, typename: str, max_bytes: int,
                 mapping: Mapping | None) -> None:
        super().__init__(bag, topic, typename, max_bytes)
        self.mapping = mapping
        self.frames: list[tuple[int, int, int, str, str]] = []  # number, sec, nanosec, seq, event
        self.ids: list[np.ndarray] = []
        self.azimuths: list[np.ndarray] = []
        self.quality: list[np.ndarray] = []
        self.labels: list[list[str]] = []
        self.quality_names: tuple[str, ...] | None = None
        self.labelled: bool | None = None
        self.total = 0

    def take(self, index: int, ns: int, raw: bytes) -> None:
        """Check a frame's message and keep its frame and detections."""
        message = self.message(index, raw)
        if self.mapping is None:
            names = tuple(message.quality_names)
            number, ids, azimuths = message.frame, message.ids, message.azimuths
            quality = np.asarray(message.quality, dtype=np.float64)
            labels, sequence, event = list(message.labels), message.sequence, message.event
        else:
            names, labels, sequence, event = tuple(n for n, _ in self.mapping.quality), [], "", ""
            number = index if self.mapping.frame is None else \
                self._number(index, self._values(index, message, self.mapping.frame))
            ids, azimuths = (self._values(index, message, path)
                             for path in (self.mapping.ids, self.mapping.azimuths))
            quality = self._mapped_quality(index, message, len(ids))
        ids = self._ids(index, np.asarray(ids))
        azimuths = self._azimuths(index, np.asarray(azimuths, dtype=np.float64), ids.size)
        quality = self._quality(index, names, quality, ids.size)
        self._labels(index, labels, ids.size)
        if event not in EVENTS:
            raise InvalidInputError(f"{self.where(index, 'event')}: {shown(event)} is no event "
                                    "(known: kidnap, outage, or empty)")
        sec, nanosec = self._stamp(message, ns)
        self.frames.append((int(number), sec, nanosec, sequence, event))
        self.ids.append(ids)
        self.azimuths.append(azimuths)
        self.quality.append(quality)
        self.labels.append(labels)

    def _stamp(self, message: Any, ns: int) -> tuple[int, int]:
        """The header's stamp; the bag's time of the message for a type without a header."""
        header = getattr(message, "header", None)
        if header is None:
            return ns // 1_000_000_000, ns % 1_000_000_000
        return int(header.stamp.sec), int(header.stamp.nanosec)

    def _values(self, index: int, message: Any, path: FieldPath) -> np.ndarray:
        """The numbers at a user type's ``path`` in message ``index``, or an error naming it."""
        try:
            return field_values(message, path)
        except InvalidInputError as exc:
            raise InvalidInputError(f"{self.where(index, shown_path(path))}: {exc}") from None

    def _number(self, index: int, values: np.ndarray) -> int:
        """The frame number: the one whole number at the mapping's frame path."""
        assert self.mapping is not None and self.mapping.frame is not None
        field = shown_path(self.mapping.frame)
        if values.size != 1:
            raise InvalidInputError(f"{self.where(index, field)}: {values.size} values, a frame "
                                    "number is one (a path through a sequence gives one per "
                                    "element)")
        return int(self._whole(index, values, field, 1)[0])

    def _mapped_quality(self, index: int, message: Any, count: int) -> np.ndarray:
        """A user type's quality values as a (count, Q) array."""
        assert self.mapping is not None
        columns = [self._values(index, message, path) for _, path in self.mapping.quality]
        for (name, path), column in zip(self.mapping.quality, columns, strict=True):
            if column.size != count:
                raise InvalidInputError(f"{self.where(index, shown_path(path))}: {column.size} "
                                        f"values of quality {name} for {count} ids")
        return np.column_stack(columns).ravel() if columns else np.zeros(0)

    def _whole(self, index: int, values: np.ndarray, field: str, count: int) -> np.ndarray:
        """Whole numbers of at most 18 digits (a log's), as int64."""
        if values.dtype.kind == "f":
            bad = ~np.isfinite(values) | (np.abs(values) > MAX_ID)
            bad |= ~bad & (values != np.floor(np.where(bad, 0.0, values)))
        elif values.dtype.kind in "iu":
            bad = (values > MAX_ID) | ((values < -MAX_ID) if values.dtype.kind == "i" else False)
        elif values.dtype.kind == "b":
            bad = np.zeros(values.shape, dtype=bool)
        else:
            raise InvalidInputError(f"{self.where(index, field)}: not numbers")
        if np.any(bad):
            k = int(np.flatnonzero(bad)[0])
            raise InvalidInputError(f"{self.where(index, field)}: {values[k].item()!r} (item "
                                    f"{k} of {count}) is not a whole number within ±{MAX_ID}")
        return values.astype(np.int64)

    def _ids(self, index: int, ids: np.ndarray) -> np.ndarray:
        field = "ids" if self.mapping is None else shown_path(self.mapping.ids)
        ids = self._whole(index, ids.ravel(), field, ids.size)
        self.total += ids.size
        width = 4 + len(self.quality_names or ())
        if self.total * width > MAX_TABLE_CELLS:
            raise InvalidInputError(f"{self.where(index)}: more detections in all than a log's "
                                    f"table holds ({MAX_TABLE_CELLS} cells; split the recording)")
        return ids

    def _azimuths(self, index: int, azimuths: np.ndarray, count: int) -> np.ndarray:
        field = "azimuths" if self.mapping is None else shown_path(self.mapping.azimuths)
        azimuths = azimuths.ravel()
        if azimuths.size != count:
            raise InvalidInputError(f"{self.where(index, field)}: {azimuths.size} azimuths for "
                                    f"{count} ids (one each)")
        bad = np.flatnonzero(~(np.abs(azimuths) <= math.pi))
        if bad.size:
            k = int(bad[0])
            raise InvalidInputError(f"{self.where(index, field)}: {azimuths[k].item()!r} (item "
                                    f"{k}) is not in [-π, π] (radians, counter-clockwise from "
                                    "the camera's x-axis)")
        return azimuths

    def _quality(self, index: int, names: tuple[str, ...], values: np.ndarray, count: int
                 ) -> np.ndarray:
        """The quality values as (count, Q), the names the same in every message."""
        if self.quality_names is None and (count or names):
            self.quality_names = self._names(index, names)
        given = self.quality_names or ()
        if count and names != given or names and names != given:
            raise InvalidInputError(f"{self.where(index, 'quality_names')}: {list(names)}, not "
                                    f"the {list(given)} of the messages before (every frame has "
                                    "the same quality values)")
        if values.size != count * len(given):
            raise InvalidInputError(f"{self.where(index, 'quality')}: {values.size} values for "
                                    f"{count} ids × {len(given)} quality names (row-major)")
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise InvalidInputError(f"{self.where(index, 'quality')}: {values[bad[0]].item()!r} "
                                    f"(item {bad[0]}) is not finite")
        return values.reshape(count, len(given))

    def _names(self, index: int, names: tuple[str, ...]) -> tuple[str, ...]:
        bad = [name for name in names if not _QUALITY_NAME.fullmatch(name)]
        if bad or len(set(names)) != len(names) or len(names) > MAX_TABLE_COLUMNS - 5:
            raise InvalidInputError(
                f"{self.where(index, 'quality_names')}: {shown(list(names), 200)}: each a "
                "distinct name of ASCII letters, digits, '_', '.' and '-' (at most 64), and at "
                f"most {MAX_TABLE_COLUMNS - 5} of them")
        return names

    def _labels(self, index: int, labels: list[str], count: int) -> None:
        if labels and len(labels) != count:
            raise InvalidInputError(f"{self.where(index, 'labels')}: {len(labels)} labels for "
                                    f"{count} ids (one each, or none)")
        for k, label in enumerate(labels):
            if label not in LABEL_NAMES:
                raise InvalidInputError(f"{self.where(index, 'labels')}: {shown(label)} (item "
                                        f"{k}) is no label (known: {', '.join(LABEL_NAMES)})")
        if count:
            if self.labelled is not None and self.labelled != bool(labels):
                raise InvalidInputError(f"{self.where(index, 'labels')}: labels in some frames "
                                        "only (give every detection's, or none)")
            self.labelled = bool(labels)

    def columns(self) -> tuple[dict[str, Any], dict[str, Any]]:
        """The frames and their detections, as a log's columns.

        Returns:
            The frames (``frame``, ``time``; ``sequence`` and ``event``, None when no frame
            has one) and the detections (``row``: the frame's, ``id``, ``azimuth``,
            ``quality`` (D, Q), ``label``: None without labels).
        """
        if not self.frames:
            raise InvalidInputError(f"{self.where()}: no messages (a log holds a frame at "
                                    "least)")
        number, sec, nanosec, sequence, event = (
            list(column) for column in zip(*self.frames, strict=True))
        index = np.arange(len(number))
        frames: dict[str, Any] = {
            "frame": np.array(number, dtype=np.int64),
            "time": self.times(np.array(sec), np.array(nanosec), index),
            "sequence": self._annotation(sequence, "sequence"),
            "event": event if any(event) else None}
        back = np.flatnonzero(np.diff(frames["frame"]) <= 0)
        if back.size:
            k = int(back[0]) + 1
            field = "frame" if self.mapping is None or self.mapping.frame is not None else None
            raise InvalidInputError(f"{self.where(k, field)}: frame {number[k]} after frame "
                                    f"{number[k - 1]} (message {k - 1}): frame numbers increase")
        counts = [ids.size for ids in self.ids]
        width = len(self.quality_names or ())
        detections = {
            "row": np.repeat(index, counts), "id": np.concatenate(self.ids),
            "azimuth": np.concatenate(self.azimuths),
            "quality": np.concatenate(self.quality) if self.quality else np.zeros((0, width)),
            "label": [label for labels in self.labels for label in labels]
            if self.labelled else None}
        return frames, detections

    def _annotation(self, values: list[str], field: str) -> list[str] | None:
        """A frame annotation every message gives, or None when none does."""
        if not any(values):
            return None
        if not all(values):
            k = values.index("")
            raise InvalidInputError(f"{self.where(k, field)}: empty, while other frames name "
                                    f"their {field} (name it on every frame, or on none)")
        return values
