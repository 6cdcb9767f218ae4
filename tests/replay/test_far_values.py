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


FAR_TF = "not finite, farther than 1e+08 m or with a zero rotation (ignored)"


def test_slam_skips_scans_whose_odometry_is_far_away(teleop_log, tmp_path):
    # the scan matcher sized its window from the odometry: np.bincount raised OverflowError at 1e39 m. Transforms
    # that far are left out of the TF tree (a scan between two of them has no odometry); 1e7 m is in the tree, and
    # the SLAM skips the scans it would place there
    with open_log(teleop_log) as r:
        scans = r.topics["/scan"].count
    overrides = ["pose_source=slam", "lidar_mapper=off"]
    for x, reason in ((1e7, "/scan: odometry farther than 1e+06 m at the scan's stamp"), (1e39, None)):
        path = tmp_path / f"far{x:g}.mcap"
        _far_tf(teleop_log, path, 100, 400, x)
        res = run_replay(path, "mapping", tmp_path / f"out{x:g}", overrides=overrides, progress=False)
        skipped = res.manifest["skipped"]
        if reason is None:
            assert skipped[f"/tf: transform odom -> base_footprint {FAR_TF}"] == 301
            reason = "/scan: no odometry (odom -> base) or laser transform at the scan's stamp"
        assert 0 < skipped[reason] < scans and (res.out_dir / "map.pgm").exists()


def test_the_planner_skips_transforms_beyond_any_frame(teleop_log, tmp_path):
    # the footprint's Point32 coordinates could not be packed at 1e39 m: OverflowError from the CDR writer. Such
    # transforms are left out of the TF tree, counted; the costmap updates on the others
    from navlog.recorder.world import write_world_map

    write_world_map("indoor_room", tmp_path / "map.yaml", margin=0.0)
    path = tmp_path / "far.mcap"
    _far_tf(teleop_log, path, 100, 400, 1e39)
    overrides = [f"map={tmp_path / 'map.yaml'}", "goals=indoor_room_waypoints"]
    res = run_replay(path, "planner", tmp_path / "out", overrides=overrides, progress=False)
    assert res.manifest["skipped"][f"/tf: transform odom -> base_footprint {FAR_TF}"] == 301
    with open_log(res.out_dir / "replay.mcap") as out:  # the footprints of the other updates are written
        assert out.topics["/global_costmap/published_footprint"].count > 0
