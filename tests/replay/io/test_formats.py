"""Reading every kind of ROS 2 log: navlog MCAP, rosbag2 sqlite3 and MCAP folders, split bags."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from navlog.errors import LogError, TruncatedLogError
from navlog.replay.io import open_log

REPO = Path(__file__).resolve().parents[3]


@pytest.mark.parametrize(
    "name, fmt, storage, messages, unknown",
    [
        (
            "neato_drive_square",
            "rosbag2",
            "db3",
            2091,
            {"/accel": "neato2_interfaces/msg/Accel", "/bump": "neato2_interfaces/msg/Bump"},
        ),
        ("tb3_gazebo_walker", "rosbag2", "db3", 6642, {"/performance_metrics": "gazebo_msgs/msg/PerformanceMetrics"}),
        ("rosbag2_talker_mcap", "rosbag2", "mcap", 20, {}),
        ("rosbag2_talker_mcap/talker.mcap", "mcap", "mcap", 20, {}),
        ("rosbag2_wbag_split_mcap", "rosbag2", "mcap", 6074, {}),
        (
            "neato_drive_square/drive_square_0.db3",
            "rosbag2",
            "db3",
            2091,
            {"/accel": "neato2_interfaces/msg/Accel", "/bump": "neato2_interfaces/msg/Bump"},
        ),
    ],
)
def test_external_bags(bags_dir, name, fmt, storage, messages, unknown):
    with open_log(bags_dir / name) as r:
        assert (r.format, r.storage) == (fmt, storage)
        assert r.message_count == messages
        assert r.unknown_types == unknown
        read = sum(1 for _ in r.messages())
        skipped = sum(r.report.skipped.values())
        assert read + skipped == messages  # nothing silently lost: read or counted as skipped
        times = [e.time_ns for e in r.messages()]
        assert times == sorted(times)


def test_neato_scan_and_odom_content(bags_dir):
    with open_log(bags_dir / "neato_drive_square") as r:
        scans = [e.msg for e in r.messages(["/scan"])]
        assert len(scans) == 185 and len(scans[0].ranges) == 361
        assert scans[0].header.frame_id == "base_laser_link"


@pytest.mark.slow
def test_info_on_every_external_bag(bags_dir):
    for bag in sorted(p for p in bags_dir.iterdir() if p.is_dir()):
        proc = subprocess.run(
            [sys.executable, "-m", "navlog", "info", str(bag)], cwd=REPO, capture_output=True, text=True
        )
        assert proc.returncode == 0, proc.stderr
        assert "Topic information:" in proc.stdout
    proc = subprocess.run(
        [sys.executable, "-m", "navlog", "info", str(bags_dir / "neato_drive_square")],
        cwd=REPO,
        capture_output=True,
        text=True,
    )
    assert "[unknown type: skipped]" in proc.stdout and "neato2_interfaces/msg/Accel" in proc.stdout


def test_bad_inputs(tmp_path):
    with pytest.raises(LogError, match="no such file"):
        open_log(tmp_path / "missing.mcap")
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not an mcap file at all")
    with pytest.raises(LogError, match="not an MCAP file"):
        open_log(junk)
    (tmp_path / "dir").mkdir()
    with pytest.raises(LogError, match="dir: not a log: no metadata.yaml and no .mcap or .db3 file in this folder"):
        open_log(tmp_path / "dir")
    (tmp_path / "dir" / "run.mcap").write_bytes(b"")
    with pytest.raises(LogError, match=r"without metadata.yaml \(not a rosbag2 folder\); pass a log file inside it"):
        open_log(tmp_path / "dir")


def test_truncated_mcap_refused_then_recovered(teleop_log, tmp_path):
    cut = tmp_path / "cut.mcap"
    data = teleop_log.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(TruncatedLogError, match="--recover"):
        open_log(cut)
    with open_log(cut, recover=True) as r:
        assert r.report.truncated
        n = sum(1 for _ in r.messages())
        assert 0 < n < 8338 and n == r.message_count
        assert r.duration_ns > 3e9
