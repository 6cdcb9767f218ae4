"""navlog view: the saved .rrd verifies and holds the expected entities; every log opens; bad input is refused cleanly."""

from __future__ import annotations

import subprocess

import numpy as np
import pytest

from navlog.cli import main
from tests.analysis import sample_nav_log as sample
from tests.analysis.view.rrd import RERUN, column, read_rrd, verify

pytestmark = pytest.mark.slow

NS = 1_000_000_000


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
        from navlog.replay.io import open_log

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


# the server's --save file, stopped by an interrupt, has no footer: rerun's reader says so and scans it whole
@pytest.mark.filterwarnings("ignore:RRD file has no footer")
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
        for wait_s in (20, 40):  # a loaded host: the first interrupt may come before the server takes it
            server.send_signal(signal.SIGINT)
            try:
                server.wait(timeout=wait_s)
                break
            except subprocess.TimeoutExpired:
                continue
        else:
            server.kill()
            server.wait()
    entities = set(read_rrd(received))
    assert {"/sensors/scan", "/top/scans/scan", "/plots/cmd_vel/vx/cmd_vel", "/events"} <= entities


def test_connect_without_a_viewer_fails_clearly(sample_log, monkeypatch, capsys):
    import socket

    import navlog.analysis.view as view

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    original = view.stream_view
    monkeypatch.setattr(view, "stream_view", lambda *a, **k: original(*a, **{**k, "flush_timeout_s": 1.0}))
    assert main(["view", str(sample_log), "--connect", f"rerun+http://127.0.0.1:{port}/proxy"]) == 2
    assert "no Rerun viewer took the recording" in capsys.readouterr().err


def test_a_replay_made_from_another_log_is_warned_about(tmp_path, teleop_log, caplog):
    import json
    import logging
    import types

    from navlog.analysis.view.log_view import _check_replay_of
    from navlog.replay.identity import input_entries

    """`view LOG --replay DIR` drew another log's replay over LOG without a word (its transforms stood in for the
    log's); the replay's manifest names its input's hash, and a different one is warned about."""
    reader = types.SimpleNamespace(path=teleop_log)
    (tmp_path / "manifest.json").write_text(json.dumps({"inputs": input_entries(teleop_log)}))
    with caplog.at_level(logging.WARNING, logger="navlog"):
        _check_replay_of(reader, tmp_path)
    assert not caplog.records
    (tmp_path / "manifest.json").write_text(json.dumps({"inputs": [{"file": "other.mcap", "sha256": "0" * 64}]}))
    with caplog.at_level(logging.WARNING, logger="navlog"):
        _check_replay_of(reader, tmp_path)
    assert "was made from another log (other.mcap)" in caplog.text
