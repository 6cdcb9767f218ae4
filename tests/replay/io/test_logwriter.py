"""McapLogWriter: writing from a thread gives the same file, and its failures reach the caller."""

from __future__ import annotations

import errno
from pathlib import Path

import numpy as np
import pytest

from navlog.errors import NavlogError
from navlog.replay import messages
from navlog.replay.io import logwriter, open_log
from navlog.replay.io.cdr import layout
from navlog.replay.io.logwriter import McapLogWriter
from navlog.replay.pointcloud import xyz_cloud
from navlog.replay.runtime.executor import Envelope


def _envelopes(n: int) -> list[Envelope]:
    """IMU samples as CDR bytes, clock and TF as objects, and a 100 kB blob every 50th message."""
    rng = np.random.default_rng(4)
    imu = layout(messages.IMU)
    cov = (0.0,) * 9
    out = []
    for i in range(n):
        t = i * 5_000_000
        sec, nsec = divmod(t, 1_000_000_000)
        if i % 50 == 0:
            blob = messages.msg_class("std_msgs/msg/String")(data="x" * 100_000)
            out.append(Envelope("/blob", "std_msgs/msg/String", t, blob))
        elif i % 2:
            g = rng.normal(size=3).tolist()
            data = imu.encode((sec, nsec, "imu_link", 0.0, 0.0, 0.0, 1.0, *cov, *g, *cov, *g, *cov))
            out.append(Envelope("/imu/data", messages.IMU, t, data))
        elif i % 4:
            out.append(Envelope("/clock", messages.CLOCK, t, messages.clock(t)))
        else:
            tf = messages.transform_stamped(t, "odom", "base_link", (i * 0.01, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
            out.append(Envelope("/tf", messages.TF_MESSAGE, t, messages.tf_message([tf])))
    return out


def _write(path: Path, envelopes: list[Envelope], **kw) -> McapLogWriter:
    with McapLogWriter(path, metadata={"navlog": {"seed": "4"}}, chunk_size=1 << 18, **kw) as w:
        for env in envelopes:
            w.write(env)
    return w


def test_writing_from_a_thread_gives_the_same_bytes(tmp_path):
    envs = _envelopes(3000)
    _write(tmp_path / "direct.mcap", envs)
    # tiny batches and a short queue: the caller waits on the writer thread again and again
    w = _write(tmp_path / "thread.mcap", envs, background=True, batch_bytes=4096, queue_batches=2)
    assert (tmp_path / "thread.mcap").read_bytes() == (tmp_path / "direct.mcap").read_bytes()
    assert w.count == 3000 and w.first_ns == 0 and w.last_ns == 2999 * 5_000_000
    assert w.topic_types == {
        "/blob": "std_msgs/msg/String",
        "/imu/data": messages.IMU,
        "/clock": messages.CLOCK,
        "/tf": messages.TF_MESSAGE,
    }
    with open_log(tmp_path / "thread.mcap") as reader:
        counts = {t: i.count for t, i in reader.topics.items()}
        imu = next(reader.messages(["/imu/data"])).msg
    assert counts == {"/blob": 60, "/imu/data": 1500, "/clock": 720, "/tf": 720}
    assert imu.header.frame_id == "imu_link" and imu.orientation.w == 1.0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["direct.mcap", "thread.mcap"]  # no partial file left


def test_a_second_type_on_a_topic_is_refused_in_the_callers_thread(tmp_path):
    out = tmp_path / "x.mcap"
    refused = "topic /clock: published as geometry_msgs/msg/Twist but already recorded"
    with pytest.raises(NavlogError, match=refused), McapLogWriter(out, background=True) as w:
        w.write(Envelope("/clock", messages.CLOCK, 0, messages.clock(0)))
        w.write(Envelope("/clock", messages.TWIST, 1, messages.twist(0.1, 0.0, 0.0)))
    assert list(tmp_path.iterdir()) == []


class _FullDisk:
    """A file that takes ``room`` bytes, then fails as a full disk does."""

    def __init__(self, f, room: int) -> None:
        self._f, self.room = f, room

    def write(self, data) -> int:
        if len(data) > self.room:
            raise OSError(errno.ENOSPC, "No space left on device")
        self.room -= len(data)
        return self._f.write(data)

    def __getattr__(self, name):
        return getattr(self._f, name)


@pytest.mark.parametrize("background", [False, True])
def test_a_full_disk_is_one_clear_error_and_leaves_nothing(tmp_path, monkeypatch, background):
    real_open = logwriter.open_new
    monkeypatch.setattr(logwriter, "open_new", lambda p: _FullDisk(real_open(p), 20_000))
    out = tmp_path / "run.mcap"
    with pytest.raises(NavlogError) as info:
        _write(out, _envelopes(3000), background=background, batch_bytes=4096)
    assert str(info.value) == (
        f"{out}: cannot write: No space left on device (a full disk or a file-size limit?); "
        "the partial file was removed"
    )
    assert list(tmp_path.iterdir()) == []


def test_ctrl_c_finishes_what_was_written(tmp_path):
    out = tmp_path / "run.mcap"
    envs = _envelopes(500)
    with pytest.raises(KeyboardInterrupt), McapLogWriter(out, background=True, batch_bytes=4096) as w:
        for env in envs:
            w.write(env)
        raise KeyboardInterrupt
    with open_log(out) as reader:
        assert sum(i.count for i in reader.topics.values()) == 500
        assert not reader.report.truncated


def test_abort_stops_the_thread_and_removes_the_partial_file(tmp_path):
    out = tmp_path / "run.mcap"
    w = McapLogWriter(out, background=True, batch_bytes=4096, queue_batches=1)
    for env in _envelopes(1000):
        w.write(env)
    w.abort()
    assert w._thread is None
    assert list(tmp_path.iterdir()) == []


def _with_clouds(n: int) -> list[Envelope]:
    """``_envelopes`` with a 1000-point PointCloud2 every 20th message (a 10 Hz LiDAR among 200 Hz IMU)."""
    out = []
    for k, env in enumerate(_envelopes(n)):
        out.append(env)
        if k % 20 == 0:
            pts = np.full((1000, 3), k, dtype=np.float32)
            cloud = xyz_cloud(env.time_ns, "livox_frame", pts)
            out.append(Envelope("/livox/lidar", messages.POINT_CLOUD2, env.time_ns, cloud))
    return out


@pytest.mark.parametrize("background", [False, True])
def test_bulk_clouds_get_chunks_of_their_own(tmp_path: Path, background: bool) -> None:
    from mcap.reader import make_reader

    envs = _with_clouds(3000)  # 15 s of log
    path = tmp_path / "bulk.mcap"
    with McapLogWriter(path, chunk_size=256 << 10, held_ns=1_000_000_000, background=background) as w:
        for env in envs:
            w.write(env)
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    lidar = next(cid for cid, ch in summary.channels.items() if ch.topic == "/livox/lidar")
    kinds = [set(ci.message_index_offsets) for ci in summary.chunk_indexes]
    assert all(k == {lidar} or lidar not in k for k in kinds)  # no chunk mixes clouds and the rest
    small = [ci for ci, k in zip(summary.chunk_indexes, kinds, strict=True) if lidar not in k]
    assert len(small) >= 14  # one per second of log (held_ns), the last one at close
    assert all(ci.message_end_time - ci.message_start_time < 1_000_000_000 for ci in small)
    # every message comes back in time order, the clouds' bytes unchanged, through navlog's and mcap's readers
    with open_log(path) as reader:
        got = [(e.topic, e.time_ns, bytes(e.msg)) for e in reader.messages(decode=False)]
    expected = sorted(
        (
            (e.topic, e.time_ns, e.msg if isinstance(e.msg, bytes) else messages.serialize(e.msg, e.typename))
            for e in envs
        ),
        key=lambda x: (x[1], x[0] == "/livox/lidar"),  # at equal times the rest before the clouds
    )
    assert [(t, ns) for t, ns, _ in got] == [(t, ns) for t, ns, _ in expected]
    assert sorted(got) == sorted(expected)
    with open(path, "rb") as f:
        times = [m.log_time for _, _, m in make_reader(f).iter_messages(log_time_order=True)]
    assert times == sorted(times) and len(times) == len(envs)


def test_a_log_without_bulk_channels_is_chunked_by_size(tmp_path: Path) -> None:
    from mcap.reader import make_reader

    path = tmp_path / "small.mcap"
    with McapLogWriter(path, chunk_size=256 << 10) as w:
        for env in _envelopes(3000):
            if env.topic != "/blob":
                w.write(env)
    with open(path, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    chunks = summary.chunk_indexes
    assert len(chunks) == 3  # about 650 kB of messages in 256 kB chunks, not one chunk per second of log
    assert all(ci.uncompressed_size > 256 << 10 for ci in chunks[:-1])
    assert all(ci.message_end_time - ci.message_start_time > 4_000_000_000 for ci in chunks[:-1])


def _chunks(path: Path) -> list:
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader

    with open(path, "rb") as f:
        return [r for r in StreamReader(f, emit_chunks=True).records if isinstance(r, Chunk)]


@pytest.mark.parametrize("background", [False, True])
def test_chunks_are_zstd_level_2_and_read_back_through_both_readers(tmp_path: Path, background: bool) -> None:
    import zstandard
    from mcap.reader import make_reader
    from mcap.writer import CompressionType, Writer

    envs = _envelopes(3000)
    path = tmp_path / "run.mcap"
    _write(path, envs, background=background)
    chunks = _chunks(path)
    assert len(chunks) >= 3 and all(c.compression == "zstd" for c in chunks)
    for c in chunks:
        raw = zstandard.decompress(c.data)
        assert len(raw) == c.uncompressed_size
        assert c.data == zstandard.compress(raw, 2) != zstandard.compress(raw, 3)
    # a plain mcap Writer in the same process keeps mcap's own level 3
    plain = tmp_path / "plain.mcap"
    with open(plain, "wb") as f:
        w = Writer(f, compression=CompressionType.ZSTD, chunk_size=1 << 18)
        w.start(profile="ros2", library="test")
        cid = w.register_channel("/x", "cdr", w.register_schema("X", "ros2msg", b""))
        for i in range(3000):
            w.add_message(cid, log_time=i, publish_time=i, data=bytes(range(i % 200)) * 20)
        w.finish()
    assert all(c.data == zstandard.compress(zstandard.decompress(c.data), 3) for c in _chunks(plain))
    # every message back, in time order, the same bytes, through navlog's reader and mcap's
    expected = [
        (e.topic, e.time_ns, e.msg if isinstance(e.msg, bytes) else messages.serialize(e.msg, e.typename)) for e in envs
    ]
    with open_log(path) as reader:
        assert [(e.topic, e.time_ns, bytes(e.msg)) for e in reader.messages(decode=False)] == expected
    with open(path, "rb") as f:
        got = [(ch.topic, m.log_time, m.data) for _, ch, m in make_reader(f).iter_messages(log_time_order=True)]
    assert got == expected
