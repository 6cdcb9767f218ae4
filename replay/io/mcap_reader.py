"""MCAP logs read with the ``mcap`` library: one file (``McapLogReader``), or the files of a rosbag2
folder with MCAP storage merged by time (``SplitMcapLogReader``).

The library reads every record: the summary (``make_reader``), and while streaming each chunk
(``Chunk``), its message indexes (``MessageIndex``) and the messages they point at (``Message``); a
truncated file is read through by its ``StreamReader``. The sizes, offsets and CRCs a chunk and its
index claim are checked before anything is allocated, and the chunk is decompressed by ``mcap_chunks``
(zstd and lz4 by their libraries): a chunk that fails is a counted skip, never a traceback, never
silently wrong data. navlog's part is choosing what to read and the order: only the chunks holding a
wanted topic in the wanted time window are read, and of those only the wanted channels' messages are
parsed (a 2D replay never parses a LiDAR cloud), merged across chunks in the library's order (log
time, chunk offset, position in the chunk) with only the chunks whose time has come held open.

One background thread reads and decompresses the next chunk while the current one is replayed: the
decompression releases the GIL, so it overlaps the replay's own work instead of adding to it. A
truncated file is refused unless ``recover=True``, which reads every complete chunk and reports how
far it got.
"""

from __future__ import annotations

import heapq
import io
import os
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any, cast

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Chunk, ChunkIndex, Message, MessageIndex

from navlog.errors import LogError, TruncatedLogError
from navlog.replay.io import cdr_decode
from navlog.replay.io.mcap_chunks import (
    NOT_A_CHUNK,
    UNREADABLE,
    ChunkSkip,
    bounded,
    chunk_records,
    chunk_skip_reasons,
    claim_error,
    decompress,
    reason,
    records_of,
    span_error,
)
from navlog.replay.io.reader import LogReader, TopicInfo
from navlog.replay.io.typestore import LogTypestore
from navlog.replay.runtime.executor import Envelope

MCAP_MAGIC = b"\x89MCAP0\r\n"

_UNSET = object()
READ_AHEAD = 1  # MCAP chunks read and decompressed (in a second thread) ahead of the one being replayed


class McapLogReader(LogReader):
    """A single MCAP file read with the ``mcap`` library (module docstring)."""

    def __init__(self, path: Path, recover: bool = False, *, types: LogTypestore | None = None) -> None:
        super().__init__(path)
        if types is not None:  # the parts of one split log share one type store
            self._types = types
        self.format = "mcap"
        self.storage = "mcap"
        self.size_bytes = path.stat().st_size
        self._fast_store: Any = None  # the store the fast decoders below were made for
        self._fast: dict[tuple[str, bool], Any] = {}  # (type, light form) -> fast decoder or None
        self._recover = recover
        if self.size_bytes == 0:
            raise LogError(
                f"{path}: the file is empty (0 bytes): the recorder wrote nothing; record it again or pass another log"
            )
        with open(path, "rb") as f:
            head = f.read(8)
            if head != MCAP_MAGIC:
                raise LogError(f"{path}: not an MCAP file (bad magic bytes); is it a rosbag2 .db3 or a folder?")
            f.seek(max(0, self.size_bytes - 8))
            tail = f.read(8)
        self.report.truncated = tail != MCAP_MAGIC
        if self.report.truncated and not recover:
            raise TruncatedLogError(
                f"{path}: the file is truncated (no MCAP footer: the writer was killed before finishing). "
                f"Use --recover to read its complete chunks, or `navlog recover {path} -o FIXED.mcap`."
            )
        self._file = open(path, "rb")
        if self.report.truncated:
            self._scan_stream()
        else:
            self._read_summary()

    def _read_summary(self) -> None:
        from mcap.reader import make_reader

        try:
            reader = make_reader(bounded(self._file))
            header = reader.get_header()
            summary = reader.get_summary()
        except Exception as exc:
            raise LogError(f"{self.path}: corrupt MCAP ({reason(exc)}); try `navlog recover`") from None
        if summary is None:
            raise LogError(f"{self.path}: MCAP has no summary section; try `navlog recover`")
        self.profile = header.profile
        self._summary = summary
        summary.chunk_indexes = [ci for ci in summary.chunk_indexes if self._plausible_index(ci)]
        self._typenames = {sid: sc.name for sid, sc in summary.schemas.items()}
        stats = summary.statistics
        counts = stats.channel_message_counts if stats else {}
        if stats and stats.message_count:
            self.start_ns, self.end_ns = stats.message_start_time, stats.message_end_time
        comps = {ci.compression or "none" for ci in summary.chunk_indexes}
        self.compression = ",".join(sorted(comps)) or "none"
        for cid, ch in sorted(summary.channels.items()):
            schema = summary.schemas.get(ch.schema_id)
            typename = schema.name if schema else ""
            known = (
                schema is not None
                and ch.message_encoding == "cdr"
                and self._types.add_schema(typename, schema.data.decode(errors="replace"))
            )
            self._add_topic(ch, typename, counts.get(cid, 0), known)
        try:
            for name, data in sorted(((m.name, m.metadata) for m in reader.iter_metadata()), key=lambda x: x[0]):
                self.metadata[name] = dict(data)
        except Exception:
            pass

    def _plausible_index(self, ci: ChunkIndex) -> bool:
        """Whether a chunk's index entry claims a place in the file and a size its bytes can hold; an entry
        that does not is a counted skip (``mcap_chunks``)."""
        end = ci.chunk_start_offset + ci.chunk_length
        why = (
            span_error(ci.chunk_start_offset, ci.chunk_length + ci.message_index_length, self.size_bytes)
            or span_error(min(ci.message_index_offsets.values(), default=end), 0, self.size_bytes)
            or span_error(max(ci.message_index_offsets.values(), default=end), 0, self.size_bytes)
            or claim_error(ci.compression, ci.compressed_size, ci.uncompressed_size)
        )
        if why:
            self.note_chunk_skip(ChunkSkip(why))
        return not why

    def note_chunk_skip(self, skip: ChunkSkip) -> None:
        chunks, messages = chunk_skip_reasons(skip.why)
        self.report.note_skip(chunks)
        if skip.messages:
            self.report.note_skip(messages, skip.messages)

    def _add_topic(self, ch: Any, typename: str, count: int, known: bool) -> None:
        """A channel's topic; a topic on several channels (a recorder restarted, a file rewritten) counts the
        messages of all of them, which are read together."""
        prev = self.topics.get(ch.topic)
        count += prev.count if prev is not None else 0
        qos = ch.metadata.get("offered_qos_profiles", "")
        why = self._types.refused.get(typename, "") if not known else ""
        self.topics[ch.topic] = TopicInfo(ch.topic, typename, count, known, qos, why)

    def _records(self, note: bool = False) -> Iterator[Any]:
        """Records of a truncated file up to the first incomplete one; a chunk that fails its checks
        (``mcap_chunks``) is left out, and counted when ``note``."""
        from mcap.records import Channel, Message, Metadata, Schema
        from mcap.stream_reader import StreamReader

        self._file.seek(0)
        try:
            stream = StreamReader(bounded(self._file), emit_chunks=True, record_size_limit=self.size_bytes)
            for rec in stream.records:
                if isinstance(rec, Chunk):
                    try:
                        yield from chunk_records(rec)
                    except ChunkSkip as skip:
                        if note:
                            self.note_chunk_skip(skip)
                elif isinstance(rec, (Schema, Channel, Message, Metadata)):
                    yield rec
        except Exception:
            return

    def _scan_stream(self) -> None:
        """Summary of a truncated file, found by reading it through."""
        from mcap.records import Channel, Message, Metadata, Schema

        schemas: dict[int, Schema] = {}
        chans: dict[int, Channel] = {}
        counts: Counter = Counter()
        first = last = None
        for rec in self._records():
            if isinstance(rec, Schema):
                schemas[rec.id] = rec
            elif isinstance(rec, Channel):
                chans[rec.id] = rec
            elif isinstance(rec, Message):
                counts[rec.channel_id] += 1
                first = rec.log_time if first is None else min(first, rec.log_time)
                last = rec.log_time if last is None else max(last, rec.log_time)
            elif isinstance(rec, Metadata):
                self.metadata[rec.name] = dict(rec.metadata)
        self.compression = "unknown (truncated)"
        self.start_ns, self.end_ns = first or 0, last or 0
        self.report.recovered_until_ns = last
        for cid, ch in sorted(chans.items()):
            schema = schemas.get(ch.schema_id)
            typename = schema.name if schema else ""
            known = schema is not None and self._types.add_schema(typename, schema.data.decode())
            self._add_topic(ch, typename, counts[cid], known)

    def messages(self, topics=None, *, decode=True, light=(), start_ns=None, end_ns=None) -> Iterator[Envelope]:
        wanted = self._wanted(topics)
        if not wanted:
            return
        light = frozenset(light)
        if self.report.truncated:
            yield from self._messages_truncated(wanted, decode, light, start_ns, end_ns)
            return
        report, types = self.report, self._types
        fast_of: dict[str, tuple[str, Any, Any]] = {}  # topic -> (type name, store, its fast decoder or None)
        try:
            for topic, typename, t, data in self._in_sequence(self._indexed(wanted, start_ns, end_ns), _time_of):
                if not decode:
                    report.read += 1
                    yield Envelope(topic, typename, t, data)
                    continue
                # ``_envelope`` inlined: the per-message path, with each topic's fast decoder kept
                kept = fast_of.get(topic)
                if kept is None or kept[0] != typename or kept[1] is not types.store:
                    kept = fast_of[topic] = (typename, types.store, self._fast_decoder(typename, topic in light))
                report.read += 1
                msg = None
                if kept[2] is not None:
                    try:
                        msg = kept[2](data)
                    except Exception:  # bytes it does not take: the store's deserializer decodes or counts them
                        pass
                if msg is None:
                    msg = LogReader._decode(self, data, typename, topic)
                if msg is not None:
                    yield Envelope(topic, typename, t, msg)
        except LogError:
            raise
        except Exception as exc:
            raise LogError(
                f"{self.path}: corrupt data after {self.report.read} messages ({reason(exc)}); try --recover"
            ) from None

    def _indexed(
        self, wanted: set[str], start_ns: int | None, end_ns: int | None
    ) -> Iterator[tuple[str, str, int, bytes]]:
        """(topic, type name, log time, CDR bytes) of the wanted topics, in log-time order.

        The order is the ``mcap`` library's (log time, then chunk offset, then position in the
        chunk), but only the wanted messages are touched: chunks without a wanted channel are never
        read, and in the others the chunk's message indexes give the wanted records' offsets, so
        the rest of the chunk (the LiDAR clouds a 2D replay does not need) is decompressed but not
        parsed. A chunk without message indexes is parsed whole. Chunks are loaded in the order
        their time ranges are reached, ``READ_AHEAD`` of them ahead in a background thread
        (decompression releases the GIL); a loaded chunk keeps only its wanted messages, so memory
        does not depend on the log's length.
        """
        summary = self._summary
        channels = {
            cid: (ch.topic, self._typenames.get(ch.schema_id, ""))
            for cid, ch in summary.channels.items()
            if ch.topic in wanted
        }
        if not channels:
            return
        chunks = []
        for ci in summary.chunk_indexes:
            if start_ns is not None and ci.message_end_time < start_ns:
                continue
            if end_ns is not None and ci.message_start_time > end_ns:
                continue
            if ci.message_index_offsets and not any(cid in channels for cid in ci.message_index_offsets):
                continue
            chunks.append(ci)
        chunks.sort(key=lambda ci: (ci.message_start_time, ci.chunk_start_offset))
        # a chunk is opened when the stream reaches its first message time; sorted, the list is a heap.
        # An open chunk is in the heap by its next message: (time, chunk offset, position, (messages, index))
        queue: list[tuple] = [(ci.message_start_time, ci.chunk_start_offset, -1, None) for ci in chunks]
        loader = _ReadAhead(lambda ci: self._chunk_messages(ci, channels), chunks, READ_AHEAD)
        opened = iter(chunks)  # the heap opens the chunks in this order, as the loader loads them
        try:
            while queue:
                t, chunk_offset, pos, item = heapq.heappop(queue)
                if pos < 0:
                    ci = next(opened)
                    try:
                        loaded = loader.next()
                    except ChunkSkip as skip:
                        self.note_chunk_skip(skip)
                        loaded = []
                    msgs = self._within_chunk_span(ci, loaded)
                    msgs = [
                        m for m in msgs if (start_ns is None or m[0] >= start_ns) and (end_ns is None or m[0] <= end_ns)
                    ]
                    if msgs:
                        heapq.heappush(queue, (msgs[0][0], chunk_offset, msgs[0][1], (msgs, 0)))
                    continue
                msgs, i = item
                while True:  # the chunk's messages while they come before every other chunk's next one
                    cid = msgs[i][2]
                    topic, typename = channels[cid]
                    yield topic, typename, t, msgs[i][3]
                    i += 1
                    if i == len(msgs):
                        break
                    t, pos = msgs[i][0], msgs[i][1]
                    if queue and t >= queue[0][0] and (t, chunk_offset, pos) > queue[0][:3]:  # another chunk's first
                        heapq.heappush(queue, (t, chunk_offset, pos, (msgs, i)))
                        break
        finally:
            loader.close()

    def _within_chunk_span(self, ci: ChunkIndex, msgs: list[tuple[int, int, int, bytes]]) -> list:
        """The messages whose log time lies in their chunk's span as its index states it; the others are
        counted skips. The writer computed that span from the true times, so a time outside it is corrupt
        (one flipped bit can put a message decades ahead, and timers would run until then)."""
        lo, hi = ci.message_start_time, ci.message_end_time
        if not msgs or (lo == hi == 0) or (lo <= msgs[0][0] and msgs[-1][0] <= hi):  # (sorted by time)
            return msgs
        kept = [m for m in msgs if lo <= m[0] <= hi]
        self.report.note_skip(
            "messages whose log time lies outside their chunk's time range (corrupt log time)", len(msgs) - len(kept)
        )
        return kept

    def _chunk_messages(self, ci: ChunkIndex, channels: dict) -> list[tuple[int, int, int, bytes]]:
        """(log time, position, channel id, bytes) of the wanted messages in one chunk, sorted.

        The chunk, its message indexes and its messages are the ``mcap`` library's records, read
        with its parsers; the chunk is checked and decompressed by ``mcap_chunks`` (a chunk that fails
        raises ``ChunkSkip`` with the number of wanted messages its indexes list). The file is read
        with ``os.pread`` (no shared file position), so this may run in another thread.
        """
        fd = self._file.fileno()
        indexes = self._index_entries(fd, ci, channels)
        try:
            data = self._chunk_data(fd, ci)
        except ChunkSkip as skip:  # counted with the wanted messages its indexes list
            raise ChunkSkip(skip.why, sum(len(e) for e in indexes.values())) from None
        size = len(data)
        if not ci.message_index_offsets:  # no indexes: every record of the chunk is parsed
            return sorted(
                (rec.log_time, pos, rec.channel_id, rec.data)
                for pos, rec in enumerate(records_of(data))
                if isinstance(rec, Message) and rec.channel_id in channels
            )  # by time, then position (unique: the bytes are never compared)
        view = io.BytesIO(data)  # the decompressed bytes themselves (BytesIO does not copy them)
        records = ReadDataStream(view)
        out = []
        for cid, entries in indexes.items():
            for _, pos in entries:
                view.seek(pos)
                if pos + 9 > size or records.read1() != Opcode.MESSAGE:
                    raise _not_a_message(self.path, cid)
                length = records.read8()
                if length < 22 or pos + 9 + length > size:
                    raise _not_a_message(self.path, cid)
                msg = Message.read(records, length)
                if msg.channel_id != cid:
                    raise _not_a_message(self.path, cid)
                out.append((msg.log_time, pos, cid, msg.data))
        out.sort()  # by time, then position (unique: the bytes are never compared)
        return out

    def _chunk_data(self, fd: int, ci: ChunkIndex) -> bytes:
        """The decompressed, checked records of the chunk ``ci`` points at; raises ``ChunkSkip``."""
        stream = ReadDataStream(cast(IO[bytes], _PreadFile(fd, ci.chunk_start_offset, self.size_bytes)))
        try:
            if stream.read1() != Opcode.CHUNK:
                raise ChunkSkip(NOT_A_CHUNK)
            stream.read8()
            chunk = Chunk.read(stream)
        except ChunkSkip:
            raise
        except Exception:
            raise ChunkSkip(UNREADABLE) from None
        return decompress(chunk)

    def _index_entries(self, fd: int, ci: ChunkIndex, channels: dict) -> dict[int, list[tuple[int, int]]]:
        """The wanted channels' message index entries (log time, position in the chunk) of one chunk."""
        if not ci.message_index_offsets:
            return {}
        first = min(ci.message_index_offsets.values())
        index_bytes = io.BytesIO(
            os.pread(fd, ci.chunk_start_offset + ci.chunk_length + ci.message_index_length - first, first)
        )
        index = ReadDataStream(index_bytes)
        out: dict[int, list[tuple[int, int]]] = {}
        for cid, offset in ci.message_index_offsets.items():
            if cid not in channels:
                continue
            index_bytes.seek(offset - first)
            if index.read1() != Opcode.MESSAGE_INDEX:
                raise LogError(f"{self.path}: bad message index for channel {cid} at offset {offset}; try --recover")
            index.read8()
            entries = MessageIndex.read(index)
            if entries.channel_id != cid:
                raise LogError(f"{self.path}: bad message index for channel {cid} at offset {offset}; try --recover")
            out[cid] = entries.records
        return out

    def _messages_truncated(self, wanted, decode, light, start_ns, end_ns) -> Iterator[Envelope]:
        from mcap.records import Channel, Message, Schema

        schemas: dict[int, str] = {}
        chans: dict[int, tuple[str, int]] = {}
        batch: list[tuple[int, int, str, str, bytes]] = []
        seq = 0
        for rec in self._records(note=True):
            if isinstance(rec, Schema):
                schemas[rec.id] = rec.name
            elif isinstance(rec, Channel):
                chans[rec.id] = (rec.topic, rec.schema_id)
            elif isinstance(rec, Message):
                if rec.channel_id not in chans:  # a damaged channel id: no topic to give the message
                    self.report.note_skip(f"messages on undefined channel {rec.channel_id}")
                    continue
                topic, sid = chans[rec.channel_id]
                if (
                    topic in wanted
                    and (start_ns is None or rec.log_time >= start_ns)
                    and (end_ns is None or rec.log_time <= end_ns)
                ):
                    seq += 1
                    batch.append((rec.log_time, seq, topic, schemas.get(sid, ""), rec.data))
        # a truncated file has no index: order what could be read by log time (file order breaks ties)
        for t, _, topic, typename, data in self._in_sequence(sorted(batch, key=lambda b: (b[0], b[1])), _first):
            env = self._envelope(topic, typename, t, data, decode, topic in light)
            if env is not None:
                yield env

    def _envelope(self, topic: str, typename: str, t: int, data: bytes, decode: bool, light: bool) -> Envelope | None:
        self.report.read += 1
        if not decode:
            return Envelope(topic, typename, t, data)
        msg = self._decode(data, typename, topic, light)
        return None if msg is None else Envelope(topic, typename, t, msg)

    def _fast_decoder(self, typename: str, light: bool) -> Any:
        """The fast decoder of a hot type (``cdr_decode``; with ``light``, its light form) for the current
        type store, or None."""
        store = self._types.store
        if store is not self._fast_store:  # a schema gave this reader a store of its own
            self._fast_store, self._fast = store, {}
        key = (typename, light)
        fast = self._fast.get(key, _UNSET)
        if fast is _UNSET:
            fast = self._fast[key] = cdr_decode.decoder(typename, store, light=light)
        return fast

    def _decode(self, data: bytes, typename: str, topic: str, light: bool = False) -> Any:
        """The fast decoder of a hot type where it applies, else the type store's."""
        fast = self._fast_decoder(typename, light)
        if fast is not None:
            try:
                return fast(data)
            except Exception:  # bytes it does not take: the store's deserializer decodes or counts them
                pass
        return super()._decode(data, typename, topic)

    def close(self) -> None:
        self._file.close()


class SplitMcapLogReader(LogReader):
    """A rosbag2 folder with MCAP storage: its files, each read with the ``mcap`` library, merged by time."""

    def __init__(self, path: Path, files: list[Path], recover: bool = False) -> None:
        super().__init__(path)
        self.format = "rosbag2"
        self.storage = "mcap"
        self.parts = [McapLogReader(f, recover=recover, types=self._types) for f in files]
        self.size_bytes = sum(p.size_bytes for p in self.parts)
        self.compression = ",".join(sorted({p.compression for p in self.parts}))
        self.start_ns = min(p.start_ns for p in self.parts)
        self.end_ns = max(p.end_ns for p in self.parts)
        for part in self.parts:
            self.metadata.update(part.metadata)
            for name, info in part.topics.items():
                prev = self.topics.get(name)
                count = info.count + (prev.count if prev else 0)
                self.topics[name] = TopicInfo(name, info.typename, count, info.known, info.qos, info.why)
        self.report.truncated = any(p.report.truncated for p in self.parts)
        for p in self.parts:  # chunk index entries the parts refused
            self.report.skipped.update(p.report.skipped)
            p.report.skipped.clear()

    def messages(self, topics=None, *, decode=True, light=(), start_ns=None, end_ns=None) -> Iterator[Envelope]:
        wanted = self._wanted(topics)
        streams = [p.messages(wanted, decode=decode, light=light, start_ns=start_ns, end_ns=end_ns) for p in self.parts]
        try:
            for env in heapq.merge(*streams, key=lambda e: e.time_ns):
                self.report.read += 1
                yield env
        finally:  # what the parts skipped is the log's
            for p in self.parts:
                self.report.skipped.update(p.report.skipped)
                p.report.skipped.clear()

    def close(self) -> None:
        for p in self.parts:
            p.close()


class _ReadAhead:
    """``fn(item)`` of each item in order, computed ``depth`` items ahead in one background thread.

    Only the timing changes, never the results or their order; an exception is raised by ``next``
    for the item that caused it.
    """

    def __init__(self, fn, items: list, depth: int) -> None:
        from collections import deque
        from concurrent.futures import ThreadPoolExecutor

        self._fn = fn
        self._items = iter(items)
        self._pool = ThreadPoolExecutor(max_workers=1, thread_name_prefix="navlog-read") if depth > 0 else None
        self._futures: deque = deque()
        for _ in range(depth):
            self._submit()

    def _submit(self) -> None:
        item = next(self._items, None)
        if item is not None and self._pool is not None:
            self._futures.append(self._pool.submit(self._fn, item))

    def next(self) -> Any:
        if not self._futures:
            return self._fn(next(self._items))
        future = self._futures.popleft()
        self._submit()
        return future.result()

    def close(self) -> None:
        if self._pool is not None:
            for f in self._futures:
                f.cancel()
            self._pool.shutdown(wait=True)


class _PreadFile:
    """A file read from ``offset`` on with ``os.pread`` (no shared file position: any thread may read it),
    never past ``size`` (a corrupt length reads what is there, not gigabytes of nothing)."""

    def __init__(self, fd: int, offset: int, size: int) -> None:
        self._fd, self._at, self._size = fd, offset, size

    def read(self, n: int) -> bytes:
        data = os.pread(self._fd, max(0, min(n, self._size - self._at)), self._at)
        self._at += len(data)
        return data


def _time_of(item: tuple) -> int:
    return int(item[2])


def _first(item: tuple) -> int:
    return int(item[0])


def _not_a_message(path: Path, cid: int) -> LogError:
    return LogError(f"{path}: message index of channel {cid} points at no message of it; try --recover")
