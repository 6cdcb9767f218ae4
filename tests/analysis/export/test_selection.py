"""navlog export: topics by name or pattern and a time window choose what is written; bad choices are clear errors."""

from __future__ import annotations

import pytest

from tests.analysis.export.bags import by_topic, export_bag, rosbags_messages, source_messages

NS = 1_000_000_000


def test_topic_and_time_filters(sample_log, tmp_path):
    out = tmp_path / "bag"
    assert export_bag(sample_log, out, "--topics", "/cmd_vel*", "/odom", "--start", "0.5", "--end", "1.0") == 0
    got = by_topic(rosbags_messages(out)[0])
    assert sorted(got) == ["/cmd_vel", "/cmd_vel_nav", "/cmd_vel_smoothed", "/odom"]
    assert [t for _, t, _ in got["/odom"]] == [
        NS // 2 + k * 20_000_000 for k in range(26)
    ]  # 50 Hz, 0.5 .. 1.0 s inclusive
    assert len(got["/cmd_vel"]) == 11  # 20 Hz


@pytest.mark.parametrize(
    "args, message",
    [
        (["--to", "rosbag2", "--topics", "/scna"], "--topics /scna: matches no topic"),
        (["--to", "rosbag2", "--topics", "/nothing*"], "matches no topic"),
        (["--to", "rosbag2", "--start", "5"], "lasts only 2.000 s"),
        (["--to", "rosbag2", "--start", "1", "--end", "0.5"], "is before --start"),
    ],
)
def test_bad_topics_and_windows_are_clear_errors_and_write_nothing(args, message, refused):
    refused(args, message)


def test_a_window_keeps_the_latched_topics_published_before_it(sample_log, tmp_path):
    # /tf_static and /map are published once, at 0 s: a bag trimmed to 0.5 .. 1.0 s still has them
    out = tmp_path / "bag"
    assert export_bag(sample_log, out, "--topics", "/tf_static", "/map", "/odom", "--start", "0.5", "--end", "1.0") == 0
    got = by_topic(rosbags_messages(out)[0])
    assert [t for _, t, _ in got["/tf_static"]] == [NS // 2] and [t for _, t, _ in got["/map"]] == [NS // 2]
    src = by_topic(source_messages(sample_log, ["/tf_static", "/map"]))
    assert got["/tf_static"][0][2] == src["/tf_static"][0][2] and got["/map"][0][2] == src["/map"][0][2]
    # a volatile topic is not carried over
    assert len(got["/odom"]) == 26  # 50 Hz, 0.5 .. 1.0 s inclusive: nothing from before


def test_tf_static_keeps_the_latest_transform_of_every_child_frame(tmp_path):
    from navlog.replay import messages as m
    from navlog.replay.io.logwriter import McapLogWriter

    log = tmp_path / "statics.mcap"

    def statics(t, *children):
        tfs = [m.transform_stamped(t, "base_link", c, (t / NS, 0, 0), (0, 0, 0, 1)) for c in children]
        return m.serialize(m.tf_message(tfs), m.TF_MESSAGE)

    with McapLogWriter(log) as w:
        w.write_raw("/tf_static", m.TF_MESSAGE, 0, statics(0, "laser", "imu"))
        w.write_raw("/tf_static", m.TF_MESSAGE, 1 * NS, statics(1 * NS, "camera"))
        w.write_raw("/tf_static", m.TF_MESSAGE, 2 * NS, statics(2 * NS, "laser", "imu"))  # replaces the first
        w.write_raw("/tf_static", m.TF_MESSAGE, 5 * NS, statics(5 * NS, "gps"))  # inside the window
        for k in range(7):
            w.write_raw(
                "/chatter",
                "std_msgs/msg/String",
                k * NS,
                m.serialize(m.msg_class("std_msgs/msg/String")("x"), "std_msgs/msg/String"),
            )
    out = tmp_path / "bag"
    assert export_bag(log, out, "--start", "3", "--end", "6") == 0
    got = by_topic(rosbags_messages(out)[0])["/tf_static"]
    frames = [[tf.child_frame_id for tf in m.deserialize(data, m.TF_MESSAGE).transforms] for _, _, data in got]
    assert frames == [["camera"], ["laser", "imu"], ["gps"]]
    assert [t for _, t, _ in got] == [3 * NS, 3 * NS, 5 * NS]


def test_the_recorded_qos_is_kept(bags_dir, tmp_path):
    from rosbags.interfaces import QosDurability, QosReliability

    # the TurtleBot3 bag records /clock best-effort and /tf_static transient-local
    out = tmp_path / "bag"
    bag = bags_dir / "tb3_gazebo_walker"
    assert export_bag(bag, out, "--topics", "/clock", "/tf_static", "/tf", "/scan", "--start", "5", "--end", "10") == 0
    msgs, qos = rosbags_messages(out)
    assert qos["/clock"][0].reliability == QosReliability.BEST_EFFORT
    assert qos["/tf_static"][0].durability == QosDurability.TRANSIENT_LOCAL
    assert len(by_topic(msgs)["/tf_static"]) == 1  # published at the start, before the window
