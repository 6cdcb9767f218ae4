"""The MCAP reader's indexed path: the same stream as the mcap library, touching only what is needed.

The reference is ``mcap.reader.SeekingReader.iter_messages(log_time_order=True)``: for every file
layout below (compressions, chunks with and without message indexes, chunks overlapping in time,
equal log times across chunks) and every topic subset and time window, ``LogReader.messages`` must
give the same (topic, log time, bytes) sequence.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import CompressionType, IndexType, Writer

import navlog.replay.io.mcap_reader
from navlog.errors import LogError
from navlog.replay.io import McapLogReader, open_log

TOPICS = ("/a", "/b", "/c")


def write_mcap(
    path: Path,
    messages: list[tuple[str, int, bytes]],
    *,
    compression=CompressionType.ZSTD,
    message_index: bool = True,
    chunk_size: int = 400,
) -> Path:
    index = IndexType.ALL if message_index else IndexType.CHUNK | IndexType.METADATA | IndexType.ATTACHMENT
    with open(path, "wb") as f:
        w = Writer(f, chunk_size=chunk_size, compression=compression, index_types=index)
        w.start(profile="ros2", library="test")
        sid = w.register_schema("std_msgs/msg/String", "ros2msg", b"string data")
        ids = {t: w.register_channel(t, "cdr", sid) for t in TOPICS}
        for seq, (topic, t, data) in enumerate(messages):
            w.add_message(ids[topic], log_time=t, data=data, publish_time=t, sequence=seq)
        w.finish()
    return path


def reference(path: Path, topics, start_ns=None, end_ns=None) -> list[tuple[str, int, bytes]]:
    with open(path, "rb") as f:
        reader = make_reader(f)
        return [
            (ch.topic, m.log_time, m.data)
            for _, ch, m in reader.iter_messages(
                topics=topics,
                starting_at=start_ns,
                ending_before=None if end_ns is None else end_ns + 1,
                log_time_order=True,
            )
        ]


def ours(path: Path, topics, start_ns=None, end_ns=None) -> list[tuple[str, int, bytes]]:
    with open_log(path) as r:
        return [(e.topic, e.time_ns, e.msg) for e in r.messages(topics, decode=False, start_ns=start_ns, end_ns=end_ns)]


def in_order() -> list[tuple[str, int, bytes]]:
    """/a at 100 Hz, /b at 10 Hz, /c once a second; /b and /c share instants with /a."""
    out = []
    for k in range(300):
        t = k * 10_000_000
        out.append(("/a", t, b"a%04d" % k))
        if k % 10 == 0:
            out.append(("/b", t, b"b%04d" % k + b"x" * 50))
        if k % 100 == 0:
            out.append(("/c", t, b"c%04d" % k))
    return out


def overlapping() -> list[tuple[str, int, bytes]]:
    """Written out of time order: chunks overlap in time and equal log times fall in different chunks."""
    a = [("/a", k * 7_000_000, b"a%04d" % k) for k in range(120)]
    b = [("/b", k * 21_000_000, b"b%04d" % k) for k in range(40)]  # every third /a instant, written later
    c = [("/c", (119 - k) * 7_000_000, b"c%04d" % k) for k in range(0, 120, 5)]  # backwards in time
    return a[:60] + b + a[60:] + c


LAYOUTS = {
    "zstd": dict(compression=CompressionType.ZSTD),
    "lz4": dict(compression=CompressionType.LZ4),
    "uncompressed": dict(compression=CompressionType.NONE),
    "no message indexes": dict(message_index=False),
    "one big chunk": dict(chunk_size=1 << 20),
}


@pytest.mark.parametrize("layout", sorted(LAYOUTS))
@pytest.mark.parametrize("content", ["in_order", "overlapping"])
@pytest.mark.parametrize("read_ahead", [0, 1, 3])
def test_same_stream_as_the_mcap_library(tmp_path, monkeypatch, layout, content, read_ahead):
    monkeypatch.setattr(navlog.replay.io.mcap_reader, "READ_AHEAD", read_ahead)
    msgs = in_order() if content == "in_order" else overlapping()
    path = write_mcap(tmp_path / "x.mcap", msgs, **LAYOUTS[layout])
    subsets = [None] + [list(c) for n in (1, 2) for c in itertools.combinations(TOPICS, n)]
    for topics in subsets:
        expected = reference(path, topics if topics is not None else list(TOPICS))
        assert ours(path, topics) == expected
        assert len(expected) == sum(1 for m in msgs if topics is None or m[0] in topics)
    # time windows: inclusive at both ends, including a window starting at an instant several topics share
    for start, end in (
        (100_000_000, 500_000_000),
        (0, 0),
        (210_000_000, 210_000_000),
        (None, 350_000_000),
        (700_000_000, None),
    ):
        assert ours(path, ["/a", "/b"], start, end) == reference(path, ["/a", "/b"], start, end)


def test_chunks_without_a_wanted_topic_are_never_read(tmp_path, monkeypatch):
    # /c only in the last second: reading /c must open only the chunks that hold it
    msgs = [("/a", k * 10_000_000, b"a" * 40) for k in range(200)] + [
        ("/c", 2_000_000_000 + k * 100_000_000, b"c" * 40) for k in range(10)
    ]
    path = write_mcap(tmp_path / "x.mcap", msgs, chunk_size=500)
    with open(path, "rb") as f:
        chunks = make_reader(f).get_summary().chunk_indexes
    with_c = [ci.chunk_start_offset for ci in chunks if any(cid == 3 for cid in ci.message_index_offsets)]
    assert 0 < len(with_c) < len(chunks) / 4
    opened: list[int] = []
    real = McapLogReader._chunk_messages

    def spy(self, ci, *args):
        opened.append(ci.chunk_start_offset)
        return real(self, ci, *args)

    monkeypatch.setattr(McapLogReader, "_chunk_messages", spy)
    assert [m[2] for m in ours(path, ["/c"])] == [b"c" * 40] * 10
    assert opened == with_c


def test_corrupt_message_index_is_a_log_error(tmp_path):
    path = write_mcap(tmp_path / "x.mcap", in_order(), chunk_size=2000)
    with open(path, "rb") as f:
        ci = make_reader(f).get_summary().chunk_indexes[1]
    data = bytearray(path.read_bytes())
    offset = ci.message_index_offsets[1]  # /a's message index of the second chunk
    # point its first entry's message offset somewhere inside another record
    data[offset + 15 + 8 : offset + 15 + 16] = (3).to_bytes(8, "little")
    path.write_bytes(bytes(data))
    with open_log(path) as r:
        with pytest.raises(LogError, match="message index of channel 1 points at no message"):
            list(r.messages(["/a"], decode=False))
        assert r.report.read > 0  # the first chunk was read before the bad index was found


def test_messages_own_their_bytes(tmp_path):
    """A message's bytes do not keep its (decompressed) chunk alive."""
    path = write_mcap(tmp_path / "x.mcap", in_order())
    with open_log(path) as r:
        first = next(iter(r.messages(["/b"], decode=False)))
    assert type(first.msg) is bytes and first.msg.startswith(b"b0000")
