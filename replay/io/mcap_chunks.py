"""One MCAP chunk checked and opened: the sizes it claims are evidence, not orders.

A chunk record states how many bytes its records decompress to (``uncompressed_size``) and their CRC
(``uncompressed_crc``, 0 when the writer computed none); its index in the summary states where it lies
and how long it is. One flipped bit can turn any of these into a lie, so before a byte is allocated:

- an offset or length past the end of the file is refused (``span_error``);
- a decompressed size beyond what the compressed bytes can expand to is refused (``claim_error``): a
  zstd block expands at most 32768-fold (a 4-byte RLE block of 128 KiB), an lz4 sequence at most
  about 255-fold, an uncompressed chunk not at all; and no chunk may claim more than
  ``MAX_CHUNK_BYTES`` (1 GiB: writers cut chunks at a few MiB, so only a single message larger than
  any sensor's could need more);
- zstd and lz4 are decompressed by their libraries (``zstandard``, ``lz4``) only into as many bytes as
  the data really yields, never into the claimed size when the frame does not agree with it;
- the decompressed bytes must have the claimed size and, when the writer recorded one, the claimed CRC.

A chunk that fails is a ``ChunkSkip``: the readers count it (and the messages its indexes list) as
skipped and go on with the next chunk.
"""

from __future__ import annotations

import io
import os
import zlib
from typing import IO, Any, cast

from mcap.data_stream import ReadDataStream
from mcap.opcode import Opcode
from mcap.records import Channel, Chunk, Message, Schema

MAX_CHUNK_BYTES = 1 << 30
EXPANSION = {"zstd": 32768, "lz4": 256, "": 1}  # the most a compressed byte can decompress to
SLACK = 1 << 16  # frame headers and the last partial block
PIECE = 1 << 20  # bytes decompressed at a time where the frame does not state its size

CRC_MISMATCH = "CRC mismatch: corrupt data"
UNDECOMPRESSABLE = "does not decompress: corrupt data"
WRONG_SIZE = "decompresses to another size than it claims"
BEYOND_FILE = "offset or length beyond the end of the file"
CLAIM = "claims more decompressed bytes than its compressed bytes can hold"
NOT_A_CHUNK = "no chunk record at the offset its index gives"
UNREADABLE = "unreadable chunk record"
UNKNOWN_COMPRESSION = "names a compression MCAP does not have"


class ChunkSkip(Exception):
    """A chunk that cannot be trusted: ``why`` (one of the reasons above) and its messages, if known."""

    def __init__(self, why: str, messages: int = 0) -> None:
        super().__init__(why)
        self.why, self.messages = why, messages


def chunk_skip_reasons(why: str) -> tuple[str, str]:
    """The two reasons a skipped chunk is counted under in a ``ReadReport``: its chunks and its messages."""
    return f"chunks skipped ({why})", f"messages in skipped chunks ({why})"


def claim_error(compression: str, compressed: int, uncompressed: int) -> str:
    """Why ``uncompressed`` bytes cannot come from ``compressed`` bytes of ``compression``, or ''."""
    if compression not in EXPANSION:
        return UNKNOWN_COMPRESSION
    if compression == "" and uncompressed != compressed:
        return WRONG_SIZE
    if uncompressed > MAX_CHUNK_BYTES or uncompressed > compressed * EXPANSION[compression] + SLACK:
        return CLAIM
    return ""


def span_error(offset: int, length: int, size: int) -> str:
    """Why ``length`` bytes at ``offset`` do not lie in a file of ``size`` bytes, or ''."""
    return BEYOND_FILE if offset < 0 or length < 0 or offset + length > size else ""


def decompress(chunk: Chunk) -> bytes:
    """A chunk's records, decompressed and checked (module docstring); raises ``ChunkSkip``."""
    claim = chunk.uncompressed_size
    why = claim_error(chunk.compression, len(chunk.data), claim)
    if why:
        raise ChunkSkip(why)
    try:
        data = _decompress(chunk.compression, chunk.data, claim)
    except ChunkSkip:
        raise
    except Exception:
        raise ChunkSkip(UNDECOMPRESSABLE) from None
    if len(data) != claim:
        raise ChunkSkip(WRONG_SIZE)
    if chunk.uncompressed_crc and zlib.crc32(data) != chunk.uncompressed_crc:
        raise ChunkSkip(CRC_MISMATCH)
    return data


def _decompress(compression: str, data: bytes, claim: int) -> bytes:
    if compression == "":
        return data
    if compression == "zstd":
        import zstandard

        stated = zstandard.frame_content_size(data)
        if stated == claim:  # the frame agrees with the chunk: one allocation of the (bounded) size
            return zstandard.ZstdDecompressor().decompress(data)
        if stated >= 0:  # two claims that disagree: one of them is corrupt
            raise ChunkSkip(WRONG_SIZE)
        reader = zstandard.ZstdDecompressor().stream_reader(data, read_across_frames=True)
        return _pieces(reader.read, claim)
    if compression == "lz4":
        import lz4.frame

        lz4_reader = lz4.frame.LZ4FrameDecompressor()
        first = [True]

        def read(n: int) -> bytes:
            if lz4_reader.eof:
                return b""
            out = lz4_reader.decompress(data if first[0] else b"", max_length=n)
            first[0] = False
            return out

        return _pieces(read, claim)
    raise ChunkSkip(UNKNOWN_COMPRESSION)


def _pieces(read: Any, claim: int) -> bytes:
    """Up to ``claim + 1`` bytes from ``read``, ``PIECE`` at a time: memory follows what the data yields."""
    parts: list[bytes] = []
    got = 0
    while got <= claim:
        piece = read(min(PIECE, claim + 1 - got))
        if not piece:
            break
        parts.append(piece)
        got += len(piece)
    if got > claim:
        raise ChunkSkip(WRONG_SIZE)
    return b"".join(parts)


def chunk_records(chunk: Chunk) -> list[Any]:
    """The schema, channel and message records of a chunk (checked by ``decompress``), in order; a record
    that does not fit in the chunk ends the list with a ``ChunkSkip``."""
    return records_of(decompress(chunk))


def records_of(data: bytes) -> list[Any]:
    """The schema, channel and message records in a chunk's decompressed bytes (see ``chunk_records``)."""
    stream = ReadDataStream(io.BytesIO(data))
    out: list[Any] = []
    try:
        while stream.count < len(data):
            opcode = stream.read1()
            length = stream.read8()
            if length > len(data) - stream.count:
                raise ChunkSkip(UNREADABLE)
            if opcode == Opcode.MESSAGE:
                out.append(Message.read(stream, length))
            elif opcode == Opcode.CHANNEL:
                out.append(Channel.read(stream))
            elif opcode == Opcode.SCHEMA:
                out.append(Schema.read(stream))
            else:
                stream.read(length)
    except ChunkSkip:
        raise
    except Exception:
        raise ChunkSkip(UNREADABLE) from None
    return out


class BoundedFile:
    """A file whose reads never ask for more than it holds: the ``mcap`` library's record parsers read a
    record's claimed length in one call, and a read of 64 GiB allocates 64 GiB before it finds the end.
    (Not an ``io.RawIOBase``: the library would wrap that in a buffer, which closes it when dropped.)"""

    def __init__(self, f: Any) -> None:
        self._f = f
        self._size = os.fstat(f.fileno()).st_size

    def readable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def seek(self, offset: int, whence: int = 0) -> int:
        return self._f.seek(offset, whence)

    def tell(self) -> int:
        return self._f.tell()

    def read(self, n: int = -1) -> bytes:
        left = max(0, self._size - self._f.tell())
        data: bytes = self._f.read(left if n is None or n < 0 else min(n, left))
        return data


def bounded(f: Any) -> IO[bytes]:
    """``f`` read through a ``BoundedFile``, typed as the file the ``mcap`` library's readers take."""
    return cast(IO[bytes], BoundedFile(f))


def reason(exc: BaseException) -> str:
    """An exception as the parenthesis of a one-line error: its text, or its kind when it has none."""
    return str(exc) or {"MemoryError": "a size beyond memory"}.get(type(exc).__name__, type(exc).__name__)
