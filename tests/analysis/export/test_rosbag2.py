"""navlog export --to rosbag2: bags round-trip byte for byte (rosbags and independent readers)."""

from __future__ import annotations

import sqlite3

import numpy as np
import pytest
import yaml

from navlog.analysis.export import BagOptions, export_rosbag2
from navlog.cli import main
from navlog.replay import messages as m
from navlog.replay.io import open_log
from tests.analysis import sample_nav_log as sample
from tests.analysis.export.bags import by_topic, export_bag, rosbags_messages, source_messages

NS = 1_000_000_000
COMBOS = [("sqlite3", "humble"), ("sqlite3", "jazzy"), ("mcap", "humble"), ("mcap", "jazzy")]


@pytest.mark.parametrize("storage, distro", COMBOS)
def test_rosbag2_round_trips_with_rosbags(storage, distro, sample_log, tmp_path):
    out = tmp_path / "bag"
    assert export_bag(sample_log, out, "--storage", storage, "--distro", distro) == 0
    src = by_topic(source_messages(sample_log))
    got_list, qos = rosbags_messages(out)
    got = by_topic(got_list)
    assert sorted(got) == sorted(src)
    for topic in src:  # same types, counts, timestamps and message bytes, in order
        assert got[topic] == src[topic], topic
    # metadata version and distro
    info = yaml.safe_load((out / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    assert info["version"] == {"humble": 8, "jazzy": 9}[distro]
    assert info["ros_distro"] == distro
    assert info["storage_identifier"] == storage
    assert info["message_count"] == sum(len(v) for v in src.values())
    assert info["starting_time"]["nanoseconds_since_epoch"] == 0
    assert info["duration"]["nanoseconds"] == 2 * NS
    files = sorted(p.name for p in out.iterdir())
    assert files == sorted(["metadata.yaml", f"bag.{'db3' if storage == 'sqlite3' else 'mcap'}"])
    # QoS: latched topics transient-local, reliable, depth 1; others volatile
    from rosbags.interfaces import QosDurability, QosReliability

    for topic in ("/tf_static", "/map"):
        (q,) = qos[topic]
        assert (q.durability, q.reliability, q.depth) == (QosDurability.TRANSIENT_LOCAL, QosReliability.RELIABLE, 1)
    assert qos["/scan"][0].durability == QosDurability.VOLATILE
    # the QoS text in metadata.yaml has the distro's format: a YAML string (8) or a list (9)
    tf_static = next(t for t in info["topics_with_message_count"] if t["topic_metadata"]["name"] == "/tf_static")
    profiles = tf_static["topic_metadata"]["offered_qos_profiles"]
    if distro == "humble":
        assert isinstance(profiles, str) and "durability: 1" in profiles
    else:
        assert isinstance(profiles, list) and profiles[0]["durability"] == "transient_local"


def test_mcap_export_reads_back_with_the_mcap_ros2_decoder(sample_log, tmp_path):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    out = tmp_path / "bag"
    assert export_bag(sample_log, out, "--storage", "mcap", "--distro", "jazzy") == 0
    src = by_topic(source_messages(sample_log))
    got: dict[str, list] = {}
    scans = []
    with open(out / "bag.mcap", "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        for schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=True):
            got.setdefault(channel.topic, []).append((schema.name, message.log_time, bytes(message.data)))
            if channel.topic == "/scan":
                scans.append((message.log_time, decoded))
    assert got == src
    # decoded independently: the first scan sees the wall 2.85 m straight ahead of the laser
    t0, scan = scans[0]
    assert t0 == NS // 10
    ranges = np.asarray(scan.ranges)
    ahead = int(round((0.0 - scan.angle_min) / scan.angle_increment))
    assert ranges[ahead] == pytest.approx(sample.WALL_X - sample.robot_x_map(0.1, 0.5) - sample.LASER_X, abs=1e-6)
    assert np.isinf(ranges[0])  # straight behind: nothing


def test_sqlite3_export_reads_back_with_plain_sqlite(sample_log, tmp_path):
    out = tmp_path / "bag"
    assert main(["-q", "export", str(sample_log), "--to", "rosbag2", "--storage", "sqlite3", "-o", str(out)]) == 0
    src = by_topic(source_messages(sample_log))
    con = sqlite3.connect(out / "bag.db3")
    rows = con.execute(
        "SELECT topics.name, topics.type, messages.timestamp, messages.data FROM messages "
        "JOIN topics ON messages.topic_id = topics.id ORDER BY messages.id"
    ).fetchall()
    defs = dict(con.execute("SELECT topic_type, encoded_message_definition FROM message_definitions").fetchall())
    con.close()
    got = by_topic([(a, b, c, bytes(d)) for a, b, c, d in rows])
    assert got == src
    assert "string kind" in defs[m.EVENT_TYPE]  # navlog's own type travels with its definition


def test_unknown_types_are_skipped_with_one_warning(bags_dir, tmp_path, caplog):
    out = tmp_path / "neato"
    with open_log(bags_dir / "neato_drive_square") as r:
        summary = export_rosbag2(r, out, BagOptions(storage="mcap", distro="humble"))
        known = {t.name: t.count for t in r.topics.values() if t.known}
    warned = [rec.getMessage() for rec in caplog.records if "unknown types" in rec.getMessage()]
    assert len(warned) == 1 and "/accel (neato2_interfaces/msg/Accel)" in warned[0]
    assert summary.skipped == {
        "unknown type neato2_interfaces/msg/Accel on /accel": 194,
        "unknown type neato2_interfaces/msg/Bump on /bump": 194,
    }
    got = by_topic(rosbags_messages(out)[0])
    assert {t: len(v) for t, v in got.items()} == known


@pytest.mark.parametrize(
    "bag", ["neato_drive_square", "tb3_gazebo_walker", "rosbag2_talker_mcap", "rosbag2_wbag_split_mcap"]
)
@pytest.mark.parametrize("storage", ["sqlite3", "mcap"])
def test_every_external_bag_exports_unchanged(bag, storage, bags_dir, tmp_path):
    out = tmp_path / "out"
    assert main(["-q", "export", str(bags_dir / bag), "--to", "rosbag2", "--storage", storage, "-o", str(out)]) == 0
    with open_log(bags_dir / bag) as r:
        known = [t.name for t in r.topics.values() if t.known]
    src = by_topic(source_messages(bags_dir / bag, known))
    got = by_topic(rosbags_messages(out)[0])
    assert got == src


def test_existing_output_needs_force_and_is_replaced_whole(sample_log, tmp_path, capsys):
    out = tmp_path / "bag"
    out.mkdir()
    (out / "old.txt").write_text("old")
    assert main(["export", str(sample_log), "--to", "rosbag2", "-o", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == ["old.txt"]
    assert (
        main(["-q", "export", str(sample_log), "--to", "rosbag2", "--storage", "mcap", "-o", str(out), "--force"]) == 0
    )
    assert sorted(p.name for p in out.iterdir()) == ["bag.mcap", "metadata.yaml"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bag"]


def test_truncated_log_is_refused_and_leaves_nothing(tmp_path_factory, tmp_path, capsys):
    whole = sample.write_sample_log(tmp_path_factory.mktemp("chunks") / "whole.mcap", chunk_size=16 << 10)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    assert main(["export", str(cut), "--to", "rosbag2", "-o", str(tmp_path / "bag")]) == 2
    assert "truncated" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cut.mcap"]
    # --recover exports the complete chunks, each message unchanged
    assert main(["-q", "export", str(cut), "--recover", "--to", "rosbag2", "-o", str(tmp_path / "bag")]) == 0
    got = rosbags_messages(tmp_path / "bag")[0]
    src = {(t, ts, d) for t, _, ts, d in source_messages(whole)}
    assert got and all((t, ts, d) in src for t, _, ts, d in got)


def test_export_is_deterministic(sample_log, tmp_path):
    for storage, ext in (("mcap", "mcap"), ("sqlite3", "db3")):
        outs = []
        for run in ("1", "2"):
            (tmp_path / storage / run).mkdir(parents=True)
            out = tmp_path / storage / run / "bag"
            assert main(["-q", "export", str(sample_log), "--to", "rosbag2", "--storage", storage, "-o", str(out)]) == 0
            outs.append(out)
        assert (outs[0] / "metadata.yaml").read_bytes() == (outs[1] / "metadata.yaml").read_bytes()
        assert (outs[0] / f"bag.{ext}").read_bytes() == (outs[1] / f"bag.{ext}").read_bytes()
