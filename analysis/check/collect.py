"""One streaming pass over a log that keeps, per topic, what the checks measure.

Per topic: the log times and header stamps (int64 nanoseconds, in the order read), and for
``sensor_msgs/LaserScan`` the counts of NaN, +inf and -inf ranges; per TF edge (parent -> child, from
/tf and /tf_static): whether it is static and its stamps. Only scans and TF messages are decoded; a
header stamp is read from the first 12 bytes of the CDR (encapsulation, then ``sec``, ``nanosec``) of
every type whose first field is a ``std_msgs/Header`` or a ``builtin_interfaces/Time``.

An MCAP file is read in the order its messages are stored (so a log time that steps back is seen;
a truncated file up to its last complete record); a rosbag2 storage gives its messages in log-time order.
Memory is 16 bytes per message, never the messages themselves.
"""

from __future__ import annotations

import struct
from array import array
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from navlog.replay.io.mcap_reader import McapLogReader, SplitMcapLogReader
from navlog.replay.io.reader import LogReader
from navlog.replay.scan_geometry import scan_fault

LASER_SCAN = "sensor_msgs/msg/LaserScan"
TF_MESSAGE = "tf2_msgs/msg/TFMessage"
TF_TOPICS = {"/tf": False, "/tf_static": True}  # topic -> static
_STAMP_TYPES = ("std_msgs/msg/Header", "builtin_interfaces/msg/Time")
_STAMP_LE, _STAMP_BE = struct.Struct("<iI"), struct.Struct(">iI")


@dataclass
class ScanValues:
    scans: int = 0
    beams: int = 0
    nan: int = 0
    pos_inf: int = 0
    neg_inf: int = 0
    no_finite: int = 0  # scans without a single finite range
    bad_geometry: int = 0  # scans whose angle fields and beam count disagree (navlog.replay.scan_geometry)
    first_fault: str | None = None  # why the first of them cannot be used


@dataclass
class TopicSeries:
    topic: str
    typename: str
    stamped: bool
    log_times: array = field(default_factory=lambda: array("q"))
    stamps: array = field(default_factory=lambda: array("q"))
    undecodable: int = 0
    scan: ScanValues | None = None


@dataclass
class EdgeSeries:
    parent: str
    child: str
    static: bool
    stamps: array = field(default_factory=lambda: array("q"))


@dataclass
class Collected:
    order: str  # "file" or "log time"
    topics: dict[str, TopicSeries]
    edges: dict[tuple[str, str], EdgeSeries]
    read: int = 0
    error: str = ""  # why reading stopped early ("" when it read to the end)


def frame_name(frame: str) -> str:
    return frame.lstrip("/")


def collect(reader: LogReader) -> Collected:
    """Read every message of the log once (see the module docstring)."""
    store = reader.typestore
    order = "file" if isinstance(reader, McapLogReader | SplitMcapLogReader) else "log time"
    out = Collected(order, {}, {})
    for name, info in sorted(reader.topics.items()):
        if info.known:
            out.topics[name] = TopicSeries(name, info.typename, _has_stamp(store, info.typename))
    try:
        for topic, t, data in _raw_messages(reader, set(out.topics)):
            series = out.topics[topic]
            out.read += 1
            series.log_times.append(t)
            if series.stamped and len(data) >= 12:
                sec, nsec = (_STAMP_LE if data[1] & 1 else _STAMP_BE).unpack_from(data, 4)
                series.stamps.append(sec * 1_000_000_000 + nsec)
            if series.typename == LASER_SCAN or (series.typename == TF_MESSAGE and topic in TF_TOPICS):
                try:
                    msg = store.deserialize_cdr(data, series.typename)
                except Exception:
                    series.undecodable += 1
                    continue
                if series.typename == LASER_SCAN:
                    _add_scan(series, msg)
                else:
                    _add_tf(out.edges, msg, TF_TOPICS[topic])
    except Exception as exc:  # a corrupt or cut file: what was read so far is checked, the error reported
        out.error = str(exc) or type(exc).__name__
    return out


def _has_stamp(store: Any, typename: str) -> bool:
    try:
        fields = store.fielddefs[typename][1]
    except (KeyError, IndexError, AttributeError):
        return False
    return bool(fields) and fields[0][1][1] in _STAMP_TYPES


def _raw_messages(reader: LogReader, wanted: set[str]) -> Iterator[tuple[str, int, bytes]]:
    """(topic, log time, CDR bytes) of the wanted topics: MCAP files in stored order, others by log time."""
    if isinstance(reader, SplitMcapLogReader):
        for part in reader.parts:
            yield from _mcap_file_order(part.path, wanted)
    elif isinstance(reader, McapLogReader):
        yield from _mcap_file_order(reader.path, wanted)
    else:
        for env in reader.messages(wanted, decode=False):
            yield env.topic, env.time_ns, env.msg


def _mcap_file_order(path: Path, wanted: set[str]) -> Iterator[tuple[str, int, bytes]]:
    from mcap.exceptions import EndOfFile
    from mcap.records import Channel, Message
    from mcap.stream_reader import StreamReader

    topics: dict[int, str] = {}
    with open(path, "rb") as f:
        records = StreamReader(f).records
        while True:
            try:
                rec = next(records)
            except (StopIteration, EndOfFile):  # the end, or the end of what a truncated file holds
                return
            if isinstance(rec, Channel):
                topics[rec.id] = rec.topic
            elif isinstance(rec, Message):
                topic = topics.get(rec.channel_id)
                if topic in wanted:
                    yield topic, rec.log_time, rec.data


def _add_scan(series: TopicSeries, msg: Any) -> None:
    sv = series.scan = series.scan or ScanValues()
    r = np.asarray(msg.ranges, dtype=np.float64)
    sv.scans += 1
    sv.beams += r.size
    nan = int(np.isnan(r).sum())
    pos = int(np.isposinf(r).sum())
    neg = int(np.isneginf(r).sum())
    sv.nan += nan
    sv.pos_inf += pos
    sv.neg_inf += neg
    sv.no_finite += int(nan + pos + neg == r.size)
    fault = scan_fault(msg)
    if fault is not None:
        sv.bad_geometry += 1
        sv.first_fault = sv.first_fault or fault


def _add_tf(edges: dict[tuple[str, str], EdgeSeries], msg: Any, static: bool) -> None:
    for ts in msg.transforms:
        key = (frame_name(ts.header.frame_id), frame_name(ts.child_frame_id))
        edge = edges.get(key)
        if edge is None:
            edge = edges[key] = EdgeSeries(key[0], key[1], static)
        edge.static = edge.static or static
        edge.stamps.append(int(ts.header.stamp.sec) * 1_000_000_000 + int(ts.header.stamp.nanosec))
