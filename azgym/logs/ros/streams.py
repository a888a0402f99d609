"""One topic's messages as they arrive: counted, bounded, checked, and gathered into columns.

A :class:`Stream` counts its topic's messages (the first is message 0, in the bag's order) and
refuses a topic with more than :data:`~azgym.logs.ros.topics.MAX_MESSAGES` messages, or a
message larger than its topic allows, before deserializing it. :class:`Fields` gathers numbers
at fixed paths (odometry, IMU, a pose) in batches through the fast path of
:mod:`azgym.logs.ros.decode`; :class:`Transforms` a tf child frame's pose; :class:`Joint` one
joint's position; :class:`Text` the one string of a manifest or map topic. Every stream's
header stamps must not run back nor lie before 1970 (:meth:`Stream.times`); a stamp becomes float
seconds (:func:`~azgym.logs.ros.messages.seconds`). A topic none of whose stamps is filled (all
0) is timed by the bag's time of each message, with a note (:attr:`Bag.notes
<azgym.logs.ros.bag.Bag>`).
"""

from __future__ import annotations

from array import array
from typing import Any

import numpy as np

from azgym.errors import InvalidInputError
from azgym.logs.problems import seconds as shown_seconds
from azgym.logs.ros.bag import Bag
from azgym.logs.ros.decode import FieldPath, FixedLayout, read_columns, shown_path
from azgym.logs.ros.messages import seconds
from azgym.logs.ros.topics import MAX_MESSAGES

__all__ = ["BATCH", "BATCH_BYTES", "STAMP", "Fields", "Joint", "Stream", "Text", "Transforms"]

BATCH = 8192
"""Messages decoded at a time by :class:`Fields` (their bytes held until then)..."""
BATCH_BYTES = 16 * 2**20
"""... or fewer, once they hold this many bytes."""
STAMP: dict[str, FieldPath] = {"sec": ("header", "stamp", "sec"),
                               "nanosec": ("header", "stamp", "nanosec")}
"""A header's stamp, as two fields."""


class Stream:
    """A topic's messages, counted and bounded; subclasses gather what they need of each.

    Attributes:
        received: Each message's time in the bag [ns] (when it was recorded).
    """

    def __init__(self, bag: Bag, topic: str, typename: str, max_bytes: int) -> None:
        self.bag, self.topic, self.typename, self.max_bytes = bag, topic, typename, max_bytes
        self.count = 0
        self.received = array("q")

    def add(self, ns: int, raw: bytes) -> None:
        """Take the next message (its time in the bag [ns] and bytes)."""
        index = self.count
        self.count += 1
        if self.count > MAX_MESSAGES:
            raise InvalidInputError(f"{self.where()}: more than {MAX_MESSAGES} messages, the "
                                    "most a log's table holds (split the recording)")
        if len(raw) > self.max_bytes:
            raise InvalidInputError(f"{self.where(index)}: {len(raw)} bytes, more than the "
                                    f"{self.max_bytes} a message of it may have")
        self.received.append(ns)
        self.take(index, ns, raw)

    def take(self, index: int, ns: int, raw: bytes) -> None:
        """Gather what is needed of message ``index``."""
        raise NotImplementedError

    def where(self, index: int | None = None, field: str | None = None) -> str:
        """This topic (a message, a field) for messages."""
        return self.bag.where(self.topic, index, field)

    def message(self, index: int, raw: bytes) -> Any:
        """Message ``index`` deserialized."""
        return self.bag.deserialize(raw, self.typename, self.topic, index)

    def times(self, sec: np.ndarray, nanosec: np.ndarray, index: np.ndarray,
              field: str = "header.stamp") -> np.ndarray:
        """Stamps as float seconds, refused before 1970, with a nanosec of 1e9, or running back.

        Stamps that are all 0 were never filled (a driver that leaves the header as it is made):
        the messages are timed by their times in the bag instead, with a note.

        Args:
            sec: Each stamp's whole seconds.
            nanosec: Each stamp's nanoseconds.
            index: Each stamp's message.
            field: The stamp's field, for messages.
        """
        sec, nanosec = sec.astype(np.int64), nanosec.astype(np.int64)
        received = np.frombuffer(self.received, dtype=np.int64)[index]
        if sec.size and not (sec.any() or nanosec.any()) and received.any():
            self.bag.notes.append(f"{self.where(field=field)}: every header stamp is 0 (never "
                                  "filled): each message is timed by its time in the bag (when "
                                  "it was recorded) instead")
            sec, nanosec = np.divmod(received, 1_000_000_000)
        before = np.flatnonzero(sec < 0)
        if before.size:
            raise InvalidInputError(f"{self.where(int(index[before[0]]), field + '.sec')}: "
                                    f"{sec[before[0]]} is negative (a ROS time counts from "
                                    "1970)")
        bad = np.flatnonzero((nanosec < 0) | (nanosec >= 1_000_000_000))
        if bad.size:
            raise InvalidInputError(f"{self.where(int(index[bad[0]]), field + '.nanosec')}: "
                                    f"{nanosec[bad[0]]} is not a nanosecond count below 1e9")
        ns = sec * 1_000_000_000 + nanosec
        back = np.flatnonzero(ns[1:] < ns[:-1])
        time = seconds(sec, nanosec)
        if back.size:
            k = int(back[0]) + 1
            raise InvalidInputError(
                f"{self.where(int(index[k]), field)}: {shown_seconds(time[k])} is before the "
                f"message before's {shown_seconds(time[k - 1])} (message {int(index[k - 1])}): "
                "a topic's stamps never run back")
        return time

    def finite(self, values: np.ndarray, index: np.ndarray, field: str) -> np.ndarray:
        """``values`` (of messages ``index``), refused where one is NaN or infinite."""
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            raise InvalidInputError(f"{self.where(int(index[bad[0]]), field)}: "
                                    f"{values[bad[0]].item()!r} is not finite ({bad.size} "
                                    "message(s))")
        return values


class Fields(Stream):
    """Numbers at fixed paths of each message (one each) and its stamp, as columns."""

    def __init__(self, bag: Bag, topic: str, typename: str, max_bytes: int,
                 paths: dict[str, FieldPath]) -> None:
        super().__init__(bag, topic, typename, max_bytes)
        self.paths = STAMP | paths
        self.batch: list[bytes] = []
        self.held = 0
        self.first = 0
        self.layout: FixedLayout | None = None
        self.chunks: list[list[np.ndarray]] = []

    def take(self, index: int, ns: int, raw: bytes) -> None:
        """Hold the message's bytes; decode them a batch at a time."""
        if index == 0:  # the first message, deserialized: the template of the topic's layout
            self.message(0, raw)
            self.layout = FixedLayout.of(self.bag.reader.typestore, self.typename, raw,
                                         self.bag.cdr)
        self.batch.append(raw)
        self.held += len(raw)
        if len(self.batch) >= BATCH or self.held >= BATCH_BYTES:
            self.flush()

    def flush(self) -> None:
        """Decode the messages held."""
        if self.batch:
            first = self.first
            self.chunks.append(read_columns(
                self.batch, list(self.paths.values()), self.layout,
                lambda k, raw: self.message(first + k, raw)))
            self.first += len(self.batch)
            self.batch, self.held = [], 0

    def columns(self) -> dict[str, np.ndarray]:
        """Every message's fields by name, ``time`` (the stamp, checked) and ``index``."""
        self.flush()
        names = list(self.paths)
        values = {name: np.concatenate([chunk[k] for chunk in self.chunks]) if self.chunks
                  else np.zeros(0) for k, name in enumerate(names)}
        index = np.arange(self.count)
        values["time"] = self.times(values.pop("sec"), values.pop("nanosec"), index)
        return values | {"index": index}

    def check_finite(self, values: dict[str, np.ndarray], *names: str) -> None:
        """Refuse a NaN or infinity in the fields ``names``."""
        for name in names:
            self.finite(values[name], values["index"], shown_path(self.paths[name]))


class Transforms(Stream):
    """One tf child frame's pose under a parent, from each transform of it in a tf topic."""

    def __init__(self, bag: Bag, topic: str, typename: str, max_bytes: int, child: str,
                 parent: str) -> None:
        super().__init__(bag, topic, typename, max_bytes)
        self.child, self.parent = child, parent
        self.rows: list[tuple[int, int, int, float, float, float, float, float, float]] = []
        self.parents: set[str] = set()

    def take(self, index: int, ns: int, raw: bytes) -> None:
        """Keep the pose of each transform of the child under the parent."""
        for transform in self.message(index, raw).transforms:
            if transform.child_frame_id != self.child:
                continue
            self.parents.add(transform.header.frame_id)
            if transform.header.frame_id == self.parent:
                t, q = transform.transform.translation, transform.transform.rotation
                self.rows.append((index, transform.header.stamp.sec,
                                  transform.header.stamp.nanosec, t.x, t.y, q.x, q.y, q.z, q.w))
                if len(self.rows) > MAX_MESSAGES:
                    raise InvalidInputError(f"{self.where()}: more than {MAX_MESSAGES} "
                                            f"transforms of {self.child}")

    def columns(self) -> dict[str, np.ndarray]:
        """Index, time, x, y and the rotation's qx, qy, qz, qw of each transform found."""
        if not self.rows:
            under = f" (it has {', '.join(sorted(self.parents))} as parent)" \
                if self.parents else ""
            raise InvalidInputError(f"{self.where()}: no transform of child frame "
                                    f"{self.child!r} under {self.parent!r}{under}")
        table = np.array(self.rows, dtype=np.float64)
        index = table[:, 0].astype(np.int64)
        time = self.times(table[:, 1], table[:, 2], index, "transforms.header.stamp")
        names = ("x", "y", "qx", "qy", "qz", "qw")
        return {"index": index, "time": time} | {
            name: self.finite(table[:, 3 + k], index, f"transforms ({self.child})")
            for k, name in enumerate(names)}


class Joint(Stream):
    """One joint's position (a steering angle) from each joint-state message that names it."""

    def __init__(self, bag: Bag, topic: str, typename: str, max_bytes: int, joint: str) -> None:
        super().__init__(bag, topic, typename, max_bytes)
        self.joint = joint
        self.rows: list[tuple[int, int, int, float]] = []
        self.names: set[str] = set()

    def take(self, index: int, ns: int, raw: bytes) -> None:
        """Keep the joint's position, if the message names the joint."""
        message = self.message(index, raw)
        names = list(message.name)
        if self.joint not in names:
            self.names.update(names[:20])
            return
        k = names.index(self.joint)
        if k >= len(message.position):
            raise InvalidInputError(f"{self.where(index, 'position')}: {len(message.position)} "
                                    f"positions for {len(names)} joints (no position of "
                                    f"{self.joint!r})")
        self.rows.append((index, message.header.stamp.sec, message.header.stamp.nanosec,
                          float(message.position[k])))

    def columns(self) -> dict[str, np.ndarray] | None:
        """Index, time and position of each message naming the joint; None if none does."""
        if not self.rows:
            return None
        table = np.array(self.rows, dtype=np.float64)
        index = table[:, 0].astype(np.int64)
        return {"index": index, "time": self.times(table[:, 1], table[:, 2], index),
                "position": self.finite(table[:, 3], index, f"position ({self.joint})")}


class Text(Stream):
    """The one string of a topic (the manifest's or the map's text)."""

    def __init__(self, bag: Bag, topic: str, typename: str, max_bytes: int) -> None:
        super().__init__(bag, topic, typename, max_bytes)
        self.text: str | None = None

    def take(self, index: int, ns: int, raw: bytes) -> None:
        """Keep the text of the topic's only message."""
        if index:
            raise InvalidInputError(f"{self.where(index)}: a second message (the topic holds "
                                    "one text)")
        self.text = self.message(index, raw).data
