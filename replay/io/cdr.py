"""CDR (ROS 2's XCDR1, little endian) from and to plain values, without building message objects.

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

``Layout.decode(data, max_len)`` is the other way: the values of a message in the same order, as the
type store's deserializer holds them (a fixed array of primitives as one read-only array over the
bytes), or an error on bytes that deserializer refuses. ``RepeatedShapes`` reads a stream whose
messages repeat a few shapes (a /tf stream's frames) with one ``struct`` call per message.

``GrowingSequence(typename)`` serves a message published again and again with one more element at
the end of its last field, a sequence of messages (a path of every pose so far): each element is
encoded once, when it is added, and ``encode(head)`` joins the other fields to the elements encoded
so far; the same bytes as ``Layout.encode`` of the whole message, in time proportional to what was added.

``UniformSequence(typename)`` serves a message whose last field is a sequence of messages of one shape
(every element holds the same strings: a path of N poses in one frame, a cloud of poses): the elements'
numbers come as columns (an array of N values, or one value for every element) and are written into
one NumPy record array per element alignment, without a value tuple per element; the same bytes as
``Layout.encode`` of the whole message.
"""

from __future__ import annotations

import operator
import struct
import sys
from functools import cache
from typing import Any

import numpy as np
from rosbags.interfaces import Nodetype

from navlog.replay import messages

__all__ = ["GrowingSequence", "Layout", "RepeatedShapes", "UniformSequence", "layout"]

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
_RUN, _STRING, _SEQ_MSG, _SEQ_PRIM, _SEQ_STR, _ARRAY = range(6)

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


class _Steps:
    """The steps of a layout as they are compiled: consecutive primitives gathered into runs."""

    def __init__(self) -> None:
        self.steps: list[tuple[int, Any, int]] = []
        self.run: list[tuple[str, int]] = []

    def close_run(self) -> None:
        if self.run:
            self.steps.append((_RUN, _run_formats(self.run), len(self.run)))
            self.run = []

    def add(self, kind: int, arg: Any) -> None:
        self.close_run()
        self.steps.append((kind, arg, 1))


class Layout:
    """The compiled CDR layout of one message type; see the module docstring."""

    def __init__(self, typename: str) -> None:
        self.typename = typename
        enc, dec = _Steps(), _Steps()  # ``encode``'s steps and ``decode``'s (a fixed array of primitives as one array)
        types: set[str] = set()

        def both(kind: int, arg: Any) -> None:
            enc.add(kind, arg)
            dec.add(kind, arg)

        def element(node: tuple[Any, Any]) -> None:
            kind, detail = node
            if kind == Nodetype.BASE:
                name = detail[0]
                if name == "string":
                    both(_STRING, None)
                elif name in _PRIMITIVES:
                    enc.run.append(_PRIMITIVES[name])
                    dec.run.append(_PRIMITIVES[name])
                else:
                    raise NotImplementedError(f"{typename}: CDR of {name} fields is not supported")
            elif kind == Nodetype.NAME:
                struct_fields(detail)
            elif kind == Nodetype.ARRAY:
                sub, count = detail
                if sub[0] == Nodetype.BASE and sub[1][0] in _PRIMITIVES:
                    code, size = _PRIMITIVES[sub[1][0]]
                    enc.run.extend([(code, size)] * count)
                    dec.add(_ARRAY, (np.dtype("<" + code), size, count))
                else:
                    for _ in range(count):
                        element(sub)
            elif kind == Nodetype.SEQUENCE:
                sub, _bound = detail
                sub_kind, sub_detail = sub
                if sub_kind == Nodetype.NAME:
                    both(_SEQ_MSG, layout(sub_detail))
                    types.update(layout(sub_detail).types)
                elif sub_kind == Nodetype.BASE and sub_detail[0] == "string":
                    both(_SEQ_STR, None)
                elif sub_kind == Nodetype.BASE and sub_detail[0] in _PRIMITIVES:
                    code, size = _PRIMITIVES[sub_detail[0]]
                    both(_SEQ_PRIM, (np.dtype("<" + code), size))
                else:
                    raise NotImplementedError(f"{typename}: CDR of sequences of {sub} is not supported")
            else:  # pragma: no cover - the type store knows no other kinds
                raise NotImplementedError(f"{typename}: CDR of {kind} fields is not supported")

        def struct_fields(name: str) -> None:
            types.add(name)
            for _field, node in messages.typestore().get_msgdef(name).fields:
                element(node)

        struct_fields(typename)
        enc.close_run()
        dec.close_run()
        self._steps = tuple(enc.steps)
        self._reads = tuple(dec.steps)
        self.size = sum(n for _, _, n in enc.steps)  # how many values ``encode`` takes
        self.types = frozenset(types)  # the message types the layout is made of (this one included)

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

    def packer(self) -> struct.Struct | None:
        """For a type of fixed size (primitives only): one ``struct`` whose ``pack(ENCAPSULATION, *values)``
        gives the bytes ``encode(values)`` gives; else None."""
        if len(self._steps) != 1 or self._steps[0][0] != _RUN:
            return None
        return struct.Struct("<4s" + self._steps[0][1][0].format[1:])

    def decode(self, data: bytes, max_len: int) -> list[Any]:
        """The values of the CDR message ``data`` (encapsulation header included), in field order: as
        ``encode`` takes them, but a fixed array of primitives as one read-only array over ``data``, a
        sequence of primitives as one too, a sequence of messages as a list of value lists.

        Raises ``ValueError`` (or ``struct.error``, ``UnicodeDecodeError``) on bytes the type store's
        deserializer refuses: not little-endian CDR, cut short, a string without its NUL, a sequence
        longer than ``max_len`` or than the data, more than 3 bytes after the message.
        """
        if len(data) < 4 or data[0] != 0 or data[1] != 1:
            raise ValueError("not little-endian CDR")
        out: list[Any] = []
        pos = self._decode(data, 0, out, max_len)
        if pos + 4 + 3 < len(data):
            raise ValueError("CDR message size mismatch")
        return out

    def _decode(self, data: bytes, pos: int, out: list[Any], max_len: int) -> int:
        """Append the values at payload offset ``pos`` to ``out``; the offset after them."""
        for kind, arg, _ in self._reads:
            if kind == _RUN:
                fmt = arg[pos & 7]
                out += fmt.unpack_from(data, 4 + pos)
                pos += fmt.size
                continue
            if kind == _ARRAY:
                dtype, size, count = arg
                pos += -pos % size
                out.append(np.frombuffer(data, dtype=dtype, count=count, offset=4 + pos))
                pos += size * count
                continue
            pos = (pos + 3) & -4
            (count,) = _U32.unpack_from(data, 4 + pos)
            pos += 4
            if kind == _STRING:
                end = 4 + pos + count
                if count < 1 or end > len(data) or data[end - 1] != 0:
                    raise ValueError(f"bad CDR string at offset {pos - 4}")
                out.append(str(data[4 + pos : end - 1], "utf-8"))
                pos += count
                continue
            if count > max_len or 4 + pos + count > len(data):
                raise ValueError(f"bad sequence length {count}")
            if kind == _SEQ_MSG:
                items = []
                for _ in range(count):
                    item: list[Any] = []
                    pos = arg._decode(data, pos, item, max_len)
                    items.append(item)
                out.append(items)
            elif kind == _SEQ_STR:
                strings = []
                for _ in range(count):
                    pos = (pos + 3) & -4
                    (size,) = _U32.unpack_from(data, 4 + pos)
                    end = 4 + pos + 4 + size
                    if size < 1 or end > len(data) or data[end - 1] != 0:
                        raise ValueError(f"bad CDR string at offset {pos}")
                    strings.append(str(data[end - size : end - 1], "utf-8"))
                    pos += 4 + size
                out.append(strings)
            else:  # _SEQ_PRIM
                dtype, size = arg
                if count:
                    pos += -pos % size
                if 4 + pos + size * count > len(data):
                    raise ValueError(f"bad sequence length {count}")
                out.append(np.frombuffer(data, dtype=dtype, count=count, offset=4 + pos))
                pos += size * count
        return pos


@cache
def layout(typename: str) -> Layout:
    """The compiled layout of a type of the shared type store, made once per type."""
    return Layout(typename)


class RepeatedShapes:
    """``Layout.decode`` for a stream that repeats a few shapes: the numbers, strings and arrays of each message.

    Messages of one size whose sequence counts and strings are the same bytes have their fields at the
    same offsets (a /tf stream: the same frames again and again; odometry, IMU samples, scans of one
    sensor). The first message of each size is walked (``decode``, raising on what it refuses) and its
    shape kept: one ``struct`` reading the whole message, counts and string bytes included, and where its
    arrays lie; a later message of that size whose counts and string bytes equal the kept ones is read
    with that one call. ``read`` gives the primitive values in field order (sequences of messages
    flattened), the strings in field order, and the arrays (fixed arrays and sequences of primitives) in
    field order, as read-only arrays over the bytes. Not for sequences of strings (``supports``).
    """

    KEEP = 64  # shapes kept; more (strings that keep changing) starts the collection again

    def __init__(self, layout: Layout, max_len: int) -> None:
        if not self.supports(layout):
            raise ValueError(f"{layout.typename}: sequences of strings have no kept shape")
        self._layout, self._max_len = layout, max_len
        self._by_size: dict[int, tuple[Any, Any, Any, Any, list[str], tuple[tuple[Any, int, int], ...]]] = {}

    @staticmethod
    def supports(layout: Layout) -> bool:
        return all(
            kind != _SEQ_STR and (kind != _SEQ_MSG or RepeatedShapes.supports(arg)) for kind, arg, _ in layout._reads
        )

    def read(self, data: bytes) -> tuple[tuple[Any, ...], list[str], list[np.ndarray]]:
        kept = self._by_size.get(len(data))
        if kept is not None:
            unpack, pick_shape, shape, pick_values, strings, arrays = kept
            values = unpack(data)
            if pick_shape(values) == shape:
                return pick_values(values), strings, _arrays(data, arrays) if arrays else []
        kept = self._shape_of(data)
        if len(self._by_size) >= self.KEEP:
            self._by_size.clear()
        self._by_size[len(data)] = kept
        unpack, _, _, pick_values, strings, arrays = kept
        return pick_values(unpack(data)), strings, _arrays(data, arrays)

    def _shape_of(self, data: bytes) -> tuple[Any, Any, Any, Any, list[str], tuple[tuple[Any, int, int], ...]]:
        """Walk ``data`` (raising as ``decode`` does) into its kept shape."""
        self._layout.decode(data, self._max_len)  # the checks, once per shape
        fmt, shape, strings = ["<2s2x"], [0], []  # the struct's format; its fields of counts and strings
        numbers: list[int] = []  # its fields of primitive values
        arrays: list[tuple[Any, int, int]] = []  # (dtype, count, offset in data) of each array
        count = 1  # fields of the struct so far

        def walk(layout: Layout, pos: int) -> int:
            nonlocal count
            for kind, arg, n in layout._reads:
                if kind == _RUN:
                    run = arg[pos & 7]
                    fmt.append(run.format[1:])
                    numbers.extend(range(count, count + n))
                    count += n
                    pos += run.size
                    continue
                if kind == _ARRAY:
                    dtype, size, length = arg
                    pad = -pos % size
                    fmt.append(f"{pad + size * length}x")
                    arrays.append((dtype, length, 4 + pos + pad))
                    pos += pad + size * length
                    continue
                pad = -pos & 3
                (size,) = _U32.unpack_from(data, 4 + pos + pad)
                pos += pad + 4
                if kind == _STRING:  # its length and bytes, compared as one field
                    fmt.append(f"{pad}x{4 + size}s")
                    strings.append(str(data[4 + pos : 4 + pos + size - 1], "utf-8"))
                    pos += size
                    shape.append(count)
                    count += 1
                    continue
                fmt.append(f"{pad}xI")
                shape.append(count)
                count += 1
                if kind == _SEQ_MSG:
                    for _ in range(size):
                        pos = walk(arg, pos)
                else:  # _SEQ_PRIM
                    dtype, item = arg
                    pad = -pos % item if size else 0
                    fmt.append(f"{pad + item * size}x")
                    arrays.append((dtype, size, 4 + pos + pad))
                    pos += pad + item * size
            return pos

        end = walk(self._layout, 0)
        fmt.append(f"{len(data) - 4 - end}x")
        unpack = struct.Struct("".join(fmt)).unpack_from
        pick_shape, pick_values = _picker(shape), _picker(numbers)
        return unpack, pick_shape, pick_shape(unpack(data)), pick_values, strings, tuple(arrays)


def _arrays(data: bytes, where: tuple[tuple[Any, int, int], ...]) -> list[np.ndarray]:
    """Read-only arrays over ``data``, one per (dtype, count, offset)."""
    return [np.frombuffer(data, dtype=dtype, count=count, offset=at) for dtype, count, at in where]


def _picker(indices: list[int]) -> Any:
    """The values at ``indices`` of a tuple, as a tuple."""
    if not indices:
        return lambda values: ()
    if len(indices) == 1:
        i = indices[0]
        return lambda values: (values[i],)
    return operator.itemgetter(*indices)


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


class UniformSequence:
    """CDR of a message whose last field is a sequence of messages of one shape (module docstring)."""

    def __init__(self, typename: str) -> None:
        whole = layout(typename)
        kind, element, _ = whole._steps[-1]
        if kind != _SEQ_MSG or any(k not in (_RUN, _STRING) for k, _, _ in element._steps):
            raise ValueError(f"{typename}: its last field is not a sequence of messages without sequences")
        self._head, self._element = whole._head(), element
        self._shapes: dict[tuple[int, tuple[str, ...]], tuple[np.dtype[Any], np.ndarray, list[str]]] = {}

    def encode(self, head: Any, count: int, columns: Any, strings: tuple[str, ...] = ()) -> bytes:
        """CDR bytes (with the encapsulation header) of the message: ``head``, its fields but the last (as
        ``Layout.encode`` takes them), then ``count`` elements whose strings are ``strings`` (in field
        order) and whose numbers are ``columns`` (in field order, depth first; each an array of ``count``
        values or one value for all)."""
        parts: list[Any] = [_HEADER]
        pos = self._head._encode(head, 0, parts)
        pad = -pos & 3
        parts.append(_PAD[pad] + _U32.pack(count))
        pos += pad + 4
        done = 0
        while done < count:
            dtype, template, names = self._shape(pos & 7, strings)
            if len(columns) != len(names):
                raise ValueError(f"{self._element.typename}: {len(columns)} columns for {len(names)} numbers")
            # the first element may start elsewhere modulo 8 than the others, which all start alike
            n = 1 if done == 0 and (pos + dtype.itemsize) & 7 != pos & 7 else count - done
            rows = np.tile(template, n).view(dtype)
            for name, column in zip(names, columns):
                rows[name] = column if np.ndim(column) == 0 else column[done : done + n]
            parts.append(rows)
            pos += n * dtype.itemsize
            done += n
            if n == 1 and done < count and (pos + self._shape(pos & 7, strings)[0].itemsize) & 7 != pos & 7:
                raise ValueError(f"{self._element.typename}: elements whose alignment keeps changing")
        return b"".join(parts)

    def _shape(self, start: int, strings: tuple[str, ...]) -> tuple[np.dtype[Any], np.ndarray, list[str]]:
        """(record dtype, template bytes, field names) of one element starting at ``start`` modulo 8."""
        key = (start, strings)
        shape = self._shapes.get(key)
        if shape is not None:
            return shape
        names: list[str] = []
        formats: list[str] = []
        offsets: list[int] = []
        template = bytearray()
        texts = iter(strings)
        for kind, arg, _ in self._element._steps:
            if kind == _RUN:
                fmt = arg[(start + len(template)) & 7]
                for code in fmt.format[1:]:
                    if code == "x":
                        template.append(0)
                        continue
                    size = struct.calcsize("<" + code)
                    names.append(f"v{len(names)}")
                    formats.append("<" + code)
                    offsets.append(len(template))
                    template += bytes(size)
            else:  # _STRING
                text = next(texts, None)
                if text is None:
                    raise ValueError(f"{self._element.typename}: fewer strings than it holds")
                raw = text.encode()
                template += _PAD[-(start + len(template)) & 3] + _U32.pack(len(raw) + 1) + raw + b"\x00"
        if next(texts, None) is not None:
            raise ValueError(f"{self._element.typename}: more strings than it holds")
        dtype = np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": len(template)})
        shape = (dtype, np.frombuffer(bytes(template), dtype=np.uint8), names)
        self._shapes[key] = shape
        return shape
