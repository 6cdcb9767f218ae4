"""A replay output folder drawn beside its log: map, PCD, TUM trajectory and replay.mcap."""

from __future__ import annotations

import logging

import numpy as np

from navlog.cli import main
from tests.analysis.view.rrd import column, read_rrd, verify

NS = 1_000_000_000


def test_replay_output_folder_is_drawn(sample_log, tmp_path):
    import open3d as o3d

    from navlog.analysis.metrics.trajectory import Trajectory
    from navlog.replay import messages as m
    from navlog.replay.io.logwriter import McapLogWriter
    from navlog.replay.io.map_server import save_map
    from navlog.replay.io.tum import write_tum
    from navlog.replay.occupancy_map import OccupancyMap

    out = tmp_path / "OUT"
    out.mkdir()
    cells = np.zeros((40, 60), np.int8)
    cells[10, :] = 100
    save_map(OccupancyMap(cells, 0.1, (-2.0, -1.0, 0.0)), out / "map.yaml")
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.5]], float)))
    o3d.io.write_point_cloud(str(out / "map.pcd"), pcd)
    times = np.arange(5, dtype=np.int64) * NS // 2
    traj = Trajectory(times, np.c_[times / NS, np.zeros(5), np.zeros(5)], np.tile([0, 0, 0, 1.0], (5, 1)))
    write_tum(out / "trajectory.tum", traj.times_ns, traj.positions, traj.quaternions)
    with McapLogWriter(out / "replay.mcap") as w:
        for k in range(5):
            t = k * NS // 2
            odo = m.odometry(t, "map", "base_link", (k * 0.1, 0, 0), (0, 0, 0, 1), (0.2, 0, 0), (0, 0, 0))
            w.write_raw("/Odometry", m.ODOMETRY, t, m.serialize(odo, m.ODOMETRY))
    rrd = tmp_path / "replay.rrd"
    assert main(["-q", "view", str(sample_log), "--replay", str(out), "--save", str(rrd)]) == 0
    assert verify(rrd).returncode == 0
    data = read_rrd(rrd)
    for e in (
        "/replay/map",
        "/replay/map_pcd",
        "/trajectories/replay/trajectory_tum/path",
        "/trajectories/replay/Odometry/path",
    ):
        assert e in data, e
    ((_, pts),) = column(data, "/replay/map_pcd", "Points3D:positions", static=True)
    assert np.allclose(pts, [[0, 0, 0], [1, 0, 0], [0, 1, 0.5]])
    ((_, strips),) = column(data, "/trajectories/replay/trajectory_tum/path", "LineStrips3D:strips", static=True)
    assert np.allclose(np.asarray(strips[0])[:, 0], [0, 0.5, 1.0, 1.5, 2.0])
    # white and thin over the replay's /Odometry it copies
    assert tum_path_style(data) == (WHITE, 0.005)
    assert "/top/trajectories/replay/trajectory_tum" not in data  # the top-down view draws the estimate once
    # the 2D view now uses the replayed map: 60 x 40 cells at 0.1 m, the occupied row 10 from the bottom
    ((_, buf),) = column(data, "/top/grid", "Image:buffer", static=True)
    img = np.asarray(buf, np.uint8).reshape(40, 60)
    assert (img[40 - 1 - 10] == 0).all() and (img[0] == 254).all()
    # without an estimate topic in replay.mcap (a SLAM replay's): the replay's estimate, blue, not white on the map
    (out / "replay.mcap").unlink()
    assert main(["-q", "view", str(sample_log), "--replay", str(out), "--save", str(rrd), "--force"]) == 0
    data = read_rrd(rrd)
    assert tum_path_style(data) == (BLUE, 0.01)
    ((_, colours),) = column(data, "/top/trajectories/replay/trajectory_tum", "LineStrips2D:colors", static=True)
    assert int(colours[0]) == BLUE  # and in the top-down view, where white would vanish on the map's free cells


WHITE, BLUE = 0xFFFFFFFF, 0x0072B2FF  # RGBA


def tum_path_style(data: dict) -> tuple[int, float]:
    """The colour and radius trajectory.tum's path is drawn with."""
    entity = "/trajectories/replay/trajectory_tum/path"
    ((_, colours),) = column(data, entity, "LineStrips3D:colors", static=True)
    ((_, radii),) = column(data, entity, "LineStrips3D:radii", static=True)
    return int(colours[0]), round(float(radii[0]), 6)


def test_a_slam_replay_s_loop_closures_are_drawn_between_their_keyframes(sample_log, tmp_path, caplog):
    import json

    from navlog.replay.io.tum import write_tum

    out = tmp_path / "OUT"
    out.mkdir()
    nodes = [
        {"id": i, "stamp_ns": i * NS, "x": x, "y": y, "yaw": 0.0} for i, (x, y) in enumerate([(0, 0), (2, 0), (2, 1)])
    ]
    edge = {"response": 0.6, "x": 0.0, "y": 0.0, "yaw": 0.0}
    edges = [{**edge, "kind": "match", "source": 0, "target": 1}, {**edge, "kind": "loop", "source": 2, "target": 0}]
    graph = {"frame_id": "map", "nodes": nodes, "edges": edges, "counts": {}, "odometry_jumps": [], "unplaced": []}
    (out / "pose_graph.json").write_text(json.dumps(graph))
    times = np.arange(3, dtype=np.int64) * NS
    write_tum(
        out / "trajectory.tum",
        times,
        np.array([[0, 0, 0], [2, 0, 0], [2, 1, 0]], float),
        np.tile([0, 0, 0, 1.0], (3, 1)),
    )
    rrd = tmp_path / "loops.rrd"
    assert main(["-q", "view", str(sample_log), "--replay", str(out), "--save", str(rrd)]) == 0
    data = read_rrd(rrd)
    ((_, strips),) = column(data, "/trajectories/replay/pose_graph/loops", "LineStrips3D:strips", static=True)
    assert len(strips) == 1 and np.allclose(strips[0], [[2, 1, 0], [0, 0, 0]])  # the loop edge only, keyframe 2 to 0
    ((_, strips2d),) = column(data, "/top/trajectories/replay/pose_graph/loops", "LineStrips2D:strips", static=True)
    assert len(strips2d) == 1
    # a pose graph navlog did not write is a warning, and the rest is drawn
    (out / "pose_graph.json").write_text('{"nodes": [{"id": "a"}], "edges": []}')
    caplog.set_level(logging.WARNING, logger="navlog")
    assert main(["-q", "view", str(sample_log), "--replay", str(out), "--save", str(rrd), "--force"]) == 0
    assert "pose_graph.json: not a pose graph navlog wrote (ValueError" in caplog.text
    (out / "pose_graph.json").write_text('{"nodes": [{"id": 1e400, "x": 0, "y": 0}], "edges": []}')
    assert main(["-q", "view", str(sample_log), "--replay", str(out), "--save", str(rrd), "--force"]) == 0
    assert "pose_graph.json: not a pose graph navlog wrote (OverflowError" in caplog.text
    assert "/trajectories/replay/pose_graph/loops" not in read_rrd(rrd)


def test_a_pose_estimate_with_covariance_is_a_trajectory_and_an_initial_pose_a_goal(tmp_path):
    from navlog.replay import messages as m
    from navlog.replay.io.logwriter import McapLogWriter

    log = tmp_path / "amcl.mcap"
    cov = np.diag([0.01, 0.01, 0.02])
    with McapLogWriter(log) as w:
        msg = m.planar_pose_with_covariance(0, "map", (0.5, 0.0, 0.0), cov)
        w.write_raw("/initialpose", m.POSE_WITH_COVARIANCE_STAMPED, 0, m.serialize(msg, m.POSE_WITH_COVARIANCE_STAMPED))
        for k in range(1, 6):
            msg = m.planar_pose_with_covariance(k * NS, "map", (0.5 + 0.2 * k, 0.1 * k, 0.0), cov)
            w.write_raw(
                "/amcl_pose", m.POSE_WITH_COVARIANCE_STAMPED, k * NS, m.serialize(msg, m.POSE_WITH_COVARIANCE_STAMPED)
            )
    rrd = tmp_path / "amcl.rrd"
    assert main(["-q", "view", str(log), "--save", str(rrd)]) == 0
    data = read_rrd(rrd)
    assert "/goals/initialpose" in data and not any(e.startswith("/goals/amcl_pose") for e in data)
    ((_, strips),) = column(data, "/trajectories/amcl_pose/path", "LineStrips3D:strips", static=True)
    assert np.allclose(np.asarray(strips[0])[:, :2], [(0.5 + 0.2 * k, 0.1 * k) for k in range(1, 6)])
    ((_, colours),) = column(data, "/trajectories/amcl_pose/path", "LineStrips3D:colors", static=True)
    assert int(colours[0]) == BLUE  # a localiser's estimate, not the odometry's sky blue
