"""A bag opened for reading: rosbags' reader behind azgym's errors, each naming the bag.

:func:`open_bag` opens a ROS 2 bag (its folder, or its ``.db3`` or ``.mcap`` file) or a ROS 1
``.bag`` file with rosbags' ``AnyReader``, with the types a bag without definitions needs.
Everything rosbags does with the bag's bytes (opening it, reading its index and messages,
deserializing one) happens behind :class:`Bag`, which turns any failure into an
:class:`~azgym.errors.InvalidInputError` naming the bag (and the topic and message): a
truncated, garbled or hostile file stops the import with a sentence, not a traceback.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TYPE_CHECKING, Any

from azgym.errors import InvalidInputError
from azgym.logs.problems import cut
from azgym.logs.ros.messages import DETECTIONS_TYPE, DETECTIONS_VERSION

if TYPE_CHECKING:
    from rosbags.highlevel import AnyReader
    from rosbags.interfaces import Connection
    from rosbags.typesys.store import Typestore

__all__ = ["Bag", "open_bag"]

_KINDS = "a ROS 2 bag (its folder, with metadata.yaml, or its .db3 or .mcap file) or a ROS 1 " \
         ".bag file"


class Bag:
    """An open bag: its topics, its messages, and deserializing them, with errors named.

    Attributes:
        path: The bag.
        reader: rosbags' reader.
        cdr: Whether its messages are ROS 2's CDR (else ROS 1's serialization).
        notes: What the import changed of what the bag says, each a sentence naming the topic
            (a robot's quirks that are read, not refused: docs/ros2.md).
    """

    def __init__(self, path: Path, reader: AnyReader) -> None:
        self.path = path
        self.reader = reader
        self.cdr = bool(reader.is2)
        self.notes: list[str] = []

    def topics(self) -> dict[str, tuple[str | None, int]]:
        """Each topic's type (None: several) and message count, by name."""
        return {name: (info.msgtype, info.msgcount) for name, info in self.reader.topics.items()}

    def listing(self) -> str:
        """The bag's topics with their types, for a message."""
        topics = self.topics()
        if not topics:
            return "the bag has no topic"
        return "the bag's topics: " + ", ".join(
            f"{name} ({kind or 'several types'}, {count} messages)"
            for name, (kind, count) in sorted(topics.items()))

    def connections(self, topic: str) -> list[Connection]:
        """The topic's connections."""
        return [c for c in self.reader.connections if c.topic == topic]

    def where(self, topic: str, index: int | None = None, field: str | None = None) -> str:
        """A place in the bag, for messages: ``BAG: topic /odom, message 12, field …``."""
        return ", ".join([f"{self.path}: topic {topic}",
                          *([f"message {index}"] if index is not None else []),
                          *([f"field {field}"] if field else [])])

    def deserialize(self, raw: bytes, typename: str, topic: str, index: int) -> Any:
        """One message's bytes as a message, or an error naming the topic and message."""
        try:
            return self.reader.deserialize(raw, typename)
        except Exception as exc:  # any failure on a hostile message's bytes is that message's
            raise InvalidInputError(f"{self.where(topic, index)}: not a valid {typename} "
                                    f"({cut(str(exc), 200)})") from None

    def messages(self, connections: list[Connection]) -> Iterator[tuple[Connection, int, bytes]]:
        """The connections' messages in the bag's time order: (connection, time [ns], bytes)."""
        iterator = self.reader.messages(connections=connections)
        count = 0
        while True:
            try:
                item = next(iterator)
            except StopIteration:
                return
            except Exception as exc:  # rosbags reading a damaged file: whatever it raises
                raise InvalidInputError(f"{self.path}: cannot read the bag after {count} "
                                        f"messages: {_reason(exc)}") from None
            count += 1
            yield item

    def define(self, typename: str, store: Typestore) -> None:
        """Make sure the reader knows ``typename``: the bag's definition, else ``store``'s.

        Raises:
            InvalidInputError: Neither defines it, or the bag defines azgym's detections in
                another version.
        """
        known = self.reader.typestore.fielddefs
        if typename not in known:
            if typename not in store.fielddefs:
                raise InvalidInputError(f"{self.path}: type {typename} is defined neither in "
                                        "the bag nor by azgym (give its definition: --msg-file)")
            self.reader.typestore.register(_with_parts(store, typename))
        if typename == DETECTIONS_TYPE and known[typename] != store.fielddefs[typename]:
            version = dict((name, value) for name, _, value in known[typename][0]).get(
                "VERSION", "unknown")
            fields = ", ".join(name for name, _ in known[typename][1])
            if version == DETECTIONS_VERSION:
                raise InvalidInputError(
                    f"{self.path}: the bag's {DETECTIONS_TYPE} says version {version} but its "
                    f"fields are {fields}; version {version}'s are "
                    f"{', '.join(name for name, _ in store.fielddefs[typename][1])} "
                    "(docs/ros2.md)")
            raise InvalidInputError(
                f"{self.path}: the bag's {DETECTIONS_TYPE} is version {version}, with fields "
                f"{fields}; this azgym reads version {DETECTIONS_VERSION} (docs/ros2.md)")


def _with_parts(store: Typestore, typename: str) -> dict[str, Any]:
    """``typename``'s definition and those of the types it holds, from ``store``."""
    found: dict[str, Any] = {}
    pending = [typename]
    while pending:
        name = pending.pop()
        if name in found or name not in store.fielddefs:
            continue
        found[name] = store.fielddefs[name]
        for _, (kind, argument) in found[name][1]:
            inner = argument[0] if kind in (3, 4) else (kind, argument)  # arrays, sequences
            if inner[0] == 2:  # a message type
                pending.append(inner[1])
    return found


def _reason(exc: BaseException) -> str:
    """What went wrong, in a line: the library's words, or the exception's kind."""
    return cut(str(exc).strip() or type(exc).__name__, 300)


@contextmanager
def open_bag(path: Path, store: Typestore) -> Iterator[Bag]:
    """Open a bag for reading (closed on leaving).

    Args:
        path: The bag: a ROS 2 bag's folder or storage file, or a ROS 1 ``.bag`` file.
        store: The types a bag without definitions is read with.

    Raises:
        InvalidInputError: No such bag, not a bag, or a bag rosbags cannot open (its reason).
    """
    from rosbags.highlevel import AnyReader

    if not (path.is_dir() or path.is_file()):
        raise InvalidInputError(f"{path}: no such bag ({_KINDS})")
    if path.is_file() and path.suffix not in (".bag", ".db3", ".mcap"):
        raise InvalidInputError(f"{path}: not a bag: {_KINDS}")
    try:
        reader = AnyReader([path], default_typestore=store)
        reader.open()
    except Exception as exc:  # rosbags opening whatever the path holds: whatever it raises
        raise InvalidInputError(f"{path}: cannot open the bag ({_KINDS}): {_reason(exc)}"
                                ) from None
    try:
        yield Bag(path, reader)
    finally:
        reader.close()
