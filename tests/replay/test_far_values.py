"""Finite values far beyond any room in a log's /tf (1e39 m, beyond float32) are counted skips, never an
OverflowError."""

from __future__ import annotations

from pathlib import Path

from navlog.replay import messages as m
from navlog.replay.io.formats import open_log
from navlog.replay.io.logwriter import McapLogWriter
from navlog.replay.runtime.executor import Envelope
from navlog.replay.session import run_replay


def _far_tf(src: Path, dst: Path, first: int, last: int, x: float) -> None:
    """``src`` with /tf messages ``first``..``last`` (1-based) moved to translation.x = ``x``."""
    i = 0
    with McapLogWriter(dst) as w, open_log(src) as r:
        for env in r.messages():
            if env.topic == "/tf" and first <= (i := i + 1) <= last:
                msg = (
                    m.deserialize(bytes(env.msg), env.typename) if isinstance(env.msg, bytes | memoryview) else env.msg
                )
                for ts in msg.transforms:
                    ts.transform.translation.x = x
                env = Envelope(env.topic, env.typename, env.time_ns, msg)
            w.write(env)


def test_slam_skips_scans_whose_odometry_is_1e39_m_away(teleop_log, tmp_path):
    # the scan matcher sized its window from the odometry: np.bincount raised OverflowError
    path = tmp_path / "far.mcap"
    _far_tf(teleop_log, path, 100, 400, 1e39)
    overrides = ["pose_source=slam", "lidar_mapper=off"]
    res = run_replay(path, "mapping", tmp_path / "out", overrides=overrides, progress=False)
    far = res.manifest["skipped"]["/scan: odometry farther than 1e+06 m at the scan's stamp"]
    with open_log(teleop_log) as r:
        scans = r.topics["/scan"].count
    assert 0 < far < scans and (res.out_dir / "map.pgm").exists()


def test_the_planner_skips_costmap_updates_whose_robot_pose_is_beyond_float32(teleop_log, tmp_path):
    # the footprint's Point32 coordinates could not be packed: OverflowError from the CDR writer
    from navlog.recorder.world import write_world_map

    write_world_map("indoor_room", tmp_path / "map.yaml", margin=0.0)
    path = tmp_path / "far.mcap"
    _far_tf(teleop_log, path, 100, 400, 1e39)
    overrides = [f"map={tmp_path / 'map.yaml'}", "goals=indoor_room_waypoints"]
    res = run_replay(path, "planner", tmp_path / "out", overrides=overrides, progress=False)
    far = res.manifest["skipped"]["costmap update: robot pose beyond float32's range (+-3.4e38 m) in the TF tree"]
    assert far > 0
    with open_log(res.out_dir / "replay.mcap") as out:  # the footprints of the other updates are written
        assert out.topics["/global_costmap/published_footprint"].count > 0
