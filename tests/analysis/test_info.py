"""navlog info as text: the log's figures, its topics in aligned columns, its metadata."""

from __future__ import annotations

from navlog.analysis.info import format_info

INFO = {
    "path": "/logs/run.mcap",
    "format": "mcap",
    "storage": "mcap",
    "compression": "zstd",
    "size_bytes": 3 * 1024 * 1024 + 512 * 1024,
    "start_ns": 0,
    "end_ns": 138_000_000_000,
    "duration_s": 138.0,
    "messages": 9,
    "truncated": True,
    "topics": [
        {"topic": "/accel", "type": "neato2_interfaces/msg/Accel", "count": 194, "rate_hz": 4.674, "known": False},
        {"topic": "/odom/ground_truth", "type": "nav_msgs/msg/Odometry", "count": 6901, "rate_hz": 50.0, "known": True},
    ],
    "unknown_types": {"/accel": "neato2_interfaces/msg/Accel"},
    "metadata": {"navlog": {"robot": "go2", "seed": "7"}},
}


def test_figures_topics_and_metadata():
    text = format_info(INFO)
    lines = text.splitlines()
    assert all(line == line.rstrip() for line in lines)
    assert lines[:9] == [
        "Files:        /logs/run.mcap",
        "Format:       mcap (storage mcap)",
        "Bag size:     3.5 MiB",
        "Compression:  zstd",
        "Duration:     138.000 s",
        "Start:        0.000000000 s",
        "End:          138.000000000 s",
        "Messages:     9",
        "State:        TRUNCATED (read up to the last complete chunk)",
    ]
    assert lines[9] == "Topic information:"
    assert lines[10].split() == ["Topic", "Type", "Count", "Rate", "(Hz)"]
    accel, odom = lines[12], lines[13]
    assert accel.split() == ["/accel", "neato2_interfaces/msg/Accel", "194", "4.67", "[unknown", "type:", "skipped]"]
    assert odom.split() == ["/odom/ground_truth", "nav_msgs/msg/Odometry", "6901", "50.00"]
    # columns line up: types start together, counts and rates end together
    assert accel.index("neato2") == odom.index("nav_msgs")
    assert accel.index("194") + 3 == odom.index("6901") + 4
    assert accel.index("4.67") + 4 == odom.index("50.00") + 5
    assert lines[14:] == ["Metadata navlog:", "  robot:  go2", "  seed:   7"]


def test_a_log_without_topics_or_metadata():
    info = {**INFO, "truncated": False, "topics": [], "metadata": {}, "size_bytes": 100}
    lines = format_info(info).splitlines()
    assert lines[2] == "Bag size:     100 B"
    assert not any(line.startswith("State:") for line in lines)
    assert lines[8:10] == ["Topic information:", "  Topic   Type   Count   Rate (Hz)"]
    assert len(lines) == 11 and set(lines[10].strip()) == {"─"}


def test_start_and_end_are_exact_integer_nanoseconds():
    # 1726965761.464204329 s does not survive a float (it prints ...369 through one)
    info = dict(INFO, start_ns=1_726_965_761_464_204_329, end_ns=1_726_965_802_764_204_330)
    lines = format_info(info).splitlines()
    start = next(line for line in lines if line.startswith("Start:"))
    end = next(line for line in lines if line.startswith("End:"))
    assert start.split()[-2:] == ["1726965761.464204329", "s"]
    assert end.split()[-2:] == ["1726965802.764204330", "s"]
    assert f"{1_726_965_761_464_204_329 / 1e9:.9f}" != "1726965761.464204329"  # what a float would print
