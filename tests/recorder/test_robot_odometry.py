"""A drive plugin's odometry topic and frames, end to end: the recorder publishes the odometry there, and
the navigation stack, AMCL, the replay pipelines and ``navlog check`` read it from there."""

from __future__ import annotations

import json
import logging
import math
from pathlib import Path

import pytest

from navlog.analysis.check import check_log
from navlog.cli import main
from navlog.recorder.description import describe
from navlog.recorder.record import prepare, record
from navlog.replay.io.formats import open_log
from navlog.replay.pipelines import pipeline_spec
from navlog.replay.session import pipeline_params, run_replay
from tests.recorder.descriptions import CLASSIC_PLUGIN, GZ_PLUGIN, ROBOT


def _robot(tmp_path: Path, plugin: str = GZ_PLUGIN) -> Path:
    path = tmp_path / "wheely.urdf"
    path.write_text(ROBOT.replace("PLUGIN", plugin))
    return path


def test_both_plugin_spellings_name_the_odometry_topic_and_frames(tmp_path):
    for plugin in (GZ_PLUGIN, CLASSIC_PLUGIN):
        robot = describe(_robot(tmp_path, plugin))
        assert robot.odom.topic == "/odometry/wheels" and robot.odom.rate == 25.0
        assert robot.frames.odom == "wheel_odom" and robot.frames.base_footprint == "base_footprint"
        assert robot.frames.base == "base_link" and robot.odometry == ("/odometry/wheels", "wheel_odom")
        assert robot.drive.wheel_radius == pytest.approx(0.05) and robot.drive.wheel_separation == pytest.approx(0.28)


@pytest.fixture(scope="module")
def navigated(tmp_path_factory) -> tuple[Path, object, Path]:
    """The robot sent 2 m ahead in walled_room by Nav2 (nav_kibot's file, which names /odom and odom) on AMCL."""
    tmp = tmp_path_factory.mktemp("odometry")
    (tmp / "goal.yaml").write_text("frame_id: map\ngoals:\n  - {name: ahead, x: 2.0, y: -1.0, yaw: 0.0}\n")
    scenario = tmp / "ahead.yaml"
    scenario.write_text(
        "name: ahead\nkind: navigate\nworld: walled_room\nstart: [0.0, 0.0, 0.0]\nnav2_params: nav_kibot\n"
        "goals: goal.yaml\nnavigation: waypoints\nmap: world\nmap_margin: 0.0\nhold: 0.5\nmax_duration: 40.0\n"
    )
    log = tmp / "nav.mcap"
    logging.getLogger("navlog").setLevel(logging.ERROR)
    setup = prepare(None, str(_robot(tmp)), str(scenario), localization="amcl")
    res = record(setup, log, progress=False, sensor_worker=False)
    return log, res, tmp


def test_the_recording_publishes_the_odometry_where_the_plugin_says(navigated):
    log, res, _ = navigated
    assert "/odom" not in res.topics and res.topics["/odometry/wheels"][1] > 100
    with open_log(log) as r:
        assert r.metadata["navlog"]["odom_topic"] == "/odometry/wheels"
        assert r.metadata["navlog"]["odom_frame"] == "wheel_odom"
        odom = [e.msg for e in r.messages(["/odometry/wheels"])]
        edges = {(t.header.frame_id, t.child_frame_id) for e in r.messages(["/tf"]) for t in e.msg.transforms}
    assert {(o.header.frame_id, o.child_frame_id) for o in odom} == {("wheel_odom", "base_footprint")}
    assert {("wheel_odom", "base_footprint"), ("base_footprint", "base_link")} <= edges
    assert "odom" not in {frame for edge in edges for frame in edge}
    # 25 Hz: 40 ms periods
    stamps = [o.header.stamp.sec * 10**9 + o.header.stamp.nanosec for o in odom[:3]]
    assert stamps[1] - stamps[0] == 40_000_000


def test_navigation_and_amcl_ran_on_that_odometry(navigated):
    _, res, _ = navigated
    goals = res.navigation["goals"]
    assert [g["status"] for g in goals] == ["succeeded"], goals
    assert res.collisions == 0
    loc = res.localization  # AMCL localised every scan on the wheel_odom frame (none on "odom")
    assert loc["poses"] > 50 and loc["final_m"] < 0.15 and loc["mean_m"] < 0.10, loc


def test_replay_and_check_read_the_odometry_the_log_names(navigated):
    log, _, tmp = navigated
    with open_log(log) as reader:
        nav = pipeline_spec("navigation").settle(
            pipeline_params("navigation", overrides=["nav2_params=nav_kibot"]), reader, {}
        )
        loc = pipeline_spec("localization").settle(pipeline_params("localization"), reader, {})
    assert nav.odom_topic == "/odometry/wheels"
    # nav_kibot's local costmap, behaviours and collision monitor name "odom": now "wheel_odom"
    assert nav.nav2["local_costmap.local_costmap.ros__parameters.global_frame"] == "wheel_odom"
    assert nav.nav2["behavior_server.ros__parameters.local_frame"] == "wheel_odom"
    assert nav.nav2["bt_navigator.ros__parameters.odom_topic"] == "/odometry/wheels"
    assert nav.nav2["collision_monitor.ros__parameters.odom_frame_id"] == "wheel_odom"
    assert loc.amcl == {"odom_frame_id": "wheel_odom"}
    built = pipeline_spec("navigation").build(nav, set())
    assert "/odometry/wheels" in built.optional_inputs and "/odom" not in built.optional_inputs
    # the localization replay localises on the recorded wheel_odom -> base_footprint
    assert main(["-q", "world-map", "walled_room", "--margin", "0", "-o", str(tmp / "map.yaml")]) == 0
    out = run_replay(log, "localization", tmp / "loc", overrides=[f"map={tmp / 'map.yaml'}"], progress=False)
    report = json.loads((out.out_dir / "localization.json").read_text())
    assert report["scans_localised"] > 50, report  # 10 Hz scans over ~9 s; on the frame "odom", none
    assert out.manifest["parameters"]["amcl"] == {"odom_frame_id": "wheel_odom"}
    # navlog check: the odometry topic is one a pipeline reads, held to its own 25 Hz
    result = check_log(log)
    rate = next(c for c in result.checks if c.name == "rate" and c.subject.startswith("/odometry/wheels"))
    assert rate.status.name == "PASS"


# ---------------------------------------------------------------- an omni base

OMNI_PLUGINS = {
    "planar_move": """<plugin name="planar" filename="libgazebo_ros_planar_move.so">
      <ros><remapping>odom:=odometry/planar</remapping></ros>
      <odometry_frame>odom</odometry_frame><robot_base_frame>base_link</robot_base_frame>
      <publish_rate>50</publish_rate>
    </plugin>""",
    "velocity_control": """<plugin filename="gz-sim-velocity-control-system"
      name="gz::sim::systems::VelocityControl"><topic>cmd_vel</topic></plugin>""",
}


@pytest.mark.parametrize("plugin", sorted(OMNI_PLUGINS))
def test_an_omni_base_moves_sideways_by_the_commanded_distance(tmp_path, plugin):
    """0.2 m/s to the left for 3 s: 0.60 m along +y within 3 cm (the carriage accelerates within a tick), no
    more than 2 cm along x and 1 degree of yaw; the odometry says the same within 1 cm."""
    robot = tmp_path / "omni.urdf"
    text = ROBOT.replace("PLUGIN", OMNI_PLUGINS[plugin])
    robot.write_text(text.replace('type="continuous"', 'type="fixed"'))  # a box on casters: the carriage drives it
    scenario = tmp_path / "left.yaml"
    scenario.write_text(
        "name: left\nkind: teleop\nstart: [0.0, 0.0, 0.0]\ncommands:\n  - {duration: 3.0, cmd: [0.0, 0.2, 0.0]}\nhold: 1.0\n"
    )
    log = tmp_path / "omni.mcap"
    setup = prepare("walled_room", str(robot), str(scenario))
    assert setup.robot.drive.type == "legged" and setup.robot.drive.max_vy > 0  # the kinematic planar carriage
    record(setup, log, progress=False, sensor_worker=False)
    odom_topic = setup.robot.odom.topic
    assert odom_topic == ("/odometry/planar" if plugin == "planar_move" else "/odom")
    with open_log(log) as r:
        truth = [e.msg.pose.pose for e in r.messages(["/odom/ground_truth"])]
        odom = [e.msg for e in r.messages([odom_topic])]
    end, start = truth[-1], truth[0]
    assert end.position.y - start.position.y == pytest.approx(0.60, abs=0.03)
    assert abs(end.position.x - start.position.x) < 0.02
    q = end.orientation
    assert abs(math.degrees(math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z)))) < 1.0
    o = odom[-1].pose.pose.position
    assert o.y == pytest.approx(end.position.y - start.position.y, abs=0.01) and abs(o.x) < 0.02
    assert max(m.twist.twist.linear.y for m in odom) == pytest.approx(0.2, abs=0.01)


def test_mapping_replays_on_the_odometry_frame_the_log_names(navigated):
    log, _, tmp = navigated
    with open_log(log) as reader:
        spec = pipeline_spec("mapping")
        slam = spec.settle(pipeline_params("mapping", overrides=["pose_source=slam"]), reader, {})
        odom = spec.settle(pipeline_params("mapping", overrides=["pose_source=odom"]), reader, {})
        kept = spec.settle(pipeline_params("mapping", overrides=["slam.odom_frame=odom"]), reader, {})
        # --remap /odom=/odometry/wheels (log topic -> the pipeline's): the pipeline reads /odom, remapped
        remapped = spec.settle(
            pipeline_params("mapping", overrides=["pose_source=odom"]), reader, {"/odometry/wheels": "/odom"}
        )
    assert slam.slam.odom_frame == "wheel_odom" and odom.occupancy.pose_topic == "/odometry/wheels"
    assert kept.slam.odom_frame == "wheel_odom"  # the default's own value reads as the default
    assert remapped.occupancy.pose_topic == ""  # /odom, which the remap feeds
    # the SLAM places every scan on wheel_odom -> base_footprint (on "odom", none)
    out = run_replay(log, "mapping", tmp / "slam", overrides=["pose_source=slam"], progress=False)
    stamps = [line for line in (out.out_dir / "trajectory.tum").read_text().splitlines() if line.strip()]
    assert len(stamps) > 50
