"""Bit flips inside zstd and lz4 chunks: every mutant replays to a clean end (exit 0 with counted skips, or
exit 2 with one line), within a time limit and a memory bound, whatever the flip claims.

The mutants are drawn with a seeded generator from a short recorded drive, each flipping a few bits of
one chunk's compressed bytes (or its frame header); each is replayed in its own process under
``RLIMIT_AS``, and its peak RSS is measured against the clean replay's."""

from __future__ import annotations

import random
import struct
import subprocess
import sys
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

MUTANTS = 8  # per compression
TIMEOUT_S = 60
ADDRESS_SPACE = 4 << 30  # RLIMIT_AS of each replay: a claimed 64 GiB allocation fails, a real 2 GiB one too
REPLAY = [sys.executable, "-m", "navlog.cli", "-q", "replay"]


def recompressed(src: Path, out: Path, compression: CompressionType, seconds: float) -> Path:
    """The first ``seconds`` of ``src`` in 16 KiB chunks of ``compression``."""
    with open(src, "rb") as f, open(out, "wb") as o:
        reader = make_reader(f)
        stats = reader.get_summary().statistics
        w = Writer(o, compression=compression, chunk_size=16 << 10)
        w.start(profile="ros2", library="test")
        sids: dict[int, int] = {}
        cids: dict[int, int] = {}
        end = stats.message_start_time + int(seconds * 1e9)
        for schema, channel, message in reader.iter_messages():  # in log-time order
            if message.log_time >= end:
                break
            if schema is not None and schema.id not in sids:
                sids[schema.id] = w.register_schema(schema.name, schema.encoding, schema.data)
            if channel.id not in cids:
                cids[channel.id] = w.register_channel(
                    channel.topic, channel.message_encoding, sids[channel.schema_id], dict(channel.metadata)
                )
            w.add_message(cids[channel.id], message.log_time, message.data, message.publish_time, message.sequence)
        w.finish()
    return out


def compressed_spans(path: Path) -> list[tuple[int, int]]:
    """(offset, length) of each chunk's compressed records in the file."""
    data = path.read_bytes()
    with open(path, "rb") as f:
        indexes = make_reader(f).get_summary().chunk_indexes
    spans = []
    for ci in indexes:
        body = ci.chunk_start_offset + 9
        (clen,) = struct.unpack_from("<I", data, body + 28)
        (rlen,) = struct.unpack_from("<Q", data, body + 32 + clen)
        spans.append((body + 40 + clen, rlen))
    return spans


def mutants(path: Path, folder: Path, seed: int) -> list[Path]:
    rng = random.Random(seed)
    data = path.read_bytes()
    spans = compressed_spans(path)
    out = []
    for k in range(MUTANTS):
        at, length = rng.choice(spans)
        buf = bytearray(data)
        head = k % 2 == 0  # half the flips land in the frame header (sizes, flags), half anywhere in the frame
        for _ in range(rng.randint(1, 4)):
            i = at + rng.randrange(min(length, 16) if head else length)
            buf[i] ^= 1 << rng.randrange(8)
        mutant = folder / f"{path.stem}-{k}.mcap"
        mutant.write_bytes(bytes(buf))
        out.append(mutant)
    return out


def peak_rss_kib(log: Path, out: Path) -> tuple[subprocess.CompletedProcess, int]:
    """A replay in a fresh process (run through a tiny parent that reports its child's peak RSS)."""
    script = (
        "import resource, subprocess, sys; "
        f"resource.setrlimit(resource.RLIMIT_AS, ({ADDRESS_SPACE}, {ADDRESS_SPACE})); "
        "p = subprocess.run(sys.argv[1:], capture_output=True, text=True); "
        "sys.stdout.write(p.stdout); sys.stderr.write(p.stderr); "
        "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, file=sys.stderr); sys.exit(p.returncode)"
    )
    argv = [*REPLAY, str(log), "--pipeline", "mapping", "--set", "lidar_mapper=off", "-o", str(out), "--force"]
    proc = subprocess.run(
        [sys.executable, "-c", script, *argv], capture_output=True, text=True, timeout=TIMEOUT_S, check=False
    )
    lines = proc.stderr.strip().splitlines()
    return proc, int(lines[-1]) if lines and lines[-1].isdigit() else 0


@pytest.mark.slow
@pytest.mark.parametrize("compression", [CompressionType.ZSTD, CompressionType.LZ4])
def test_bit_flips_in_compressed_chunks_end_cleanly_in_bounded_time_and_memory(teleop_log, tmp_path, compression):
    short = recompressed(teleop_log, tmp_path / "short.mcap", compression, 3.0)
    clean, clean_kib = peak_rss_kib(short, tmp_path / "clean")
    assert clean.returncode == 0, clean.stderr
    bound = clean_kib + 200 * 1024  # the clean replay's peak and 200 MiB
    outcomes = []
    for k, mutant in enumerate(mutants(short, tmp_path, seed=35 + int(compression == CompressionType.LZ4))):
        proc, kib = peak_rss_kib(mutant, tmp_path / f"out{k}")
        err = proc.stderr.strip().splitlines()[:-1]
        assert proc.returncode in (0, 2), (mutant.name, proc.stderr)
        assert "Traceback" not in proc.stderr and "Traceback" not in proc.stdout, (mutant.name, proc.stderr)
        if proc.returncode == 2:
            assert len(err) == 1 and err[0].startswith("navlog: error:") and "()" not in err[0], err
        else:
            assert "log: chunks skipped" in proc.stdout or "log: messages" in proc.stdout, (mutant.name, proc.stdout)
        assert kib < bound, (mutant.name, kib, bound)
        outcomes.append(proc.returncode)
    assert outcomes.count(0) >= MUTANTS // 2  # most flips cost one chunk, not the replay
