"""A chunk's sizes, offsets and CRC are evidence, not orders: a chunk that fails them is a counted skip (its
chunk and the messages its indexes list), the other chunks are read, and nothing is allocated by a lie.
Log times that jump an hour away from their neighbours are counted skips too."""

from __future__ import annotations

import struct
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import CompressionType

from navlog.analysis.info import summarize
from navlog.errors import LogError
from navlog.replay.io import open_log
from navlog.replay.io.mcap_chunks import (
    BEYOND_FILE,
    CLAIM,
    CRC_MISMATCH,
    WRONG_SIZE,
    chunk_skip_reasons,
    reason,
)
from navlog.replay.io.reader import EARLY, LATE
from navlog.replay.io.recovery import recover_mcap

from .test_mcap_reader import write_mcap

N = 300  # messages of /a, 10 ms apart, 40 bytes each: chunks of a few


def messages(times=None) -> list[tuple[str, int, bytes]]:
    times = times or [k * 10_000_000 for k in range(N)]
    return [("/a", t, b"a%04d" % k + b"." * 35) for k, t in enumerate(times)]


def chunk_at(path: Path, i: int) -> tuple[int, int]:
    """(file offset of chunk ``i``'s record body, its compression string's length)."""
    with open(path, "rb") as f:
        ci = make_reader(f).get_summary().chunk_indexes[i]
    data = path.read_bytes()
    body = ci.chunk_start_offset + 9
    (clen,) = struct.unpack_from("<I", data, body + 28)
    return body, clen


def patch(path: Path, at: int, fmt: str, value: int) -> None:
    data = bytearray(path.read_bytes())
    struct.pack_into(fmt, data, at, value)
    path.write_bytes(bytes(data))


def summary_records(data: bytes) -> list[tuple[int, int]]:
    """(offset, opcode) of the summary section's records (from the footer's summary_start)."""
    (pos,) = struct.unpack_from("<Q", data, len(data) - 8 - 20)
    out = []
    while data[pos] != 0x02:  # up to the footer
        out.append((pos, data[pos]))
        pos += 9 + struct.unpack_from("<Q", data, pos + 1)[0]
    return out


def read(path: Path) -> tuple[list[bytes], dict[str, int]]:
    with open_log(path) as r:
        got = [env.msg for env in r.messages(["/a"], decode=False)]
        return got, dict(r.report.skipped)


def per_chunk(path: Path, i: int) -> list[bytes]:
    with open(path, "rb") as f:
        ci = make_reader(f).get_summary().chunk_indexes[i]
    with open_log(path) as r:
        return [
            env.msg
            for env in r.messages(["/a"], decode=False, start_ns=ci.message_start_time, end_ns=ci.message_end_time)
        ]


@pytest.mark.parametrize("compression", [CompressionType.NONE, CompressionType.ZSTD, CompressionType.LZ4])
def test_a_flipped_crc_skips_its_chunk_and_counts_it(tmp_path, compression):
    path = write_mcap(tmp_path / "x.mcap", messages(), compression=compression, chunk_size=400)
    lost = per_chunk(path, 3)
    body, _ = chunk_at(path, 3)
    data = bytearray(path.read_bytes())
    data[body + 24] ^= 0x01  # the chunk's uncompressed_crc
    path.write_bytes(bytes(data))
    got, skipped = read(path)
    chunks, msgs = chunk_skip_reasons(CRC_MISMATCH)
    assert skipped == {chunks: 1, msgs: len(lost)} and len(lost) > 2
    assert len(got) == N - len(lost) and not set(lost) & set(got)


def test_a_flipped_byte_in_an_uncompressed_chunk_is_not_silently_wrong_data(tmp_path):
    path = write_mcap(tmp_path / "x.mcap", messages(), compression=CompressionType.NONE, chunk_size=400)
    data = bytearray(path.read_bytes())
    at = data.find(b"a0042")
    data[at + 4] ^= 0x04  # "a0042" -> "a0046": a payload the writer never wrote
    path.write_bytes(bytes(data))
    got, skipped = read(path)
    assert skipped[chunk_skip_reasons(CRC_MISMATCH)[0]] == 1
    assert b"a0042" + b"." * 35 not in got and got.count(b"a0046" + b"." * 35) == 1


@pytest.mark.parametrize("claim", [2 << 30, 64 << 30])
def test_a_huge_decompressed_size_claim_is_a_counted_skip(tmp_path, claim):
    path = write_mcap(tmp_path / "x.mcap", messages(), chunk_size=400)
    lost = per_chunk(path, 5)
    body, _ = chunk_at(path, 5)
    patch(path, body + 16, "<Q", claim)  # the chunk record's uncompressed_size
    got, skipped = read(path)
    assert skipped == {chunk_skip_reasons(CLAIM)[0]: 1, chunk_skip_reasons(CLAIM)[1]: len(lost)}
    assert len(got) == N - len(lost)


def test_a_size_claim_the_frame_contradicts_is_a_counted_skip(tmp_path):
    path = write_mcap(tmp_path / "x.mcap", messages(), chunk_size=400)
    body, _ = chunk_at(path, 5)
    with open(path, "rb") as f:
        size = make_reader(f).get_summary().chunk_indexes[5].uncompressed_size
    patch(path, body + 16, "<Q", size + 1)
    assert read(path)[1][chunk_skip_reasons(WRONG_SIZE)[0]] == 1


@pytest.mark.parametrize("length", [2 << 30, 64 << 30])
def test_a_huge_chunk_length_in_the_index_is_a_counted_skip_not_an_allocation(tmp_path, length):
    path = write_mcap(tmp_path / "x.mcap", messages(), chunk_size=400)
    lost = per_chunk(path, 0)
    at = [pos for pos, op in summary_records(path.read_bytes()) if op == 0x08]  # the chunk indexes
    patch(path, at[0] + 9 + 24, "<Q", length)
    with open_log(path) as r:
        assert summarize(r)["skipped"] == {chunk_skip_reasons(BEYOND_FILE)[0]: 1}  # `navlog info` says so
        got = [env.msg for env in r.messages(["/a"], decode=False)]
    assert len(got) == N - len(lost) and got[0] not in lost


def test_an_error_never_has_an_empty_parenthesis():
    assert reason(MemoryError()) == "a size beyond memory"
    assert reason(EOFError()) == "EOFError" and reason(ValueError("bad")) == "bad"


def test_a_corrupt_summary_names_what_went_wrong(tmp_path):
    path = write_mcap(tmp_path / "x.mcap", messages(), chunk_size=400)
    data = bytearray(path.read_bytes())
    first = summary_records(bytes(data))[0][0]
    struct.pack_into("<Q", data, first + 1, 64 << 30)  # the summary's first record claims 64 GiB
    path.write_bytes(bytes(data))
    with pytest.raises(LogError, match=r"corrupt MCAP \(\w"):
        open_log(path)


# ------------------------------------------------------------------------------------------ log times
HOUR = 3600 * 10**9


@pytest.mark.parametrize("compression", [CompressionType.NONE, CompressionType.ZSTD])
def test_a_log_time_the_writer_recorded_days_ahead_is_a_counted_skip(tmp_path, compression):
    # the writer itself stamped it (its chunk's span and the statistics include it): only the jump tells
    times = [k * 10_000_000 for k in range(N)]
    times[150] += 1 << 50  # 13 days
    path = write_mcap(tmp_path / "x.mcap", messages(sorted(times)), compression=compression, chunk_size=400)
    got, skipped = read(path)
    assert skipped == {LATE: 1} and len(got) == N - 1


def test_a_log_time_days_early_is_a_counted_skip(tmp_path):
    times = [HOUR * 24 * 30 + k * 10_000_000 for k in range(N)]
    times[0] = 5  # the epoch, a month before the rest
    got, skipped = read(write_mcap(tmp_path / "x.mcap", messages(times), chunk_size=400))
    assert skipped == {EARLY: 1} and len(got) == N - 1 and got[0].startswith(b"a0001")


def test_a_jump_in_a_truncated_log_is_a_counted_skip(tmp_path):
    times = [k * 10_000_000 for k in range(N)]
    times[-1] += 1 << 52
    path = write_mcap(tmp_path / "x.mcap", messages(times), chunk_size=400)
    data = path.read_bytes()
    cut = tmp_path / "cut.mcap"
    with open(path, "rb") as f:
        end = make_reader(f).get_summary().chunk_indexes[-1]
    cut.write_bytes(data[: end.chunk_start_offset + end.chunk_length + end.message_index_length])
    with open_log(cut, recover=True) as r:
        got = [env.msg for env in r.messages(["/a"], decode=False)]
        assert r.report.skipped[LATE] == 1 and len(got) == N - 1


def test_a_short_log_keeps_its_longest_run(tmp_path):
    times = [0, 10, 20, 5 * HOUR, 5 * HOUR + 10]  # never 16 in a row: the longer run is kept
    got, skipped = read(write_mcap(tmp_path / "x.mcap", messages(times)))
    assert skipped == {LATE: 2} and len(got) == 3


def test_recover_leaves_a_damaged_chunk_out_instead_of_giving_it_a_valid_crc(tmp_path):
    path = write_mcap(tmp_path / "x.mcap", messages(), chunk_size=400)
    lost = per_chunk(path, 3)
    body, _ = chunk_at(path, 3)
    data = bytearray(path.read_bytes())
    data[body + 24] ^= 0x01
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(bytes(data[: len(data) * 4 // 5]))  # and cut: a recording killed later on
    res = recover_mcap(cut, tmp_path / "fixed.mcap")
    assert res.chunks_skipped == {CRC_MISMATCH: 1}
    got, skipped = read(tmp_path / "fixed.mcap")
    assert skipped == {} and len(got) == res.messages and not set(lost) & set(got)


def test_times_that_jump_everywhere_hold_a_bounded_number_of_messages(tmp_path):
    times = [k * 2 * HOUR for k in range(100)]  # no run of 16: after HELD_AT_MOST, the earliest one is trusted
    got, skipped = read(write_mcap(tmp_path / "x.mcap", messages(times)))
    assert skipped == {LATE: 99} and got == [messages(times)[0][2]]


def test_a_message_on_a_channel_never_defined_is_a_counted_skip(tmp_path):
    # a recording cut short (no index: read record by record) whose one message names channel 999 (a
    # damaged channel id): that message is skipped and counted, the rest read
    from mcap.writer import Writer

    path = tmp_path / "x.mcap"
    with open(path, "wb") as f:
        w = Writer(f, chunk_size=400, compression=CompressionType.NONE, enable_crcs=False)
        w.start(profile="ros2", library="test")
        cid = w.register_channel("/a", "cdr", w.register_schema("std_msgs/msg/String", "ros2msg", b"string data"))
        for k, t in enumerate(range(0, N * 10_000_000, 10_000_000)):
            w.add_message(cid, log_time=t, data=b"a%04d" % k + b"." * 35, publish_time=t, sequence=k)
        w.finish()
    data = bytearray(path.read_bytes())
    at = data.index(b"a0100") - 22  # the message record: channel id (u16), sequence, log and publish times, data
    assert struct.unpack_from("<H", data, at)[0] == cid
    struct.pack_into("<H", data, at, 999)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(bytes(data[: len(data) * 9 // 10]))
    with open_log(cut, recover=True) as r:
        got = [env.msg for env in r.messages(["/a"], decode=False)]
        assert r.report.skipped["messages on undefined channel 999"] == 1
    assert b"a0100" + b"." * 35 not in got and b"a0099" + b"." * 35 in got and len(got) > 200
