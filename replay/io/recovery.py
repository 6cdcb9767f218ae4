"""Salvaging a truncated MCAP file (a recorder killed with SIGKILL, a disk that filled up).

Every record up to the first incomplete one is copied — schemas, channels, metadata and the messages
of every complete chunk — into a new, properly finished MCAP file. A file with no complete chunk holding
a message (a recording cut before its first chunk) is a ``LogError``, and nothing is written.

navlog writes a file's metadata records (a recording's ``navlog`` record: world, robot, scenario,
seed, config hash) first, before any message, so they are copied with the rest; a navlog file cut
before them (or written by an older navlog, which wrote them at its end) has lost them, and
``RecoveryResult.metadata_lost`` says so. They are not rebuilt: the messages do not hold the seed or
the configuration, and a guessed record would pass for the real one.

A chunk that fails its checks (``mcap_chunks``: its CRC, the sizes it claims) is left out and counted
(``RecoveryResult.chunks_skipped``): copying it would give its corrupt bytes a new, valid CRC.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from mcap.records import Channel, Chunk, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.writer import CompressionType, Writer

from navlog.errors import LogError
from navlog.replay.io.atomic import check_not_input, hold_output, open_new, temp_path, write_error
from navlog.replay.io.logwriter import check_output
from navlog.replay.io.mcap_chunks import ChunkSkip, bounded, chunk_records
from navlog.replay.io.mcap_reader import MCAP_MAGIC


@dataclass
class RecoveryResult:
    messages: int
    first_ns: int | None
    last_ns: int | None
    bytes_read: int
    bytes_total: int
    complete: bool  # the input was not truncated after all
    metadata: tuple[str, ...] = ()  # the names of the metadata records kept
    library: str = ""  # the writer the input's header names ("navlog X.Y" for navlog's files)
    chunks_skipped: dict[str, int] = field(default_factory=dict)  # why -> chunks left out (mcap_chunks)

    @property
    def metadata_lost(self) -> bool:
        """A navlog file without its metadata records (cut before them, or an older navlog's, which wrote
        them at its end): they cannot be rebuilt from its messages."""
        return self.library.startswith("navlog") and not self.metadata

    @property
    def seconds(self) -> float:
        return 0.0 if self.first_ns is None or self.last_ns is None else (self.last_ns - self.first_ns) / 1e9


def recover_mcap(broken: Path | str, out: Path | str, *, force: bool = False) -> RecoveryResult:
    src, dst = Path(broken), Path(out)
    if src.is_dir():
        raise LogError(
            f"{src}: is a folder; recover expects a truncated .mcap file (e.g. NAME.mcap.part), pass the file inside it"
        )
    if not src.is_file():
        raise LogError(f"{src}: no such file")
    check_not_input(dst, [src])
    check_output(dst, force)
    total = src.stat().st_size
    if total == 0:
        raise LogError(f"{src}: the file is empty (0 bytes): there is nothing to recover; record it again")
    with open(src, "rb") as f:
        if f.read(8) != MCAP_MAGIC:
            raise LogError(f"{src}: not an MCAP file (bad magic bytes)")
    with hold_output(dst):  # one run writes ``dst`` at a time
        tmp = temp_path(dst)  # .NAME.PID.part: another process's temporary is never this one's
        try:
            n, first, last, read, ok, names, library, skipped = _copy_complete_records(src, tmp)
        except OSError as exc:
            tmp.unlink(missing_ok=True)
            raise write_error(dst, exc) from exc
        if n == 0:
            tmp.unlink(missing_ok=True)
            why = (
                "the file holds no message"
                if ok
                else f"it was cut after {read} bytes, before the end of its first chunk"
                if read > 8
                else "it was cut right after its magic bytes"
            )
            raise LogError(
                f"{src}: nothing to recover: no complete chunk holds a message ({why}); nothing was written to {dst}. "
                "A recording killed this early has no data to salvage: record it again."
            )
        os.replace(tmp, dst)
        return RecoveryResult(n, first, last, min(read, total), total, ok, names, library, skipped)


def _copy_complete_records(
    src: Path, tmp: Path
) -> tuple[int, int | None, int | None, int, bool, tuple[str, ...], str, dict[str, int]]:
    """Copy every record of ``src`` up to the first incomplete one into a finished MCAP file ``tmp``:
    (messages, first and last log time, bytes read, whether ``src`` was read to its end, the names
    of the metadata records copied, the writer library its header names, the chunks left out by why)."""
    n, first, last, ok = 0, None, None, True
    skipped: dict[str, int] = {}
    names: list[str] = []
    library = ""
    with open(src, "rb") as f, open_new(tmp) as o:
        w = Writer(o, compression=CompressionType.ZSTD)
        w.start(profile="ros2", library="navlog recover")
        schema_ids: dict[int, int] = {}
        channel_ids: dict[int, int] = {}
        try:
            size = os.fstat(f.fileno()).st_size
            for rec in _unchunked(StreamReader(bounded(f), emit_chunks=True, record_size_limit=size), skipped):
                # the summary section repeats the schemas and channels: each is registered once, by id
                if isinstance(rec, Schema) and rec.id not in schema_ids:
                    schema_ids[rec.id] = w.register_schema(rec.name, rec.encoding, rec.data)
                elif isinstance(rec, Channel) and rec.id not in channel_ids:
                    channel_ids[rec.id] = w.register_channel(
                        rec.topic, rec.message_encoding, schema_ids.get(rec.schema_id, 0), dict(rec.metadata)
                    )
                elif isinstance(rec, Message):
                    if rec.channel_id not in channel_ids:
                        continue
                    w.add_message(
                        channel_ids[rec.channel_id],
                        log_time=rec.log_time,
                        data=rec.data,
                        publish_time=rec.publish_time,
                        sequence=rec.sequence,
                    )
                    n += 1
                    first = rec.log_time if first is None else min(first, rec.log_time)
                    last = rec.log_time if last is None else max(last, rec.log_time)
                elif isinstance(rec, Metadata):
                    w.add_metadata(rec.name, dict(rec.metadata))
                    names.append(rec.name)
                elif isinstance(rec, Header):
                    library = rec.library
        except OSError:
            raise
        except Exception:
            ok = False
        read = f.tell()
        w.finish()
        o.flush()
        os.fsync(o.fileno())
    return n, first, last, read, ok, tuple(names), library, skipped


def _unchunked(stream: StreamReader, skipped: dict[str, int]) -> Iterator[object]:
    """The stream's records, each chunk's opened in its place; a chunk that fails its checks is left out
    and counted in ``skipped`` by why."""
    for rec in stream.records:
        if isinstance(rec, Chunk):
            try:
                yield from chunk_records(rec)
            except ChunkSkip as skip:
                skipped[skip.why] = skipped.get(skip.why, 0) + 1
        else:
            yield rec
