"""navlog export: topics by name or pattern and a time window choose what is written; bad choices are clear errors."""

from __future__ import annotations

import pytest

from tests.analysis.export.bags import by_topic, export_bag, rosbags_messages

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
