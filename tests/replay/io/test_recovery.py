"""``recover_mcap``: every complete chunk of a cut MCAP file is kept; a file with none is a clear error."""

from __future__ import annotations

import io
import struct
from pathlib import Path

import pytest
from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer

from navlog.errors import LogError
from navlog.replay import messages
from navlog.replay.io import open_log
from navlog.replay.io.atomic import WriteError
from navlog.replay.io.recovery import recover_mcap

STRING = "std_msgs/msg/String"


def chatter_log(path: Path, count: int = 60) -> list[bytes]:
    """A zstd MCAP of ``count`` 10 Hz /chatter strings in 1 KiB chunks (about 6 messages a chunk)."""
    store = messages.typestore()
    payloads = [
        bytes(store.serialize_cdr(store.types[STRING](data=f"message {i:03d} " * 8), STRING)) for i in range(count)
    ]
    with open(path, "wb") as f:
        w = Writer(f, compression=CompressionType.ZSTD, chunk_size=1024)
        w.start(profile="ros2", library="test")
        sid = w.register_schema(STRING, "ros2msg", b"string data")
        cid = w.register_channel("/chatter", "cdr", sid)
        for i, data in enumerate(payloads):
            w.add_message(cid, log_time=(i + 1) * 10**8, data=data, publish_time=(i + 1) * 10**8, sequence=i)
        w.finish()
    return payloads


def chunk_ends(path: Path) -> list[tuple[int, int]]:
    """(end offset, messages up to it) of each chunk of a ``chatter_log`` (message i is at (i + 1) * 0.1 s)."""
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    chunks = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)
    return [(c.chunk_start_offset + c.chunk_length, c.message_end_time // 10**8) for c in chunks]


def read_back(path: Path) -> list[bytes]:
    with open_log(path) as reader:
        assert not reader.report.truncated
        return [bytes(e.msg) for e in reader.messages(decode=False)]


def test_a_cut_file_keeps_exactly_its_complete_chunks(tmp_path: Path) -> None:
    log = tmp_path / "run.mcap"
    payloads = chatter_log(log)
    ends = chunk_ends(log)
    assert len(ends) >= 8  # the test needs many chunks
    end, kept = ends[4]
    cut = tmp_path / "run.mcap.part"
    cut.write_bytes(log.read_bytes()[: end + 5])  # chunk 5 whole, a few bytes of what follows
    res = recover_mcap(cut, tmp_path / "fixed.mcap")
    assert (res.messages, res.complete) == (kept, False)
    assert (res.first_ns, res.last_ns) == (10**8, kept * 10**8)
    assert res.seconds == pytest.approx((kept - 1) / 10)
    assert read_back(tmp_path / "fixed.mcap") == payloads[:kept]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fixed.mcap", "run.mcap", "run.mcap.part"]


@pytest.mark.parametrize("cut", [None, "summary"])
def test_a_whole_file_is_copied_whole(tmp_path: Path, cut: str | None) -> None:
    """A whole file, or one cut in its summary section (killed while finishing it): every message,
    and each channel once (the summary repeats the schemas and channels)."""
    log = tmp_path / "run.mcap"
    payloads = chatter_log(log)
    if cut:
        data = log.read_bytes()
        # the footer: opcode, length, summary start, summary offset start, crc; then the magic bytes
        (summary_start,) = struct.unpack_from("<Q", data, len(data) - 8 - 29 + 9)
        assert 0 < summary_start < len(data) - 200
        (tmp_path / "cut.mcap").write_bytes(data[: len(data) - 50])  # the summary's schemas and channels, not its end
        log = tmp_path / "cut.mcap"
    res = recover_mcap(log, tmp_path / "fixed.mcap")
    assert (res.messages, res.complete) == (60, cut is None)
    assert res.bytes_read == log.stat().st_size or cut
    assert read_back(tmp_path / "fixed.mcap") == payloads
    with open_log(tmp_path / "fixed.mcap") as reader:
        assert {t: i.count for t, i in reader.topics.items()} == {"/chatter": 60}
    with open(tmp_path / "fixed.mcap", "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and len(summary.channels) == len(summary.schemas) == 1


@pytest.mark.parametrize("keep", ["magic", "header", "half-chunk"])
def test_a_file_without_a_complete_chunk_is_an_error_and_writes_nothing(tmp_path: Path, keep: str) -> None:
    log = tmp_path / "run.mcap"
    chatter_log(log)
    first_end = chunk_ends(log)[0][0]
    size = {"magic": 8, "header": 40, "half-chunk": first_end - 200}[keep]
    cut = tmp_path / "cut.mcap.part"
    cut.write_bytes(log.read_bytes()[:size])
    out = tmp_path / "fixed.mcap"
    with pytest.raises(LogError, match=r"cut\.mcap\.part: nothing to recover: no complete chunk holds a message"):
        recover_mcap(cut, out)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cut.mcap.part", "run.mcap"]  # no output, no temporary


def test_a_file_with_no_message_is_an_error(tmp_path: Path) -> None:
    empty = tmp_path / "empty.mcap"
    buf = io.BytesIO()
    w = Writer(buf)
    w.start(profile="ros2", library="test")
    w.register_channel("/chatter", "cdr", w.register_schema(STRING, "ros2msg", b"string data"))
    w.finish()
    empty.write_bytes(buf.getvalue())
    with pytest.raises(LogError, match="the file holds no message"):
        recover_mcap(empty, tmp_path / "fixed.mcap")
    assert not (tmp_path / "fixed.mcap").exists()


def test_the_recover_command_exits_2_and_writes_nothing(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from navlog.cli import main

    log = tmp_path / "run.mcap"
    chatter_log(log)
    cut = tmp_path / "cut.mcap.part"
    cut.write_bytes(log.read_bytes()[:100])
    assert main(["recover", str(cut), "-o", str(tmp_path / "fixed.mcap")]) == 2
    err = capsys.readouterr().err
    assert "nothing to recover" in err and "record it again" in err and "Traceback" not in err
    assert not (tmp_path / "fixed.mcap").exists() and not (tmp_path / "fixed.mcap.part").exists()


def test_a_write_that_fails_is_one_clear_error_and_leaves_nothing(tmp_path: Path, monkeypatch) -> None:
    import navlog.replay.io.recovery as recovery

    log = tmp_path / "run.mcap"
    chatter_log(log)

    def full_disk(src: Path, tmp: Path):
        tmp.write_bytes(b"partial")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(recovery, "_copy_complete_records", full_disk)
    with pytest.raises(Exception, match="fixed.mcap: cannot write: No space left on device") as info:
        recover_mcap(log, tmp_path / "fixed.mcap")
    assert isinstance(info.value, WriteError) and info.value.path == tmp_path / "fixed.mcap"  # a NavlogError
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.mcap"]


@pytest.mark.parametrize("cut", [False, True])
def test_a_topic_on_two_channels_counts_and_reads_the_messages_of_both(tmp_path: Path, cut: bool) -> None:
    """A file whose topic is on two channels (as the recovery of a file cut in its summary once wrote):
    the reader counts and reads the messages of both, from its summary or, cut, by reading it through."""
    store = messages.typestore()
    data = [bytes(store.serialize_cdr(store.types[STRING](data=f"m{i}"), STRING)) for i in range(5)]
    log = tmp_path / "two.mcap"
    with open(log, "wb") as f:
        w = Writer(f, compression=CompressionType.ZSTD, chunk_size=64)
        w.start(profile="ros2", library="test")
        sid = w.register_schema(STRING, "ros2msg", b"string data")
        first, second = w.register_channel("/chatter", "cdr", sid), w.register_channel("/chatter", "cdr", sid)
        for i, d in enumerate(data):
            w.add_message(first if i < 3 else second, log_time=(i + 1) * 10**8, data=d, publish_time=(i + 1) * 10**8)
        w.finish()
    if cut:
        log.write_bytes(log.read_bytes()[:-60])
    with open_log(log, recover=cut) as reader:
        assert reader.report.truncated == cut
        assert {t: i.count for t, i in reader.topics.items()} == {"/chatter": 5}
        assert [bytes(e.msg) for e in reader.messages(decode=False)] == data


def test_a_folder_is_named_as_a_folder_with_what_recover_expects(tmp_path: Path, capsys) -> None:
    from navlog.cli import main

    assert main(["recover", str(tmp_path), "-o", str(tmp_path / "fixed.mcap")]) == 2
    err = capsys.readouterr().err
    assert f"{tmp_path}: is a folder" in err and "truncated .mcap file" in err and "NAME.mcap.part" in err
    assert "no such file" not in err
    assert not (tmp_path / "fixed.mcap").exists()


@pytest.mark.parametrize(
    "argv",
    [
        ["info", "{log}"],
        ["check", "{log}"],
        ["replay", "{log}", "--pipeline", "mapping", "-o", "{out}"],
        ["recover", "{log}", "-o", "{out}.mcap"],
    ],
)
def test_an_empty_mcap_file_is_called_empty_not_bad_magic(tmp_path: Path, capsys, argv: list[str]) -> None:
    from navlog.cli import main

    log = tmp_path / "run.mcap"
    log.write_bytes(b"")
    out = tmp_path / "out"
    assert main([a.format(log=log, out=out) for a in argv]) == 2
    err = capsys.readouterr().err
    assert f"{log}: the file is empty (0 bytes)" in err and "magic" not in err
    assert not out.exists() and not Path(f"{out}.mcap").exists()


def test_a_cut_navlog_recording_keeps_its_metadata(tmp_path: Path, capsys) -> None:
    """navlog writes its metadata record first: a recording cut short (kill -9) and recovered still
    names its world, robot and seed."""
    from navlog.cli import main
    from navlog.replay.io.logwriter import McapLogWriter

    store = messages.typestore()
    log = tmp_path / "run.mcap"
    meta = {"navlog": {"world": "indoor_room", "robot": "kibot", "seed": "7"}}
    with McapLogWriter(log, metadata=meta, chunk_size=1024) as w:
        for i in range(60):
            data = bytes(store.serialize_cdr(store.types[STRING](data=f"message {i:03d} " * 8), STRING))
            w.write_raw("/chatter", STRING, (i + 1) * 10**8, data)
    with open_log(log) as reader:
        assert reader.metadata["navlog"]["seed"] == "7"
    end, _ = chunk_ends(log)[3]
    cut = tmp_path / "run.mcap.part"
    cut.write_bytes(log.read_bytes()[: end + 5])
    assert main(["recover", str(cut), "-o", str(tmp_path / "fixed.mcap")]) == 0
    out = capsys.readouterr().out
    assert "the input was truncated" in out and "metadata lost" not in out
    with open_log(tmp_path / "fixed.mcap") as reader:
        assert reader.metadata["navlog"] == {"world": "indoor_room", "robot": "kibot", "seed": "7"}
        assert reader.message_count > 0
    assert log.read_bytes().index(b"indoor_room") < chunk_ends(log)[0][0]  # the record comes before the first chunk
