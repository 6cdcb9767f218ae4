"""Replaying logs through the mapping pipeline: known cells, byte-identical replays, live = replay, bad input."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from navlog.errors import NavlogError, TruncatedLogError
from navlog.replay import messages
from navlog.replay.io import open_log
from navlog.replay.io.logwriter import McapLogWriter
from navlog.replay.io.map_server import load_map
from navlog.replay.runtime.executor import Envelope
from navlog.replay.session import pipeline_params, run_replay

pytestmark = pytest.mark.slow

REPO = Path(__file__).resolve().parents[3]
NAVLOG = [sys.executable, "-m", "navlog"]
MOUNT = (0.2, 0.0, 0.1)


def scan_msg(ns: int, ranges, frame="laser", rmin=0.1, rmax=4.0):
    n = len(ranges)
    inc = 2 * math.pi / n
    return messages.msg_class(messages.LASER_SCAN)(
        header=messages.header(ns, frame),
        angle_min=-math.pi,
        angle_max=-math.pi + inc * (n - 1),
        angle_increment=inc,
        time_increment=0.0,
        scan_time=0.1,
        range_min=rmin,
        range_max=rmax,
        ranges=np.asarray(ranges, dtype=np.float32),
        intensities=np.zeros(0, dtype=np.float32),
    )


def write_log(path: Path, envelopes: list[Envelope]) -> Path:
    with McapLogWriter(path) as w:
        for env in envelopes:
            w.write(env)
    return path


def wall_log(path: Path, *, tf_from_ns: int = 0, scans=None, stamps_backwards=False) -> Path:
    """A robot standing at (1.0, 0.5), yaw 0, laser 0.2 m ahead: a wall 2.0 m ahead of the laser.

    720 beams: straight ahead (index 360) sees the wall at 2.0 m; the beam straight back has no return
    (inf); one beam is NaN; all others have no return either.
    """
    envs = [
        Envelope(
            "/tf_static",
            messages.TF_MESSAGE,
            0,
            messages.tf_message([messages.transform_stamped(0, "base_link", "laser", MOUNT, (0, 0, 0, 1))]),
        )
    ]
    ranges = np.full(720, np.inf)
    ranges[355:366] = 2.0 / np.cos((np.arange(355, 366) - 360) * 2 * math.pi / 720)  # a wall across x = 3.2
    ranges[100] = np.nan
    for k in range(10):
        t = k * 100_000_000
        stamp = t if not (stamps_backwards and k == 5) else t - 250_000_000
        if t >= tf_from_ns:
            envs.append(
                Envelope(
                    "/odom/ground_truth",
                    messages.ODOMETRY,
                    t,
                    messages.odometry(t, "world", "base_link", (1.0, 0.5, 0.0), (0, 0, 0, 1), (0, 0, 0), (0, 0, 0)),
                )
            )
        envs.append(Envelope("/scan", messages.LASER_SCAN, t, scan_msg(stamp, ranges if scans is None else scans[k])))
    return write_log(path, envs)


def cell(m, x, y) -> int:
    mx, my = m.world_to_cell(x, y)
    return int(m.data[my, mx])


def test_known_geometry_gives_the_expected_cells(tmp_path):
    log = wall_log(tmp_path / "wall.mcap")
    # no-return beams clear up to range_max here (an explicit option; by default they clear nothing)
    overrides = ["occupancy.minimum_travel_distance=0", "occupancy.grid.no_return_ray_length=4.0"]
    params = pipeline_params("mapping", overrides=overrides)
    res = run_replay(log, "mapping", tmp_path / "out", params=params, progress=False)
    m = load_map(tmp_path / "out" / "map.yaml")
    assert m.resolution == 0.05
    # the wall: the laser at x = 1.2 sees it at x = 3.2 (cells right at the hit point)
    for y in (0.45, 0.5, 0.55):
        assert cell(m, 3.2 + 0.01, y) == 100
    # free along the beam, up to the cell before the wall
    for x in np.arange(1.25, 3.15, 0.05):
        assert cell(m, x, 0.5) == 0, x
    # beyond the wall: never seen
    assert cell(m, 3.4, 0.5) == -1
    # no return straight back: cleared to range_max (4 m) without marking an obstacle
    assert cell(m, 1.2 - 3.9, 0.5) == 0
    assert cell(m, 1.2 - 4.1, 0.5) == -1
    assert (m.data == 100).sum() <= 12
    man = res.manifest
    assert man["skipped"]["/scan: NaN ranges (skipped)"] == 10
    assert man["pipeline_info"]["pose_source"] == "ground_truth"
    assert man["published"]["/map"] >= 1
    assert {o["file"] for o in man["outputs"].values()} == {"replay.mcap", "map.yaml", "map.pgm", "trajectory.tum"}
    tum = (tmp_path / "out" / "trajectory.tum").read_text().splitlines()
    assert tum[1].split()[:4] == ["0.000000000", "1.000000000", "0.500000000", "0.000000000"]


def test_missing_tf_skips_and_counts_and_backwards_stamps_are_counted(tmp_path):
    log = wall_log(tmp_path / "late.mcap", tf_from_ns=300_000_000, stamps_backwards=True)
    params = pipeline_params("mapping", overrides=["occupancy.minimum_travel_distance=0"])
    res = run_replay(log, "mapping", tmp_path / "out", params=params, progress=False)
    skipped = res.manifest["skipped"]
    assert skipped["/scan: no pose or transform at the scan's stamp"] == 4  # 0.0-0.2 s, and the one stamped 0.25 s
    assert skipped["log: /scan header stamps going backwards (replayed in log order)"] == 1


def test_missing_topic_error_lists_needs_and_remap(tmp_path):
    log = write_log(
        tmp_path / "nolaser.mcap",
        [
            Envelope(
                "/odom",
                messages.ODOMETRY,
                0,
                messages.odometry(0, "odom", "base_link", (0, 0, 0), (0, 0, 0, 1), (0, 0, 0), (0, 0, 0)),
            )
        ],
    )
    with pytest.raises(NavlogError) as exc:
        run_replay(log, "mapping", tmp_path / "out", progress=False)
    text = str(exc.value)
    assert (
        "needs /scan" in text
        and "missing /scan" in text
        and "/odom (nav_msgs/msg/Odometry)" in text
        and "--remap" in text
    )
    assert not (tmp_path / "out").exists() and not list(tmp_path.glob(".out*"))
    # a remap to a topic the log lacks names that topic, not the pipeline's
    with pytest.raises(NavlogError) as exc:
        run_replay(log, "mapping", tmp_path / "out", remap={"/scan": "/nonexistent"}, progress=False)
    text = str(exc.value)
    assert "the remapped topic /nonexistent (read as /scan, --remap /scan=/nonexistent) is not in the log" in text
    assert "The log has: /odom (nav_msgs/msg/Odometry)" in text and "missing /scan" not in text
    assert not (tmp_path / "out").exists()


def test_remap_reads_another_topic(tmp_path):
    src = wall_log(tmp_path / "wall.mcap")
    renamed = tmp_path / "renamed.mcap"
    with open_log(src) as r, McapLogWriter(renamed) as w:
        for env in r.messages(decode=False):
            w.write_raw("/stable_scan" if env.topic == "/scan" else env.topic, env.typename, env.time_ns, env.msg)
    params = pipeline_params("mapping", overrides=["occupancy.minimum_travel_distance=0"])
    a = run_replay(src, "mapping", tmp_path / "a", params=params, progress=False)
    b = run_replay(renamed, "mapping", tmp_path / "b", params=params, remap={"/scan": "/stable_scan"}, progress=False)
    assert a.manifest["outputs"]["map_pgm"] == b.manifest["outputs"]["map_pgm"]


def test_truncated_log_needs_recover(teleop_log, tmp_path):
    cut = tmp_path / "cut.mcap"
    data = teleop_log.read_bytes()
    cut.write_bytes(data[: len(data) // 2])
    with pytest.raises(TruncatedLogError):
        run_replay(cut, "mapping", tmp_path / "out", overrides=["lidar_mapper=off"], progress=False)
    assert not (tmp_path / "out").exists()
    res = run_replay(cut, "mapping", tmp_path / "out", overrides=["lidar_mapper=off"], recover=True, progress=False)
    assert res.manifest["log"]["truncated"] is True
    assert 3.0 < res.log_s < 17.0


def test_existing_output_folder_needs_force(tmp_path):
    log = wall_log(tmp_path / "wall.mcap")
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "keep.txt").write_text("x")
    with pytest.raises(NavlogError, match="not empty.*--force"):
        run_replay(log, "mapping", tmp_path / "out", progress=False)
    assert (tmp_path / "out" / "keep.txt").exists()


def test_double_replay_in_fresh_processes_is_byte_identical(teleop_log, tmp_path):
    outs = []
    for name in ("a", "b"):
        proc = subprocess.run(
            NAVLOG + ["-q", "replay", str(teleop_log), "--pipeline", "mapping", "-o", str(tmp_path / name)],
            cwd=REPO,
            capture_output=True,
            text=True,
            timeout=600,
        )
        assert proc.returncode == 0, proc.stderr
        outs.append(json.loads((tmp_path / name / "manifest.json").read_text()))
    assert outs[0] == outs[1]
    assert set(outs[0]["outputs"]) >= {"replay_mcap", "map_yaml", "map_pgm", "map_pcd", "trajectory_tum"}
    for f in ("replay.mcap", "map.pgm", "map.pcd", "trajectory.tum", "manifest.json"):
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes(), f


def test_live_mapping_during_record_equals_replay(tmp_path):
    from navlog.recorder.record import prepare, record
    from navlog.replay.pipelines import pipeline_spec

    setup = prepare("indoor_room", "go2", "teleop", seed=5)
    params = pipeline_params("mapping")
    assert setup.topics() == {
        "/scan",
        "/livox/lidar",
        "/imu/data",
        "/odom",
        "/odom/ground_truth",
        "/tf",
        "/tf_static",
        "/clock",
        "/cmd_vel",
    }
    pipe = pipeline_spec("mapping").build(params, setup.topics())
    log = tmp_path / "live.mcap"
    record(setup, log, progress=False, live_nodes=pipe.nodes)
    res = run_replay(log, "mapping", tmp_path / "out", params=params, progress=False)

    def raw(path: Path, topic: str) -> list[tuple[int, bytes]]:
        with open_log(path) as r:
            return [(e.time_ns, e.msg) for e in r.messages([topic], decode=False)]

    for topic in ("/map", "/Odometry"):
        live, replayed = raw(log, topic), raw(res.out_dir / "replay.mcap", topic)
        assert len(live) > 5
        assert live == replayed, topic


def test_real_robot_bags_replay(bags_dir, tmp_path):
    tf = ["pose_source=tf"]  # the TF mapper on real bags (auto picks SLAM on a log without ground truth)
    neato = run_replay(bags_dir / "neato_drive_square", "mapping", tmp_path / "neato", overrides=tf, progress=False)
    info = neato.manifest
    assert info["pipeline_info"]["pose_source"] == "tf" and info["pipeline_info"]["lidar_mapper"] == "off"
    assert info["log"]["unknown_types"] == {
        "/accel": "neato2_interfaces/msg/Accel",
        "/bump": "neato2_interfaces/msg/Bump",
    }
    m = load_map(tmp_path / "neato" / "map.yaml")
    assert (m.data == 100).sum() > 50 and (m.data == 0).sum() > 5000
    # the robot drove a ~1 m square: its path stays within a 2 m box
    tum = np.loadtxt(tmp_path / "neato" / "trajectory.tum")
    assert len(tum) > 20 and np.ptp(tum[:, 1]) < 2.0 and np.ptp(tum[:, 2]) < 2.0
    tb3 = run_replay(bags_dir / "tb3_gazebo_walker", "mapping", tmp_path / "tb3", overrides=tf, progress=False)
    m3 = load_map(tmp_path / "tb3" / "map.yaml")
    assert (m3.data == 100).sum() > 20
    # header stamps are sim time (~1396 s) while receive times are wall clock: the trajectory uses stamps
    t3 = np.atleast_2d(np.loadtxt(tmp_path / "tb3" / "trajectory.tum"))
    assert 1300 < t3[0, 0] < 1500  # the robot never moves: one scan inserted, the rest within minimum travel
    assert tb3.manifest["skipped"]["scans within minimum travel (not inserted)"] >= 90
    assert tb3.manifest["log"]["unknown_types"] == {"/performance_metrics": "gazebo_msgs/msg/PerformanceMetrics"}
