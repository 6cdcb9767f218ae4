"""CDR (ROS 2's XCDR1, little endian) from plain values, without building message objects.

A ``Layout`` is compiled once per message type from the type store's own definition
(``messages.typestore()``), so it cannot disagree with the schema written into a log. It flattens
the type into steps:

- a *run*: consecutive fixed-size primitives (nested structs and fixed arrays included), packed by
  one ``struct`` format; CDR aligns each primitive to its size from the start of the data, so a run
  has one format per start offset modulo 8;
- a *string*: uint32 length (with the NUL), the UTF-8 bytes, NUL;
- a *sequence*: uint32 count, then its elements: a numpy array (or anything ``numpy.asarray`` takes)
  or bytes for primitives, a list of value tuples (each in the element type's layout order) for
  messages, a list of str for strings. A contiguous array of the element type is not copied before
  the one final join, so large blobs (a LaserScan's ranges, a PointCloud2's points) cost one copy.

``Layout(typename).encode(values)`` takes the values in field order, depth first, every element of a
fixed array as its own value (an Imu: sec, nanosec, frame_id, x, y, z, w, 9 covariances, ...), and
returns the bytes ``Typestore.serialize_cdr(msg, typename)`` gives for the equal message (the 4-byte
encapsulation header included). ``layout(typename)`` returns the compiled layout, made once.

``GrowingSequence(typename)`` serves a message published again and again with one more element at
the end of its last field, a sequence of messages (a path of every pose so far): each element is
encoded once, when it is added, and ``encode(head)`` joins the other fields to the elements encoded
so far; the same bytes as ``Layout.encode`` of the whole message, in time proportional to what was added.
"""

from __future__ import annotations

import struct
import sys
from functools import cache
from typing import Any

import numpy as np
from rosbags.interfaces import Nodetype

from navlog.replay import messages

__all__ = ["GrowingSequence", "Layout", "layout"]

_HEADER = b"\x00\x01\x00\x00"  # CDR_LE, no options
_U32 = struct.Struct("<I")
_PAD = tuple(b"\x00" * n for n in range(8))
# ROS 2 primitive -> (struct code, size)
_PRIMITIVES = {
    "bool": ("?", 1),
    "byte": ("B", 1),
    "char": ("B", 1),
    "int8": ("b", 1),
    "uint8": ("B", 1),
    "int16": ("h", 2),
    "uint16": ("H", 2),
    "int32": ("i", 4),
    "uint32": ("I", 4),
    "int64": ("q", 8),
    "uint64": ("Q", 8),
    "float32": ("f", 4),
    "float64": ("d", 8),
}
_RUN, _STRING, _SEQ_MSG, _SEQ_PRIM, _SEQ_STR = range(5)

if sys.byteorder != "little":  # pragma: no cover - every supported platform is little endian
    raise ImportError("navlog.replay.io.cdr writes little-endian CDR and needs a little-endian machine")


def _run_formats(codes: list[tuple[str, int]]) -> tuple[struct.Struct, ...]:
    """The run's ``struct`` format for each start offset modulo 8 (padding before every primitive)."""
    out = []
    for start in range(8):
        pos, fmt = start, ["<"]
        for code, size in codes:
            pad = -pos % size
            fmt.append("x" * pad + code)
            pos += pad + size
        out.append(struct.Struct("".join(fmt)))
    return tuple(out)


class Layout:
    """The compiled CDR layout of one message type; see the module docstring."""

    def __init__(self, typename: str) -> None:
        self.typename = typename
        steps: list[tuple[int, Any, int]] = []
        run: list[tuple[str, int]] = []

        def close_run() -> None:
            if run:
                steps.append((_RUN, _run_formats(run), len(run)))
                run.clear()

        def element(node: tuple[Any, Any]) -> None:
            kind, detail = node
            if kind == Nodetype.BASE:
                name = detail[0]
                if name == "string":
                    close_run()
                    steps.append((_STRING, None, 1))
                elif name in _PRIMITIVES:
                    run.append(_PRIMITIVES[name])
                else:
                    raise NotImplementedError(f"{typename}: CDR of {name} fields is not supported")
            elif kind == Nodetype.NAME:
                struct_fields(detail)
            elif kind == Nodetype.ARRAY:
                sub, count = detail
                for _ in range(count):
                    element(sub)
            elif kind == Nodetype.SEQUENCE:
                sub, _bound = detail
                close_run()
                sub_kind, sub_detail = sub
                if sub_kind == Nodetype.NAME:
                    steps.append((_SEQ_MSG, layout(sub_detail), 1))
                elif sub_kind == Nodetype.BASE and sub_detail[0] == "string":
                    steps.append((_SEQ_STR, None, 1))
                elif sub_kind == Nodetype.BASE and sub_detail[0] in _PRIMITIVES:
                    code, size = _PRIMITIVES[sub_detail[0]]
                    steps.append((_SEQ_PRIM, (np.dtype("<" + code), size), 1))
                else:
                    raise NotImplementedError(f"{typename}: CDR of sequences of {sub} is not supported")
            else:  # pragma: no cover - the type store knows no other kinds
                raise NotImplementedError(f"{typename}: CDR of {kind} fields is not supported")

        def struct_fields(name: str) -> None:
            for _field, node in messages.typestore().get_msgdef(name).fields:
                element(node)

        struct_fields(typename)
        close_run()
        self._steps = tuple(steps)
        self.size = sum(n for _, _, n in steps)  # how many values ``encode`` takes

    def _head(self) -> Layout:
        """This layout without its last step (``GrowingSequence``)."""
        head = object.__new__(Layout)
        head.typename, head._steps = self.typename, self._steps[:-1]
        head.size = self.size - self._steps[-1][2]
        return head

    def encode(self, values: Any) -> bytes:
        """CDR bytes (with the encapsulation header) of ``values``, in field order; see the module docstring."""
        parts = [_HEADER]
        self._encode(values, 0, parts)
        return b"".join(parts)

    def _encode(self, values: Any, pos: int, parts: list[bytes]) -> int:
        i = 0
        for kind, arg, n in self._steps:
            if kind == _RUN:
                fmt = arg[pos & 7]
                parts.append(fmt.pack(*values[i : i + n]))
                pos += fmt.size
                i += n
                continue
            value = values[i]
            i += 1
            pad = -pos & 3
            if kind == _STRING:
                raw = value.encode()
                parts.append(_PAD[pad] + _U32.pack(len(raw) + 1) + raw + b"\x00")
                pos += pad + 5 + len(raw)
            elif kind == _SEQ_MSG:
                parts.append(_PAD[pad] + _U32.pack(len(value)))
                pos += pad + 4
                for item in value:
                    pos = arg._encode(item, pos, parts)
            elif kind == _SEQ_STR:
                parts.append(_PAD[pad] + _U32.pack(len(value)))
                pos += pad + 4
                for s in value:
                    raw = s.encode()
                    pad = -pos & 3
                    parts.append(_PAD[pad] + _U32.pack(len(raw) + 1) + raw + b"\x00")
                    pos += pad + 5 + len(raw)
            else:  # _SEQ_PRIM
                dtype, size = arg
                if isinstance(value, bytes):
                    raw, nbytes = value, len(value)
                else:  # the array's own buffer, copied once by the final join
                    raw = np.ascontiguousarray(value, dtype=dtype)
                    nbytes = raw.nbytes
                count = nbytes // size
                parts.append(_PAD[pad] + _U32.pack(count))
                pos += pad + 4
                if count:
                    pad = -pos % size
                    if pad:
                        parts.append(_PAD[pad])
                    parts.append(raw)
                    pos += pad + nbytes
        return pos


@cache
def layout(typename: str) -> Layout:
    """The compiled layout of a type of the shared type store, made once per type."""
    return Layout(typename)


class GrowingSequence:
    """CDR of a message whose last field is a sequence of messages that only grows (module docstring)."""

    def __init__(self, typename: str) -> None:
        whole = layout(typename)
        kind, element, _ = whole._steps[-1]
        if kind != _SEQ_MSG:
            raise ValueError(f"{typename}: its last field is not a sequence of messages")
        self._head, self._element = whole._head(), element
        self._start = -1  # where the first element starts (modulo 8): the encoded elements' alignment
        self._body = b""  # the elements encoded so far
        self._count = 0
        self._end = 0  # where the last of them ends

    def __len__(self) -> int:
        return self._count

    def encode(self, head: Any, added: Any = ()) -> bytes:
        """CDR bytes (with the encapsulation header) of the message: ``head``, its fields but the last
        (as ``Layout.encode`` takes them), then every element added so far and ``added`` (value tuples)."""
        parts = [_HEADER]
        pos = self._head._encode(head, 0, parts)
        pad = -pos & 3
        parts.append(_PAD[pad])
        pos += pad + 4
        if self._start < 0 or not self._count:
            self._start = self._end = pos & 7
        elif pos & 7 != self._start:  # the elements encoded so far would be aligned otherwise
            raise ValueError(f"{self._head.typename}: the fields before the sequence changed their size modulo 8")
        at, new, count = self._end, [self._body], self._count  # committed once every element is encoded
        for item in added:
            at = self._element._encode(item, at, new)
            count += 1
        self._body, self._count, self._end = b"".join(new), count, at
        parts += (_U32.pack(self._count), self._body)
        return b"".join(parts)
