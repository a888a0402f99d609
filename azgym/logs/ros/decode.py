"""A topic's messages as numbers: field paths checked against the type, read fast where they can be.

A field is named by its path of names (``twist.twist.linear.x``; a number picks an element of a
fixed array: ``linear_acceleration_covariance.0``), checked against the bag's own definition of
the type before any message is read (:func:`field_problem`). :func:`field_values` reads a path
from a deserialized message; a path through a sequence of messages (``blobs.id``) gives one
value per element.

Most messages azgym reads have a fixed layout: no sequence, and strings (the header's
``frame_id``) the same in every message, so each number lies at the same offset of every
message's bytes. :class:`FixedLayout` finds those offsets in a topic's first message and reads a
batch of messages as numpy columns; a message of another size, or whose strings differ, is
deserialized on its own. Both give the same values, bit for bit (tested); the fast one is what
lets an import read a 100 Hz odometry at a few hundred thousand messages a second
(``baselines/bag_speed.py``).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from azgym.errors import InvalidInputError

if TYPE_CHECKING:
    from rosbags.typesys.store import Typestore

__all__ = ["FieldPath", "FixedLayout", "field_problem", "field_values", "parse_path",
           "read_columns", "shown_path"]

FieldPath = tuple[str | int, ...]
"""A field's path: names, and element numbers of fixed arrays."""

_NUMBERS = {"bool": "?", "byte": "u1", "char": "u1", "int8": "i1", "uint8": "u1",
            "int16": "<i2", "uint16": "<u2", "int32": "<i4", "uint32": "<u4", "int64": "<i8",
            "uint64": "<u8", "float32": "<f4", "float64": "<f8"}
"""The numeric base types and their numpy types as serialized (little-endian)."""
_PART = re.compile(r"[A-Za-z][A-Za-z0-9_]*|[0-9]+")
_BASE, _NAME, _ARRAY, _SEQUENCE = 1, 2, 3, 4
"""rosbags' node types of a field's description (rosbags.interfaces.Nodetype)."""


def parse_path(text: str, option: str) -> FieldPath:
    """A dotted field path (``pose.position.x``, ``covariance.0``).

    Raises:
        InvalidInputError: Not a path (``option`` names where it was given).
    """
    parts = text.split(".")
    if not text or not all(_PART.fullmatch(part) for part in parts):
        raise InvalidInputError(f"{option}: {text!r} is no field path (field names joined by dots, "
                         "e.g. detections.azimuth)")
    return tuple(int(part) if part.isdigit() else part for part in parts)


def shown_path(path: FieldPath) -> str:
    """A path as written: ``twist.twist.linear.x``."""
    return ".".join(map(str, path))


def field_problem(store: Typestore, typename: str, path: FieldPath) -> str | None:
    """Why ``path`` names no number (or numeric array) of ``typename``, or None when it does."""
    current: Any = (_NAME, typename)
    for k, part in enumerate(path):
        kind, argument = current
        if kind in (_ARRAY, _SEQUENCE):
            current, _ = argument  # a sequence of messages: the path goes on in each element
            kind, argument = current
            if isinstance(part, int):
                if kind != _BASE or k != len(path) - 1:
                    return f"{shown_path(path[:k + 1])}: an element number ends a path to a " \
                           "number"
                continue
        if isinstance(part, int) or kind != _NAME:
            return f"{shown_path(path[:k])} has no field {part!r}"
        if argument not in store.fielddefs:
            return f"type {argument} is not defined (give its .msg file)"
        fields = dict(store.fielddefs[argument][1])
        if part not in fields:
            return f"{argument} has no field {part!r} (its fields: {', '.join(fields)})"
        current = fields[part]
    kind, argument = current
    leaf = argument[0] if kind in (_ARRAY, _SEQUENCE) else current
    if leaf[0] != _BASE or leaf[1][0] not in _NUMBERS:
        return f"{shown_path(path)} is not a number (nor an array of numbers)"
    return None


def field_values(message: object, path: FieldPath) -> np.ndarray:
    """The numbers at ``path`` in a deserialized message, as a 1-D array.

    A path through a sequence of messages gives one number per element.

    Raises:
        InvalidInputError: An element number past the end of a sequence (the message does not
            say where: its caller does).
    """
    items: list[Any] = [message]
    for k, part in enumerate(path):
        if isinstance(part, int):
            short = [len(item) for item in items if part >= len(item)]
            if short:
                raise InvalidInputError(f"no element {part} ({shown_path(path[:k])} has "
                                        f"{short[0]})")
            items = [item[part] for item in items]
            continue
        values = [getattr(item, part) for item in items]
        items = [element for value in values
                 for element in (value if isinstance(value, list) else [value])]
    if len(items) == 1 and isinstance(items[0], np.ndarray):
        return items[0]
    return np.concatenate([np.atleast_1d(np.asarray(item)) for item in items]) if items else \
        np.zeros(0)


@dataclass(frozen=True)
class FixedLayout:
    """Where each number of a message lies in its bytes, for messages shaped like a template.

    Attributes:
        size: The template's length in bytes.
        template: The template's bytes.
        kept: The offsets of the bytes every message read must share with the template: the
            encapsulation (CDR) and each string with its length.
        fields: Each numeric field's offset and numpy type, by path.
    """

    size: int
    template: np.ndarray
    kept: np.ndarray
    fields: dict[FieldPath, tuple[int, str]]

    @classmethod
    def of(cls, store: Typestore, typename: str, template: bytes, cdr: bool
           ) -> FixedLayout | None:
        """The layout of ``typename`` as ``template`` (a valid message of it) has it, or None.

        None when the type has a sequence (its layout varies from message to message) or the
        template is big-endian.

        Args:
            store: The types.
            typename: The message type.
            template: A message's bytes (serialized by ``cdr``, else ROS 1).
            cdr: Whether ROS 2's CDR (aligned, behind a 4-byte encapsulation), else ROS 1's.
        """
        if cdr and template[:2] != b"\x00\x01":
            return None
        fields: dict[FieldPath, tuple[int, str]] = {}
        spans = [(0, 2)] if cdr else []
        end = _walk(store, typename, template, 4 if cdr else 0, cdr, (), fields, spans)
        if end is None or end > len(template):
            return None
        kept = np.concatenate([np.arange(a, b) for a, b in spans]) if spans else \
            np.zeros(0, dtype=np.int64)
        return cls(len(template), np.frombuffer(template, dtype=np.uint8), kept, fields)

    def read(self, raws: Sequence[bytes], paths: Sequence[FieldPath]
             ) -> tuple[np.ndarray, list[np.ndarray]]:
        """Which of ``raws`` have this layout, and the values at ``paths`` of those.

        Returns:
            A mask of the messages read, and each path's values (as float64 or int64), one per
            message read, in order.
        """
        sized = np.fromiter((len(raw) == self.size for raw in raws), dtype=bool,
                            count=len(raws))
        rows = np.frombuffer(b"".join(raw for raw, ok in zip(raws, sized, strict=True) if ok),
                             dtype=np.uint8).reshape(-1, self.size)
        same = (rows[:, self.kept] == self.template[self.kept]).all(axis=1)
        rows = rows[same]
        read = sized.copy()
        read[sized] = same
        columns = []
        for path in paths:
            offset, dtype = self.fields[path]
            width = np.dtype(dtype).itemsize
            values = np.ascontiguousarray(rows[:, offset:offset + width]).view(dtype).ravel()
            columns.append(_widened(values))
        return read, columns


def _aligned(position: int, size: int, cdr: bool) -> int:
    """CDR aligns a number to its size, counted from the end of the 4-byte encapsulation."""
    return position if not cdr else 4 + -(-(position - 4) // size) * size


def _walk(store: Typestore, typename: str, raw: bytes, position: int, cdr: bool,
          prefix: FieldPath, fields: dict[FieldPath, tuple[int, str]],
          spans: list[tuple[int, int]]) -> int | None:
    """Lay out ``typename``'s fields from ``position``; the end, or None (no fixed layout)."""
    definition: Any = store.fielddefs[typename][1]
    for name, (kind, argument) in definition:
        path = (*prefix, name)
        if kind == _NAME:
            end = _walk(store, argument, raw, position, cdr, path, fields, spans)
            if end is None:
                return None
            position = end
        elif kind == _BASE and argument[0] == "string":
            position = _aligned(position, 4, cdr)
            if position + 4 > len(raw):
                return None
            length = int.from_bytes(raw[position:position + 4], "little")
            spans.append((position, position + 4 + length))
            position += 4 + length
        elif kind == _BASE and argument[0] in _NUMBERS:
            dtype = _NUMBERS[argument[0]]
            position = _aligned(position, np.dtype(dtype).itemsize, cdr)
            fields[path] = (position, dtype)
            position += np.dtype(dtype).itemsize
        elif kind == _ARRAY and argument[0][0] == _BASE and argument[0][1][0] in _NUMBERS:
            dtype = _NUMBERS[argument[0][1][0]]
            width = np.dtype(dtype).itemsize
            position = _aligned(position, width, cdr)
            for k in range(argument[1]):
                fields[(*path, k)] = (position + k * width, dtype)
            position += argument[1] * width
        else:  # a sequence, an array of strings or messages, a long double: no fixed layout
            return None
    return position


def read_columns(raws: Sequence[bytes], paths: Sequence[FieldPath], layout: FixedLayout | None,
                 deserialize: Callable[[int, bytes], object]) -> list[np.ndarray]:
    """The values at ``paths`` of every message (one number each): fast where the layout fits.

    Args:
        raws: The messages' bytes.
        paths: The fields, each one number per message.
        layout: The topic's fixed layout, or None.
        deserialize: A message (its row in ``raws`` and bytes) deserialized; raises on a
            malformed one.
    """
    read = np.zeros(len(raws), dtype=bool)
    fast: list[np.ndarray] = []
    if layout is not None:
        read, fast = layout.read(raws, paths)
    slow = np.flatnonzero(~read)
    messages = [deserialize(int(k), raws[int(k)]) for k in slow]
    columns = []
    for p, path in enumerate(paths):
        parts = [(read, fast[p])] if fast else []
        if slow.size:
            parts.append((slow, _widened(np.array([field_values(message, path)[0]
                                                     for message in messages]))))
        values = np.empty(len(raws), dtype=np.result_type(*(part.dtype for _, part in parts)))
        for rows, part in parts:
            values[rows] = part
        columns.append(values)
    return columns


def _widened(values: np.ndarray) -> np.ndarray:
    """Numbers as float64 (floating point) or int64 (whole)."""
    return values.astype(np.float64 if values.dtype.kind == "f" else np.int64)
