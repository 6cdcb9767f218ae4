"""A log time is evidence, not an order: a message whose log time a flipped bit moved outside its chunk's
time range is a counted skip, and the replay does not run its timers until then. (With the chunk's CRC
left as the writer computed it, the whole chunk is a counted skip: ``test_chunk_evidence``.) A log whose
first messages lie years before the rest replays from the rest, its timers not run over the years between."""

from __future__ import annotations

import signal
import struct
import zlib
from contextlib import contextmanager
from pathlib import Path

import pytest

from navlog.replay.io.formats import open_log
from navlog.replay.io.logwriter import McapLogWriter
from navlog.replay.io.reader import EARLY
from navlog.replay.runtime.executor import Envelope
from navlog.replay.session import run_replay

REASON = "messages whose log time lies outside their chunk's time range (corrupt log time)"
FLIP = 1 << 50  # ns: 13 days later


def fix_chunk_crc(data: bytearray, at: int) -> None:
    """Recompute the CRC of the uncompressed chunk holding byte ``at`` (as a writer that saw the bad time
    would have): the chunk's records are then intact, only the time is absurd."""
    pos = 8
    while pos < len(data):
        (length,) = struct.unpack_from("<Q", data, pos + 1)
        if data[pos] == 0x06 and pos < at < pos + 9 + length:
            body = pos + 9
            (clen,) = struct.unpack_from("<I", data, body + 28)
            records = body + 32 + clen + 8
            struct.pack_into("<I", data, body + 24, zlib.crc32(data[records : pos + 9 + length]))
            return
        pos += 9 + length
    raise AssertionError("no chunk holds the message")


def _finds(data: bytearray, pattern: bytes) -> list[int]:
    out, at = [], data.find(pattern)
    while at >= 0:
        out.append(at)
        at = data.find(pattern, at + 1)
    return out


@pytest.fixture(scope="module")
def flipped(teleop_log, tmp_path_factory) -> tuple[Path, int]:
    """The teleop log uncompressed, with bit 50 of the 50th /scan's log time flipped in the file's bytes."""
    path = tmp_path_factory.mktemp("log_times") / "flipped.mcap"
    scans = 0
    with McapLogWriter(path, compression="none") as w, open_log(teleop_log) as r:
        for env in r.messages(decode=False):
            w.write(env)
            if env.topic == "/scan" and (scans := scans + 1) == 50:
                t = env.time_ns
    with open_log(path) as r:
        (cid,) = [c for c, ch in r._summary.channels.items() if ch.topic == "/scan"]
    data = bytearray(path.read_bytes())
    # a Message record: channel id (u16), sequence (u32), log time, publish time (u64)
    found = [at for at in _finds(data, struct.pack("<QQ", t, t)) if data[at - 6 : at - 4] == struct.pack("<H", cid)]
    assert len(found) == 1
    data[found[0] : found[0] + 8] = struct.pack("<Q", t ^ FLIP)
    fix_chunk_crc(data, found[0])
    path.write_bytes(bytes(data))
    return path, t


def test_the_reader_skips_and_counts_a_far_future_log_time(flipped):
    path, t = flipped
    with open_log(path) as r:
        times = [env.time_ns for env in r.messages(["/scan"], decode=False)]
        assert r.report.skipped[REASON] == 1
        assert t not in times and max(times) <= r.end_ns and len(times) == r.topics["/scan"].count - 1


def test_a_replay_counts_it_and_ends_with_the_log(flipped, tmp_path):
    path, _ = flipped
    res = run_replay(path, "mapping", tmp_path / "out", overrides=["lidar_mapper=off"], progress=False)
    assert res.manifest["skipped"][f"log: {REASON}"] == 1
    with open_log(path) as r, open_log(res.out_dir / "replay.mcap") as out:
        assert out.end_ns <= r.end_ns + 2_000_000_000  # the last /map at most one publish period after the log


YEARS = 9 * 365 * 86400 * 10**9  # ns


@contextmanager
def _within(seconds: int):
    """Fails the test, instead of hanging it, when the block takes longer than ``seconds``."""

    def late(signum, frame):
        raise AssertionError(f"still running after {seconds} s")

    before = signal.signal(signal.SIGALRM, late)
    signal.alarm(seconds)
    try:
        yield
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, before)


def _later(msg, seconds: int) -> None:
    """``msg``'s header stamps (its own, its transforms') moved ``seconds`` later."""
    for header in [getattr(msg, "header", None), *(t.header for t in getattr(msg, "transforms", []))]:
        if header is not None:
            header.stamp.sec += seconds


@pytest.fixture(scope="module")
def early(teleop_log, tmp_path_factory) -> Path:
    """The teleop log with every message but its first 10 scans moved 9 years later (log times and stamps):
    a log whose first messages lie 9 years before the rest."""
    path = tmp_path_factory.mktemp("log_times") / "early.mcap"
    scans = 0
    with McapLogWriter(path) as w, open_log(teleop_log) as r:
        for env in r.messages():
            if env.topic == "/scan" and (scans := scans + 1) <= 10:
                w.write(env)
                continue
            _later(env.msg, YEARS // 10**9)
            w.write(Envelope(env.topic, env.typename, env.time_ns + YEARS, env.msg))
    return path


def test_a_replay_starts_where_the_trusted_messages_do_not_years_before(early, teleop_log, tmp_path):
    with _within(120):
        res = run_replay(early, "mapping", tmp_path / "out", overrides=["lidar_mapper=off"], progress=False)
    assert res.manifest["skipped"][f"log: {EARLY}"] == 10
    with open_log(early) as r, open_log(teleop_log) as original, open_log(res.out_dir / "replay.mcap") as out:
        assert r.start_ns == original.start_ns  # the log's own start: the early scans
        assert original.start_ns + YEARS <= out.start_ns and out.end_ns <= original.end_ns + YEARS + 2_000_000_000
