"""The replay summary: the same numbers as the manifest, as tables."""

from __future__ import annotations

from pathlib import Path

import pytest

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


# ---------------------------------------------------------------- bad input is named before anything runs


def replay_2d(log, out, **kw):
    from navlog.replay.session import run_replay

    return run_replay(
        log, "mapping", out, overrides=["lidar_mapper=off", *kw.pop("overrides", [])], progress=False, **kw
    )


def test_a_remap_onto_a_topic_of_another_type_is_refused_naming_both_types(teleop_log, tmp_path):
    import pytest

    from navlog.errors import ConfigError

    with pytest.raises(ConfigError) as err:
        replay_2d(teleop_log, tmp_path / "out", remap={"/scan": "/odom"})
    msg = str(err.value)
    assert msg.startswith("--remap /scan=/odom: /odom carries nav_msgs/msg/Odometry")
    assert "reads /scan as sensor_msgs/msg/LaserScan" in msg and "topics of that type in the log: /scan" in msg
    assert not (tmp_path / "out").exists() and not list(tmp_path.glob(".out*"))


def test_a_remap_of_a_topic_the_pipeline_does_not_read_or_the_log_lacks_is_refused(teleop_log, tmp_path):
    import pytest

    from navlog.errors import ConfigError

    with pytest.raises(
        ConfigError, match=r"--remap /scann=/scan: pipeline 'mapping' reads no topic /scann \(did you mean '/scan'\?\)"
    ):
        replay_2d(teleop_log, tmp_path / "a", remap={"/scann": "/scan"})
    with pytest.raises(ConfigError, match=r"--remap /tf=/tf_missing: .* has no topic /tf_missing"):
        replay_2d(teleop_log, tmp_path / "b", remap={"/tf": "/tf_missing"})


def test_a_replay_that_produces_no_map_fails_and_says_why(teleop_log, tmp_path):
    """A trimmed log without /tf_static: no scan can be placed in the TF tree, so there is no map."""
    import pytest

    from navlog.analysis.export import BagOptions, export_rosbag2
    from navlog.errors import NavlogError
    from navlog.replay.io import open_log

    with open_log(teleop_log) as reader:
        export_rosbag2(reader, tmp_path / "trim", BagOptions(topics=("/scan", "/tf")).validate())
    with pytest.raises(NavlogError) as err:
        replay_2d(tmp_path / "trim", tmp_path / "out", overrides=["pose_source=tf"])
    msg = str(err.value)
    assert "pipeline 'mapping' produced nothing: no map: no scan on /scan could be placed (pose source tf)" in msg
    assert "/scan: no pose or transform at the scan's stamp x171" in msg and "/tf_static" in msg
    assert not (tmp_path / "out").exists()


def test_a_map_that_cannot_be_written_is_named_in_the_output_folder_asked_for(teleop_log, tmp_path, monkeypatch):
    import errno

    import navlog.replay.io.map_server as map_server
    from navlog.errors import NavlogError

    def full(path, data):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(map_server, "write_file", full)
    out = tmp_path / "out"
    with pytest.raises(NavlogError) as info:
        replay_2d(teleop_log, out)
    assert str(info.value) == f"{out / 'map.yaml'}: cannot write map: No space left on device"
    assert not out.exists() and list(tmp_path.iterdir()) == []  # no partial folder left beside it
