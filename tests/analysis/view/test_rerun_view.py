"""navlog view: the saved .rrd verifies, holds the expected entities, and draws known geometry where it belongs."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from navlog.cli import main
from tests.analysis import sample_nav_log as sample

RERUN = Path(sys.executable).with_name("rerun")
NS = 1_000_000_000


def read_rrd(path: Path) -> dict[str, dict[str, list]]:
    """entity -> {"static": [record batches], "temporal": [record batches]} of the first recording."""
    from rerun.chunk import RrdReader

    out: dict[str, dict[str, list]] = {}
    for ch in RrdReader(path).stream().collect().stream():
        slot = out.setdefault(ch.entity_path, {"static": [], "temporal": []})
        slot["static" if ch.is_static else "temporal"].append(ch.to_record_batch())
    return out


def column(data: dict, entity: str, name: str, static: bool = False) -> list:
    """All values of one column of an entity, in time order for temporal data."""
    rows = []
    for rb in data[entity]["static" if static else "temporal"]:
        if name not in rb.schema.names:
            continue
        vals = rb.column(name).to_pylist()
        times = rb.column("sim_time").cast("int64").to_pylist() if "sim_time" in rb.schema.names else [0] * len(vals)
        rows.extend(zip(times, vals))
    rows.sort(key=lambda r: r[0])
    return rows


def verify(path: Path) -> subprocess.CompletedProcess:
    return subprocess.run([str(RERUN), "rrd", "verify", str(path)], capture_output=True, text=True, timeout=60)


@pytest.fixture(scope="module")
def sample_log(tmp_path_factory) -> Path:
    return sample.write_sample_log(tmp_path_factory.mktemp("log") / "sample.mcap")


@pytest.fixture(scope="module")
def rrd(sample_log, tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("view") / "sample.rrd"
    assert main(["-q", "view", str(sample_log), "--save", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def data(rrd) -> dict:
    return read_rrd(rrd)


def test_saved_rrd_verifies_and_has_a_blueprint(rrd):
    res = verify(rrd)
    assert res.returncode == 0, res.stderr
    from rerun.chunk import RrdReader

    reader = RrdReader(rrd)
    assert len(reader.recordings()) == 1
    assert len(reader.blueprints()) == 1
    assert not list(rrd.parent.glob("*.part"))


def test_expected_entities_are_drawn(data):
    expected = {
        "/sensors/scan",
        "/sensors/livox/lidar",
        "/tf/odom",
        "/tf/base_footprint",
        "/tf/front_laser",
        "/trajectories/odom/ground_truth/path",
        "/trajectories/odom/path",
        "/trajectories/odom/pose",
        "/plans/plan",
        "/goals/goal_pose",
        "/grids/map",
        "/top/grid",
        "/top/scans/scan",
        "/top/footprint",
        "/plots/cmd_vel/vx/cmd_vel_nav",
        "/plots/cmd_vel/vx/cmd_vel_smoothed",
        "/plots/cmd_vel/vx/cmd_vel",
        "/plots/cmd_vel/wz/cmd_vel",
        "/plots/speed/odom",
        "/plots/metrics/drift/odom",
        "/events",
    }
    missing = expected - set(data)
    assert not missing, f"missing entities {sorted(missing)}"
    # a holonomic axis that was never commanded is not plotted
    assert "/plots/cmd_vel/vy/cmd_vel" not in data


def test_timeline_is_sim_time_as_a_duration(data):
    rb = data["/sensors/scan"]["temporal"][0]
    assert str(rb.schema.field("sim_time").type) == "duration[ns]"
    times = [t for t, _ in column(data, "/sensors/scan", "Points3D:positions")]
    assert times == [k * 100_000_000 for k in range(1, 21)]  # scans at 0.1 .. 2.0 s of sim time
    assert "log_time" not in rb.schema.names  # no wall-clock timeline mixed in


def test_scan_points_land_on_the_wall_in_the_top_view(data):
    # the wall x = 4 m in the map frame, the canvas starts at the grid origin x = -1 m, 0.05 m per pixel
    u_wall = (sample.WALL_X - sample.GRID_ORIGIN[0]) / sample.GRID_RES
    rows = column(data, "/top/scans/scan", "Points2D:positions")
    assert len(rows) == 20
    for _, pts in rows:
        uv = np.asarray(pts)
        assert len(uv) > 50
        assert np.allclose(uv[:, 0], u_wall, atol=1e-3)
    # and in 3D, in the laser frame: the first scan (robot at x=1.05 map, laser at 1.15) sees the wall 2.85 m ahead
    t0, pts3 = column(data, "/sensors/scan", "Points3D:positions")[0]
    x_laser = sample.WALL_X - (sample.robot_x_map(0.1, 0.5) + sample.LASER_X)
    assert np.allclose(np.asarray(pts3)[:, 0], x_laser, atol=1e-5)


def test_grid_image_marks_the_wall_column(data):
    ((_, buf),) = column(data, "/top/grid", "Image:buffer")
    ((_, fmt),) = column(data, "/top/grid", "Image:format")
    width, height = sample.GRID_SIZE
    img = np.asarray(buf, dtype=np.uint8).reshape(height, width)
    wall_col = int(round((sample.WALL_X - sample.GRID_ORIGIN[0]) / sample.GRID_RES))
    assert (img[:, wall_col] == 0).all()  # occupied: black
    assert (img[:, :wall_col] == 254).all()  # free: white
    assert (img[:, wall_col + 1 :] == 205).all()  # unknown: grey


def test_footprint_follows_the_robot(data):
    rows = column(data, "/top/footprint", "LineStrips2D:strips")
    assert len(rows) == 20
    for t, strips in rows:
        strip = np.asarray(strips[0])
        centre = strip[:-1].mean(axis=0)
        x_map = sample.robot_x_map(t / NS, 0.5)
        assert centre[0] == pytest.approx((x_map - sample.GRID_ORIGIN[0]) / sample.GRID_RES, abs=1e-3)
        assert centre[1] == pytest.approx(
            (sample.GRID_ORIGIN[1] + sample.GRID_SIZE[1] * sample.GRID_RES) / sample.GRID_RES, abs=1e-3
        )


def test_velocity_chain_speed_and_drift_series(data):
    nav = column(data, "/plots/cmd_vel/vx/cmd_vel_nav", "Scalars:scalars")
    smoothed = column(data, "/plots/cmd_vel/vx/cmd_vel_smoothed", "Scalars:scalars")
    final = column(data, "/plots/cmd_vel/wz/cmd_vel_smoothed", "Scalars:scalars")
    assert len(nav) == 41 and {v[0] for _, v in nav} == {0.6}
    assert {v[0] for _, v in smoothed} == {0.55}
    assert {v[0] for _, v in final} == {0.05}
    speed = column(data, "/plots/speed/odom", "Scalars:scalars")
    assert len(speed) == 101 and all(math.isclose(v[0], 0.5) for _, v in speed)
    drift = column(data, "/plots/metrics/drift/odom", "Scalars:scalars")
    t_end, d_end = drift[-1]
    assert t_end == 2 * NS
    assert d_end[0] == pytest.approx(sample.DRIFT * 2.0, abs=1e-9)  # 0.01 m/s sideways for 2 s


def test_events_and_goal_labels(data):
    texts = column(data, "/events", "TextLog:text")
    assert [v for _, v in texts] == [
        ["goal_accepted [navigator]: corridor_end"],
        ["goal_reached [navigator]: corridor_end (0.12)"],
    ]
    labels = column(data, "/goals/goal_pose", "Arrows3D:labels")
    assert labels[0][1] == ["goal 1: corridor_end"]
    origins = column(data, "/goals/goal_pose", "Arrows3D:origins")
    assert np.allclose(origins[0][1], [[3.0, 0.0, 0.0]])


def test_tf_tree_and_frames(data):
    child = column(data, "/tf/base_footprint", "Transform3D:child_frame")
    parent = column(data, "/tf/base_footprint", "Transform3D:parent_frame")
    trans = column(data, "/tf/base_footprint", "Transform3D:translation")
    assert len(trans) == 101 and child[0][1] == ["base_footprint"] and parent[0][1] == ["odom"]
    assert np.allclose(trans[-1][1], [[1.0, 0.0, 0.0]])  # odom x = 0.5 m/s * 2 s
    frames = {
        e: column(data, e, "CoordinateFrame:frame", static=True)[0][1][0]
        for e in ("/sensors/scan", "/sensors/livox/lidar", "/trajectories/odom/path")
    }
    assert frames == {
        "/sensors/scan": "front_laser",
        "/sensors/livox/lidar": "livox_frame",
        "/trajectories/odom/path": "odom",
    }
    # ground truth is in `world`, which has no TF path to map: linked as coincident
    assert "/tf/_unlinked/world" in data


def test_replay_output_folder_is_drawn(sample_log, tmp_path):
    import open3d as o3d

    from navlog.analysis.metrics.trajectory import Trajectory
    from navlog.analysis.tum import write_tum
    from navlog.replay import messages as m
    from navlog.replay.io.logwriter import McapLogWriter
    from navlog.replay.io.map_server import OccupancyMap, save_map

    out = tmp_path / "OUT"
    out.mkdir()
    cells = np.zeros((40, 60), np.int8)
    cells[10, :] = 100
    save_map(OccupancyMap(cells, 0.1, (-2.0, -1.0, 0.0)), out / "map.yaml")
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0.5]], float)))
    o3d.io.write_point_cloud(str(out / "map.pcd"), pcd)
    times = np.arange(5, dtype=np.int64) * NS // 2
    write_tum(
        out / "trajectory.tum",
        Trajectory(times, np.c_[times / NS, np.zeros(5), np.zeros(5)], np.tile([0, 0, 0, 1.0], (5, 1))),
    )
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
    # the 2D view now uses the replayed map: 60 x 40 cells at 0.1 m, the occupied row 10 from the bottom
    ((_, buf),) = column(data, "/top/grid", "Image:buffer", static=True)
    img = np.asarray(buf, np.uint8).reshape(40, 60)
    assert (img[40 - 1 - 10] == 0).all() and (img[0] == 254).all()


@pytest.mark.parametrize(
    "bag", ["neato_drive_square", "tb3_gazebo_walker", "rosbag2_talker_mcap", "rosbag2_wbag_split_mcap"]
)
def test_every_external_bag_opens(bag, bags_dir, tmp_path, caplog):
    out = tmp_path / f"{bag}.rrd"
    assert main(["view", str(bags_dir / bag), "--save", str(out)]) == 0
    assert verify(out).returncode == 0
    data = read_rrd(out)
    if bag == "neato_drive_square":
        warned = [r.getMessage() for r in caplog.records if "unknown types" in r.getMessage()]
        assert (
            len(warned) == 1 and "/accel (neato2_interfaces/msg/Accel), /bump (neato2_interfaces/msg/Bump)" in warned[0]
        )
        assert {
            "/sensors/scan",
            "/sensors/projected_stable_scan",
            "/trajectories/odom/path",
            "/top/footprint",
            "/plots/cmd_vel/vx/cmd_vel",
        } <= set(data)
        # wall-clock receive times: the timeline starts at zero, not in 2024
        times = [t for t, _ in column(data, "/sensors/scan", "Points3D:positions")]
        assert 0 <= times[0] < NS and times[-1] < 45 * NS
    elif bag == "tb3_gazebo_walker":
        assert {"/sensors/scan", "/tf/base_scan", "/plots/imu/imu/wz", "/text/rosout"} <= set(data)
        frame = column(data, "/sensors/scan", "CoordinateFrame:frame", static=True)[0][1]
        assert frame == ["base_scan"]
    elif bag == "rosbag2_talker_mcap":
        texts = [v[0] for _, v in column(data, "/text/topic", "TextLog:text")]
        from navlog.replay.io.logreader import open_log

        with open_log(bags_dir / bag) as r:
            count = r.topics["/topic"].count
        assert texts == [f"Hello, world! {i}" for i in range(count)]
    else:
        assert {f"/text/{n * 3}" for n in "ABCDEFGH"} <= set(data)


def test_existing_output_is_refused_without_force(sample_log, tmp_path, capsys):
    out = tmp_path / "x.rrd"
    out.write_bytes(b"keep me")
    assert main(["view", str(sample_log), "--save", str(out)]) == 2
    assert "already exists" in capsys.readouterr().err and out.read_bytes() == b"keep me"
    assert main(["-q", "view", str(sample_log), "--save", str(out), "--force"]) == 0
    assert verify(out).returncode == 0


def test_truncated_log_is_a_clear_error_and_leaves_nothing(tmp_path_factory, tmp_path, capsys):
    whole = sample.write_sample_log(tmp_path_factory.mktemp("chunks") / "whole.mcap", chunk_size=16 << 10)
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(whole.read_bytes()[: whole.stat().st_size // 2])
    out = tmp_path / "cut.rrd"
    assert main(["view", str(cut), "--save", str(out)]) == 2
    err = capsys.readouterr().err
    assert "truncated" in err and "--recover" in err
    assert list(tmp_path.iterdir()) == [cut]
    # with --recover the readable part is drawn
    assert main(["-q", "view", str(cut), "--recover", "--save", str(out)]) == 0
    assert verify(out).returncode == 0


@pytest.mark.parametrize(
    "args, message",
    [
        (["--save", "{tmp}/a.txt"], "must end in .rrd"),
        (["--save", "{tmp}/nope/a.rrd"], "output folder does not exist"),
        (["--save", "{tmp}/a.rrd", "--replay", "{tmp}/missing"], "replay output folder does not exist"),
        (["--connect", "localhost:9876"], "expected a URL like rerun+http"),
    ],
)
def test_bad_arguments(args, message, sample_log, tmp_path, capsys):
    argv = ["view", str(sample_log)] + [a.format(tmp=tmp_path) for a in args]
    assert main(argv) == 2
    assert message in capsys.readouterr().err
    assert list(tmp_path.iterdir()) == []


def test_not_a_log(tmp_path, capsys):
    bad = tmp_path / "notes.mcap"
    bad.write_text("hello")
    assert main(["view", str(bad), "--save", str(tmp_path / "a.rrd")]) == 2
    assert "not an MCAP file" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.mcap"]


def test_frame_prefix_twist_stamped_and_robot_radius(tmp_path):
    from navlog.replay.config import load_yaml, named_config

    log = sample.write_sample_log(
        tmp_path / "p.mcap", frame_prefix="simple_robot/", twist_stamped=True, robot="go2", with_events=False
    )
    out = tmp_path / "p.rrd"
    assert main(["-q", "view", str(log), "--frame-prefix", "simple_robot/", "--save", str(out)]) == 0
    data = read_rrd(out)
    # frame names as configured: the prefix is stripped everywhere, scans land on the wall as before
    assert column(data, "/sensors/scan", "CoordinateFrame:frame", static=True)[0][1] == ["front_laser"]
    assert column(data, "/tf/base_footprint", "Transform3D:parent_frame")[0][1] == ["odom"]
    u_wall = (sample.WALL_X - sample.GRID_ORIGIN[0]) / sample.GRID_RES
    rows = column(data, "/top/scans/scan", "Points2D:positions")
    assert len(rows) == 20 and all(np.allclose(np.asarray(p)[:, 0], u_wall, atol=1e-3) for _, p in rows)
    # TwistStamped reads like Twist
    assert {v[0] for _, v in column(data, "/plots/cmd_vel/vx/cmd_vel_nav", "Scalars:scalars")} == {0.6}
    # the footprint is the recorded robot's circle (config/robots/go2.yaml radius)
    radius = float(load_yaml(named_config("robots", "go2"))["radius"])
    strip = np.asarray(column(data, "/top/footprint", "LineStrips2D:strips")[0][1][0])
    dist = np.linalg.norm(strip[:-1] - strip[:-1].mean(axis=0), axis=1)
    assert np.allclose(dist, radius / sample.GRID_RES, atol=1e-3)


def test_fast_grids_are_thinned_to_one_per_period(tmp_path):
    from navlog.analysis.view.rerun_view import ViewOptions, save_view

    log = sample.write_sample_log(tmp_path / "c.mcap", costmap_hz=5.0, with_events=False)
    summary = save_view(log, tmp_path / "c.rrd", options=ViewOptions(grid_period_s=1.0))
    data = read_rrd(tmp_path / "c.rrd")
    times = [t for t, _ in column(data, "/grids/global_costmap/costmap", "GridMap:data")]
    assert times == [0, NS, 2 * NS]  # 11 costmaps at 5 Hz over 0..2 s
    assert summary.skipped == {"grid thinned to one per 1 s on /global_costmap/costmap": 8}
    # /map stays the top-down grid; the costmap is drawn in 3D only
    assert summary.grid_source == "/map"


def test_connect_streams_to_a_listening_viewer_server(sample_log, tmp_path):
    """--connect sends the recording over gRPC; a headless `rerun --save` server receives it."""
    import signal
    import socket
    import time

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    received = tmp_path / "received.rrd"
    server = subprocess.Popen(
        [str(RERUN), "--bind", "127.0.0.1", "--port", str(port), "--save", str(received)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    try:
        deadline = time.monotonic() + 20
        while time.monotonic() < deadline:
            try:
                socket.create_connection(("127.0.0.1", port), timeout=0.2).close()
                break
            except OSError:
                time.sleep(0.1)
        assert main(["-q", "view", str(sample_log), "--connect", f"rerun+http://127.0.0.1:{port}/proxy"]) == 0
        time.sleep(0.5)
    finally:
        server.send_signal(signal.SIGINT)
        server.wait(timeout=20)
    entities = set(read_rrd(received))
    assert {"/sensors/scan", "/top/scans/scan", "/plots/cmd_vel/vx/cmd_vel", "/events"} <= entities


def test_connect_without_a_viewer_fails_clearly(sample_log, monkeypatch, capsys):
    import socket

    import navlog.analysis.view.rerun_view as rv

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    original = rv.stream_view
    monkeypatch.setattr(rv, "stream_view", lambda *a, **k: original(*a, **{**k, "flush_timeout_s": 1.0}))
    assert main(["view", str(sample_log), "--connect", f"rerun+http://127.0.0.1:{port}/proxy"]) == 2
    assert "no Rerun viewer took the recording" in capsys.readouterr().err
