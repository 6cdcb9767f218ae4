"""The replay summary: the same numbers as the manifest, as tables."""

from __future__ import annotations

from pathlib import Path

from navlog.replay.session import ReplayResult, format_summary


def test_summary_shows_speed_info_outputs_and_skips_from_the_manifest():
    manifest = {
        "pipeline": "mapping",
        "log": {"start_ns": 0, "end_ns": 138_000_000_000, "messages_read": 15184, "truncated": True},
        "pipeline_info": {"pose_source": "ground_truth"},
        "outputs": {"map_yaml": {"file": "map.yaml", "sha256": "227fca363681d5c0" + "0" * 48}},
        "skipped": {"log: unknown type foo_msgs/msg/Bar on /bar": 12},
    }
    text = format_summary("run.mcap", ReplayResult(Path("out"), manifest, 6.9))
    lines = text.splitlines()
    assert lines[0] == "replayed run.mcap through 'mapping' into out/"
    assert lines[1] == (
        "log 138.00 s in 6.90 s wall (20.0x real time), 15184 messages read (truncated log: readable part only)"
    )
    rows = [line.split() for line in lines]
    assert ["pose_source", "ground_truth"] in rows
    assert ["map.yaml", "227fca363681d5c0"] in rows
    assert "skipped inputs" in lines
    assert ["12", "log:", "unknown", "type", "foo_msgs/msg/Bar", "on", "/bar"] in rows
    assert "\x1b[" not in text
