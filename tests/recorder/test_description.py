"""Robots from Nav2's own description files (URDF, SDF, xacro): their numbers, a recording, and bad input."""

from __future__ import annotations

import logging
import math
import os
from pathlib import Path

import numpy as np
import pytest

from navlog.cli import main
from navlog.errors import ConfigError
from navlog.recorder.description import describe, load_robot
from navlog.recorder.record import prepare, record
from navlog.recorder.robot_model import pose_matrix
from navlog.replay.io import open_log
from tests.recorder.descriptions import GZ_PLUGIN, ROBOT


@pytest.fixture(scope="module")
def nav2_sim(shared_dir: Path) -> Path:
    return shared_dir / "external-data" / "nav2_sim"


@pytest.fixture(scope="module")
def waffle_sdf(nav2_sim: Path) -> Path:
    return nav2_sim / "nav2_minimal_tb3_sim" / "urdf" / "gz_waffle.sdf.xacro"


@pytest.fixture(scope="module")
def tb4(nav2_sim: Path) -> Path:
    return nav2_sim / "nav2_minimal_tb4_description" / "urdf" / "standard" / "turtlebot4.urdf.xacro"


def _static(robot, child: str):
    assert robot.model is not None
    return next(f for f in robot.model.static_frames if f.child == child)


def test_waffle_sdf_xacro_has_nav2s_numbers(waffle_sdf):
    r = describe(waffle_sdf)
    d = r.drive
    assert (d.type, d.wheel_separation, d.wheel_radius) == ("diff_drive", 0.287, 0.033)
    assert (d.max_vx, d.min_vx, d.max_wz, d.max_accel) == (0.46, -0.46, 1.9, (1.0, 0.0, 2.0))
    assert r.model.wheel_joints == ("wheel_left_joint", "wheel_right_joint")
    assert r.model.drive_plugin == "gz-sim-diff-drive-system"
    assert (r.cmd_topic, r.odom.topic, r.odom.rate) == ("/cmd_vel", "/odom", 30.0)
    assert (r.frames.odom, r.frames.base, r.frames.base_footprint) == ("odom", "base_footprint", "")
    assert (r.model.joint_states_topic, r.model.joint_states_rate) == ("/joint_states", 30.0)
    s = r.scan
    assert (s.topic, s.frame, s.samples, s.rate, s.noise_std) == ("/scan", "base_scan", 360, 5.0, 0.01)
    assert (s.range_min, s.range_max) == (0.00001, 20.0)
    # Gazebo's increment: 6.28 over 359 steps; the last beam at the file's max_angle
    inc = (s.angle_max - s.angle_min) / s.samples
    assert inc == pytest.approx(6.28 / 359) and s.angle_min + inc * 359 == pytest.approx(6.28)
    # the sensor sits at its <pose> in base_scan (a link at the model's origin): its frame is published there
    assert s.mount == pytest.approx((-0.064, 0.0, 0.15, 0.0, 0.0, 0.0))
    assert _static(r, "base_scan").pose[:3] == pytest.approx((-0.064, 0.0, 0.15))
    assert _static(r, "base_scan").parent == "base_link"
    assert (r.imu.topic, r.imu.frame, r.imu.rate) == ("/imu", "imu_link", 200.0)
    assert (r.imu.gyro_noise, r.imu.accel_noise) == (2e-4, 1.7e-2)
    assert r.lidar is None
    assert r.model.other_sensors == ["intel_realsense_r200_depth (depth)"]
    # the masses of the file, and the robot standing on its wheels and casters (1 cm below the model's origin)
    assert r.body.mass == pytest.approx(1.0 + 0.125 + 2 * 0.1 + 2 * 0.001 + 0.035)
    assert r.model.height == pytest.approx(0.010, abs=1e-4)
    wheel = r.model.link("wheel_left_link")
    assert wheel.joint_type == "revolute" and wheel.joint_pos == pytest.approx((0.0, 0.144, 0.023))
    assert wheel.axis == pytest.approx((0.0, 1.0, 0.0), abs=1e-3)  # the joint frame's z, rolled by -1.57


def test_waffle_urdf_names_the_plugins_it_understands_then_measures_its_wheels(nav2_sim):
    urdf = nav2_sim / "nav2_minimal_tb3_sim" / "urdf" / "turtlebot3_waffle.urdf"
    with pytest.raises(ConfigError, match="no drive plugin.*gz-sim-diff-drive-system.*libgazebo_ros_diff_drive.so"):
        describe(urdf)
    r = describe(urdf, drive="diff_drive")
    assert r.drive.wheel_separation == pytest.approx(0.288) and r.drive.wheel_radius == 0.033
    assert r.model.wheel_joints == ("wheel_left_joint", "wheel_right_joint")
    assert _static(r, "base_link").pose[:3] == (0.0, 0.0, 0.010)
    assert _static(r, "base_scan").pose[:3] == (-0.064, 0.0, 0.122)
    rgb = _static(r, "camera_rgb_optical_frame")
    assert rgb.parent == "camera_rgb_frame"
    assert pose_matrix(rgb.pose)[:3, :3] @ np.array([0, 0, 1.0]) == pytest.approx([1.0, 0.0, 0.0], abs=1e-3)
    assert r.scan is None and r.imu is None  # the plain URDF declares no sensor
    assert r.body.mass == pytest.approx(1.3729096 + 2 * 0.028498940 + 2 * 0.005 + 0.114, abs=0.01)


def test_turtlebot4_xacro_loads_with_its_two_missing_visual_meshes_as_warnings(tb4, caplog):
    with caplog.at_level(logging.WARNING, logger="navlog"):
        r = describe(tb4)
    missing = [m for m in caplog.messages if "visual mesh" in m]
    assert len(missing) == 2
    assert any("shell.dae" in m and "shell_link" in m for m in missing)
    assert any("oakd_pro.dae" in m and "oakd_link" in m for m in missing)
    assert (r.drive.wheel_separation, r.drive.wheel_radius) == (0.233, 0.03575)
    assert r.model.wheel_joints == ("left_wheel_joint", "right_wheel_joint")
    assert (r.frames.base, r.odom.rate) == ("base_link", 100.0)
    s = r.scan
    assert (s.topic, s.frame, s.samples, s.range_min, s.range_max, s.rate) == (
        "/scan",
        "rplidar_link",
        360,
        0.164,
        20.0,
        10.0,
    )
    assert s.mount[:3] == pytest.approx((-0.04, 0.0, 0.0642 + 0.03 + 0.098715))
    assert s.mount[5] == pytest.approx(math.pi / 2)
    shell = r.model.link("shell_link").collisions[0].geometry
    assert shell.shape == "mesh" and shell.mesh.endswith("shell_collision.dae")
    assert "rgbd_camera (rgbd_camera)" in r.model.other_sensors


def test_xacro_arguments_name_the_topics(waffle_sdf):
    r = load_robot(str(waffle_sdf), {"namespace": "/tb3"})
    assert (r.cmd_topic, r.odom.topic, r.scan.topic, r.imu.topic) == (
        "/tb3/cmd_vel",
        "/tb3/odom",
        "/tb3/scan",
        "/tb3/imu",
    )


def test_a_robot_yaml_adds_what_the_description_lacks(waffle_sdf, tmp_path):
    yaml = tmp_path / "my_waffle.yaml"
    yaml.write_text(
        f"description_file: {os.path.relpath(waffle_sdf, tmp_path)}\n"
        "odom: {linear_noise: 0.02, angular_noise: 0.03}\n"
        "lidar: {topic: /points, frame: base_scan, lines: 16, columns: 360}\n"
    )
    r = load_robot(str(yaml))
    assert (r.odom.linear_noise, r.odom.angular_noise, r.odom.rate) == (0.02, 0.03, 30.0)
    assert r.lidar is not None and (r.lidar.lines, r.lidar.columns) == (16, 360)
    assert r.drive.wheel_separation == 0.287 and r.scan.samples == 360


def test_the_waffle_records_the_files_topics_and_drives_as_commanded(waffle_sdf, tmp_path):
    scenario = tmp_path / "straight.yaml"
    scenario.write_text(
        "name: straight\nkind: teleop\nstart: [0.0, 0.0, 0.0]\n"
        "commands:\n  - {duration: 3.0, cmd: [0.3, 0.0, 0.0]}\n  - {duration: 2.0, cmd: [0.0, 0.0, 0.5]}\nhold: 0.5\n"
    )
    out = tmp_path / "waffle.mcap"
    res = record(prepare("walled_room", str(waffle_sdf), str(scenario)), out, progress=False, sensor_worker=False)
    for topic in ("/scan", "/imu", "/odom", "/tf", "/tf_static", "/joint_states", "/odom/ground_truth"):
        assert res.topics[topic][1] > 0, topic
    assert res.topics["/scan"][1] == int(res.sim_s * 5) + 1  # 5 Hz, from t = 0
    assert any("intel_realsense_r200_depth (depth)" in n for n in res.notes)
    with open_log(out) as r:
        scan = next(iter(r.messages(["/scan"]))).msg
        odom = [(e.log_time_ns if hasattr(e, "log_time_ns") else 0, e.msg) for e in r.messages(["/odom"])]
        truth = [e.msg for e in r.messages(["/odom/ground_truth"])]
        static = next(iter(r.messages(["/tf_static"]))).msg
        joints = [e.msg for e in r.messages(["/joint_states"])]
    assert scan.header.frame_id == "base_scan" and len(scan.ranges) == 360
    assert odom[0][1].header.frame_id == "odom" and odom[0][1].child_frame_id == "base_footprint"
    assert {(t.header.frame_id, t.child_frame_id) for t in static.transforms} >= {
        ("base_footprint", "base_link"),
        ("base_link", "base_scan"),
        ("base_link", "imu_link"),
    }
    assert list(joints[-1].name) == ["wheel_left_joint", "wheel_right_joint"]
    # 3 s forward at 0.3 m/s: the true speed at its end, and the distance along x
    at_3s = truth[int(3.0 * 30 * 0.95)]  # odometry at 28.6 Hz (35 ms periods)
    assert at_3s.twist.twist.linear.x == pytest.approx(0.3, rel=0.1)
    p = at_3s.pose.pose.position
    assert 0.7 < p.x < 0.95 and abs(p.y) < 0.02
    # then 2 s turning left at 0.5 rad/s: the yaw grows in the commanded direction
    q = truth[-1].pose.pose.orientation
    yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
    assert 0.7 < yaw < 1.1
    # the wheels' odometry follows the truth
    last = odom[-1][1].pose.pose.position
    assert last.x == pytest.approx(truth[-1].pose.pose.position.x, abs=0.08)


# ---------------------------------------------------------------- bad input


def _record(tmp_path: Path, robot: Path, *extra: str) -> tuple[int, Path]:
    out = tmp_path / "out.mcap"
    code = main(
        [
            "-q",
            "record",
            "--robot",
            str(robot),
            "--world",
            "walled_room",
            "--scenario",
            "teleop",
            *extra,
            "-o",
            str(out),
        ]
    )
    return code, out


URDF_HEAD = '<?xml version="1.0"?>\n<robot name="bad">\n'


def _refused_urdf(tmp_path: Path, capsys, body: str) -> str:
    """Record with the URDF ``body`` (as bad.urdf, an omni drive): it must be refused, nothing written; the error."""
    urdf = tmp_path / "bad.urdf"
    urdf.write_text(URDF_HEAD + body + "</robot>\n")
    code, out = _record(tmp_path, urdf, "--drive", "omni")
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    return err


@pytest.mark.parametrize(
    ("content", "said"),
    [
        (b"", "has no volume (0 vertices)"),  # an empty STL
        (
            b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 0 nan\nendloop\nendfacet\nendsolid\n",
            "cannot be read",
        ),
        (b"\0" * 80 + (2**31 - 1).to_bytes(4, "little") + b"\0" * 50, "has no volume"),  # claims 2^31 triangles
        ("fifo", "is not a regular file"),
        (None, "no such file"),
    ],
)
def test_a_collision_mesh_that_is_no_mesh_names_the_file_and_the_link(tmp_path, capsys, content, said):
    mesh = tmp_path / "meshes" / "body.stl"
    mesh.parent.mkdir()
    if content == "fifo":
        os.mkfifo(mesh)
    elif content is not None:
        mesh.write_bytes(content)
    err = _refused_urdf(
        tmp_path,
        capsys,
        '<link name="base_link"><collision><geometry><mesh filename="meshes/body.stl"/></geometry></collision></link>\n',
    )
    assert "link 'base_link'" in err and "collision mesh" in err and "body.stl" in err and said in err
    assert len(err.strip().splitlines()) == 1


def test_a_xacro_error_names_the_file_and_the_line(tmp_path, capsys):
    xacro = tmp_path / "bad.urdf.xacro"
    xacro.write_text(
        '<?xml version="1.0"?>\n<robot name="bad" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'
        '  <link name="base_link"/>\n  <joint name="j" type="fixed">\n'
        '    <origin xyz="0 0 ${undefined_height}"/>\n  </joint>\n</robot>\n'
    )
    code, out = _record(tmp_path, xacro)
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    assert f"{xacro}:5: xacro error:" in err and "undefined_height" in err


XACRO_HEAD = '<?xml version="1.0"?>\n<robot name="bad" xmlns:xacro="http://www.ros.org/wiki/xacro">\n'


def test_a_xacro_argument_without_a_value_and_a_missing_package_are_said_once_with_their_line(tmp_path, capsys):
    """xacro's 'Undefined substitution argument prefix' gains the line and the option that gives it; a $(find)
    of a package on no path was said twice, behind a Python class name."""
    needs = tmp_path / "needs.urdf.xacro"
    needs.write_text(
        XACRO_HEAD + '  <xacro:arg name="prefix" default=""/>\n  <link name="$(arg prefixx)base"/>\n</robot>\n'
    )
    code, _ = _record(tmp_path, needs)
    err = capsys.readouterr().err
    assert code == 2
    assert f"{needs}:4: xacro error: argument 'prefixx' has no value and no default: give it with --robot-arg " in err
    finds = tmp_path / "finds.urdf.xacro"
    finds.write_text(XACRO_HEAD + '  <xacro:include filename="$(find nosuchpkg)/urdf/part.xacro"/>\n</robot>\n')
    code, _ = _record(tmp_path, finds)
    err = capsys.readouterr().err
    assert code == 2 and err.count("package 'nosuchpkg' not found") == 1 and "<class" not in err, err
    assert f"{finds}:3: xacro error: package 'nosuchpkg' not found (searched " in err


def test_a_malformed_xacro_names_the_line(tmp_path, capsys):
    xacro = tmp_path / "bad.sdf.xacro"
    xacro.write_text('<?xml version="1.0"?>\n<sdf version="1.6">\n  <model name="m">\n  </modle>\n</sdf>\n')
    code, out = _record(tmp_path, xacro)
    assert code == 2 and not out.exists()
    assert f"{xacro}:4" in capsys.readouterr().err


def test_no_drive_plugin_lists_the_understood_ones(nav2_sim, tmp_path, capsys):
    code, out = _record(tmp_path, nav2_sim / "nav2_minimal_tb3_sim" / "urdf" / "turtlebot3_waffle.urdf")
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    assert "libgazebo_ros_diff_drive.so" in err and "--drive" in err


def test_a_sensor_with_zero_samples_is_an_error(waffle_sdf, tmp_path, capsys):
    bad = tmp_path / "zero.sdf.xacro"
    bad.write_text(waffle_sdf.read_text().replace("<samples>360</samples>", "<samples>0</samples>"))
    code, out = _record(tmp_path, bad, "--package-path", str(waffle_sdf.parents[2]))
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    assert "hls_lfcd_lds" in err and "0 horizontal" in err


def test_robot_arg_needs_name_and_value(waffle_sdf, tmp_path, capsys):
    code, out = _record(tmp_path, waffle_sdf, "--robot-arg", "namespace=/x")
    assert code == 2 and not out.exists()
    assert "NAME:=VALUE" in capsys.readouterr().err


def _drive(robot, vx: float, wz: float, seconds: float = 3.0) -> tuple[float, float, float]:
    """The robot on its wheels' servos in an open world: (speed m/s, turn rate rad/s, pitch range deg) after 1 s."""
    import mujoco

    from navlog.recorder.sim import add_to_spec
    from navlog.recorder.world import build_spec, load_world

    spec = build_spec(load_world("indoor_room"))
    add_to_spec(spec, robot, (-1.5, -1.5, 0.0))
    m = spec.compile()
    d = mujoco.MjData(m)
    half, r = robot.drive.wheel_separation / 2, robot.drive.wheel_radius
    body = m.body(robot.model.root).id
    steps, settle = int(round((1.0 + seconds) / m.opt.timestep)), int(round(1.0 / m.opt.timestep))
    pitches = []
    for i in range(steps):
        d.ctrl[m.actuator("act_wheel_left").id] = (vx - wz * half) / r
        d.ctrl[m.actuator("act_wheel_right").id] = (vx + wz * half) / r
        mujoco.mj_step(m, d)
        w, x, y, z = d.xquat[body]
        if i == settle:
            start, yaw0 = d.xpos[body][:2].copy(), math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        if i > settle:
            pitches.append(math.degrees(math.asin(2 * (w * y - z * x))))
    w, x, y, z = d.xquat[body]
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    speed = float(np.hypot(*(d.xpos[body][:2] - start))) / seconds
    return speed, (yaw - yaw0) / seconds, max(pitches) - min(pitches)


def test_casters_slide_without_friction_so_wheels_reach_the_commanded_speeds(waffle_sdf, tb4, caplog):
    """The casters' contact takes their frictionless settings, not the floor's friction (MuJoCo's pair
    rule takes the larger of the two unless the caster has priority): the TurtleBot4, on one front
    caster, no longer rocks and stalls (it made 0.28 m/s of 0.4), the Waffle turns at the commanded rate
    (it made 0.42-0.47 rad/s of 0.5)."""
    caplog.set_level(logging.ERROR)
    speed, _, pitch_range = _drive(load_robot(str(tb4)), 0.4, 0.0)
    assert speed == pytest.approx(0.4, rel=0.02) and pitch_range < 0.5
    _, turn, _ = _drive(load_robot(str(waffle_sdf)), 0.0, 0.5)
    assert turn == pytest.approx(0.5, rel=0.03)


# ---------------------------------------------------------------- nested models and includes

LIDAR_MODEL = """<?xml version="1.0"?>
<sdf version="1.9"><model name="mini_lidar"><pose>5 5 5 0 0 0</pose>
  <link name="link"><pose>0 0 0.05 0 0 0</pose>
    <collision name="c"><geometry><cylinder><radius>0.03</radius><length>0.04</length></cylinder></geometry></collision>
    <sensor name="ray" type="gpu_lidar"><pose>0.01 0 0.02 0 0 0</pose><update_rate>10</update_rate>
      <topic>scan</topic><lidar><scan><horizontal><samples>180</samples><min_angle>-1.5708</min_angle>
      <max_angle>1.5708</max_angle></horizontal></scan><range><min>0.1</min><max>6</max></range></lidar></sensor>
  </link>
</model></sdf>
"""
NESTED_ROBOT = """<?xml version="1.0"?>
<sdf version="1.9"><model name="bot">
  <link name="base_link"><pose>0 0 0.06 0 0 0</pose>
    <collision name="body"><geometry><box><size>0.3 0.2 0.06</size></box></geometry></collision></link>
  <link name="wl"><pose>0 0.12 0.04 -1.5708 0 0</pose>
    <collision name="c"><geometry><cylinder><radius>0.04</radius><length>0.02</length></cylinder></geometry></collision></link>
  <link name="wr"><pose>0 -0.12 0.04 -1.5708 0 0</pose>
    <collision name="c"><geometry><cylinder><radius>0.04</radius><length>0.02</length></cylinder></geometry></collision></link>
  <joint name="wl_joint" type="revolute"><parent>base_link</parent><child>wl</child><axis><xyz>0 0 1</xyz></axis></joint>
  <joint name="wr_joint" type="revolute"><parent>base_link</parent><child>wr</child><axis><xyz>0 0 1</xyz></axis></joint>
  <model name="outer"><pose>-0.1 0 0 0 0 1.5707963267948966</pose>
    <model name="inner"><pose>0.05 0 0 0 0 0</pose>
      <link name="ball"><pose>0 0 0.02 0 0 0</pose>
        <collision name="c"><geometry><sphere><radius>0.02</radius></sphere></geometry></collision></link>
    </model>
  </model>
  <include><uri>model://mini_lidar</uri><name>lidar</name><pose>0.1 0 0.12 0 0 1.5707963267948966</pose></include>
  <joint name="caster_joint" type="fixed"><parent>base_link</parent><child>outer::inner::ball</child></joint>
  <joint name="lidar_joint" type="fixed"><parent>base_link</parent><child>lidar::link</child></joint>
  <plugin filename="gz-sim-diff-drive-system" name="gz::sim::systems::DiffDrive">
    <left_joint>wl_joint</left_joint><right_joint>wr_joint</right_joint></plugin>
</model></sdf>
"""


def test_nested_models_and_includes_are_scoped_and_posed_as_gz_sim_does(tmp_path, monkeypatch):
    """The include's pose (0.1, 0, 0.12, yaw 90 deg) replaces the model's own (5, 5, 5); its link sits 0.05 m up
    in it, its sensor 0.01 m ahead and 0.02 m up of the link, turned with the include: the laser at (0.1, 0.01,
    0.19) in the model, 0.13 m above base_link (at 0.06 m). outer (-0.1, 0, 0, yaw 90) > inner (0.05, 0, 0) >
    ball (0, 0, 0.02): the ball at (-0.1, 0.05, 0.02), -0.04 m below base_link."""
    models = tmp_path / "models"
    (models / "mini_lidar").mkdir(parents=True)
    (models / "mini_lidar" / "model.config").write_text('<model><sdf version="1.9">model.sdf</sdf></model>')
    (models / "mini_lidar" / "model.sdf").write_text(LIDAR_MODEL)
    robot_file = tmp_path / "bot.sdf"
    robot_file.write_text(NESTED_ROBOT)
    monkeypatch.setenv("GZ_SIM_RESOURCE_PATH", str(models))
    robot = describe(robot_file)
    names = [link.name for link in robot.model.links]
    assert names[0] == "base_link" and {"outer::inner::ball", "lidar::link"} <= set(names)
    static = {(f.parent, f.child): f.pose for f in robot.model.static_frames}
    ball = static[("base_link", "outer::inner::ball")]
    assert ball[:3] == pytest.approx((-0.1, 0.05, 0.02 - 0.06), abs=1e-9)
    # the laser's frame is its link, posed where the sensor sits (module docstring of description)
    lidar = static[("base_link", "lidar::link")]
    assert lidar[:3] == pytest.approx((0.1, 0.01, 0.19 - 0.06), abs=1e-9)
    assert 2 * math.atan2(lidar[5], lidar[6]) == pytest.approx(math.pi / 2, abs=1e-9)
    scan = robot.scan
    assert scan is not None and scan.frame == "lidar::link" and scan.samples == 180
    assert scan.mount == pytest.approx((0.1, 0.01, 0.13, 0.0, 0.0, math.pi / 2), abs=1e-9)
    assert robot.drive.wheel_separation == pytest.approx(0.24) and robot.drive.wheel_radius == pytest.approx(0.04)


def test_a_joint_to_an_unscoped_nested_link_names_the_scoped_form(tmp_path, monkeypatch):
    models = tmp_path / "models"
    (models / "mini_lidar").mkdir(parents=True)
    (models / "mini_lidar" / "model.config").write_text('<model><sdf version="1.9">model.sdf</sdf></model>')
    (models / "mini_lidar" / "model.sdf").write_text(LIDAR_MODEL)
    bad = tmp_path / "bot.sdf"
    bad.write_text(NESTED_ROBOT.replace("<child>lidar::link</child>", "<child>link</child>"))
    monkeypatch.setenv("GZ_SIM_RESOURCE_PATH", str(models))
    with pytest.raises(ConfigError, match=r"bot\.sdf: joint 'lidar_joint' joins 'base_link' to 'link'.*MODEL::LINK"):
        describe(bad)


def test_a_model_that_includes_itself_is_an_error_naming_the_chain(tmp_path, monkeypatch):
    """mini_lidar includes loop_a, which includes mini_lidar again: a ConfigError naming both files, not a
    RecursionError."""
    models = tmp_path / "models"
    for name, text in {
        "mini_lidar": LIDAR_MODEL.replace(
            "</model></sdf>", "<include><uri>model://loop_a</uri></include></model></sdf>"
        ),
        "loop_a": '<sdf version="1.9"><model name="loop_a"><include><uri>model://mini_lidar</uri></include></model></sdf>',
    }.items():
        (models / name).mkdir(parents=True)
        (models / name / "model.config").write_text('<model><sdf version="1.9">model.sdf</sdf></model>')
        (models / name / "model.sdf").write_text(text)
    robot_file = tmp_path / "bot.sdf"
    robot_file.write_text(NESTED_ROBOT)
    monkeypatch.setenv("GZ_SIM_RESOURCE_PATH", str(models))
    with pytest.raises(
        ConfigError, match=r"loop_a/model\.sdf: <include> model://mini_lidar: includes itself \(.*bot\.sdf -> "
    ):
        describe(robot_file)


def test_an_axis_expressed_in_the_model_is_the_declaring_models_frame(tmp_path, monkeypatch):
    """The top model's joint turns lidar::link (its include yawed 90 deg) about the top model's y axis
    (``expressed_in="__model__"``): in the link's own frame that is its x axis, not the include's y."""
    models = tmp_path / "models"
    (models / "mini_lidar").mkdir(parents=True)
    (models / "mini_lidar" / "model.config").write_text('<model><sdf version="1.9">model.sdf</sdf></model>')
    (models / "mini_lidar" / "model.sdf").write_text(LIDAR_MODEL)
    robot_file = tmp_path / "bot.sdf"
    robot_file.write_text(
        NESTED_ROBOT.replace(
            '<joint name="lidar_joint" type="fixed"><parent>base_link</parent><child>lidar::link</child></joint>',
            '<joint name="lidar_joint" type="revolute"><parent>base_link</parent><child>lidar::link</child>'
            '<axis><xyz expressed_in="__model__">0 1 0</xyz></axis></joint>',
        )
    )
    monkeypatch.setenv("GZ_SIM_RESOURCE_PATH", str(models))
    link = next(link for link in describe(robot_file).model.links if link.name == "lidar::link")
    assert link.joint_type == "revolute"
    assert link.axis == pytest.approx((1.0, 0.0, 0.0), abs=1e-6)


def _wheely(tmp_path: Path, base_inertial: str) -> Path:
    """The two-wheeled robot of ``tests.recorder.descriptions`` with its base link's ``<inertial>`` replaced."""
    base = '<inertial><mass value="4.0"/><inertia ixx="0.03" iyy="0.04" izz="0.05" ixy="0" ixz="0" iyz="0"/></inertial>'
    assert base in ROBOT
    path = tmp_path / "wheely.urdf"
    path.write_text(ROBOT.replace("PLUGIN", GZ_PLUGIN).replace(base, base_inertial))
    return path


@pytest.mark.parametrize(
    ("inertial", "named"),
    [
        ('<inertial><mass value="four"/></inertial>', "<mass>"),
        ('<inertial><mass value="-4"/></inertial>', "<mass> must be zero or more"),
        ('<inertial><mass value="4"/><inertia ixx="nan" iyy="0.04" izz="0.05"/></inertial>', "<inertia ixx>"),
        (
            '<inertial><mass value="4"/><inertia ixx="0.03" iyy="0.04" izz="0.05" ixy="0.2"/></inertial>',
            "no rigid body",
        ),
    ],
)
def test_an_inertial_no_body_has_names_the_link_and_the_value(tmp_path, capsys, inertial, named):
    code, out = _record(tmp_path, _wheely(tmp_path, inertial))
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    assert "wheely.urdf: link 'base_link'" in err and named in err
    assert len(err.strip().splitlines()) == 1


def test_an_inertia_above_the_triangle_inequality_is_evened_out_and_reported(tmp_path):
    # izz = 0.1 > ixx + iyy = 0.07: what CAD exports after rounding; Gazebo loads it, MuJoCo refuses it as it is
    urdf = _wheely(tmp_path, '<inertial><mass value="4.0"/><inertia ixx="0.03" iyy="0.04" izz="0.1"/></inertial>')
    robot = describe(urdf)
    assert robot.model is not None
    base = robot.model.link("base_link").inertial
    assert base is not None and base.unbalanced
    assert np.allclose(base.principal_moments(), [0.03, 0.04, 0.1])
    assert not any(link.inertial.unbalanced for link in robot.model.links[1:] if link.inertial is not None)
    setup = prepare("indoor_room", str(urdf), "teleop")
    assert any("evened out: base_link" in note for note in setup.notes())
    res = record(setup, tmp_path / "even.mcap", progress=False, sensor_worker=False)
    assert res.sim_s > 1.0 and any("evened out: base_link" in note for note in res.notes)


def test_a_robot_whose_physics_diverges_stops_the_recording_naming_the_link(tmp_path, capsys, monkeypatch):
    # a 1e9 kg base with the inertia of a gram: the wheel servos' gain follows the mass, the first step explodes
    monkeypatch.chdir(tmp_path)
    urdf = _wheely(tmp_path, '<inertial><mass value="1e9"/><inertia ixx="1e-6" iyy="1e-6" izz="1e-6"/></inertial>')
    out = tmp_path / "out.mcap"
    code = main(
        ["-q", "record", "--robot", str(urdf), "--world", "indoor_room", "--scenario", "teleop", "-o", str(out)]
    )
    err = capsys.readouterr().err
    assert code == 2 and not out.exists() and not list(tmp_path.glob("out.mcap*"))
    line = next(line for line in err.splitlines() if "error:" in line)
    assert "diverged at t = 0.005 s" in line and "link 'base_link'" in line and "wheely.urdf" in line
    assert not (tmp_path / "MUJOCO_LOG.TXT").exists()  # MuJoCo's warning went to the log, not to a file here


def test_a_cylinder_radius_that_is_no_number_names_the_collision(tmp_path, capsys):
    robot = _wheely(tmp_path, "").read_text().replace('radius="0.05" length="0.03"', 'radius="wide" length="0.03"', 1)
    (tmp_path / "wheely.urdf").write_text(robot)
    code, out = _record(tmp_path, tmp_path / "wheely.urdf")
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    assert "link 'wheel_left'" in err and "cylinder radius" in err and "'wide'" in err


def test_two_collisions_of_a_link_named_alike_are_both_simulated(tmp_path):
    box = '<collision name="c"><origin xyz="0 0 0.07"/><geometry><box size="0.3 0.24 0.08"/></geometry></collision>'
    roof = '<collision name="c"><origin xyz="0 0 0.2"/><geometry><box size="0.1 0.1 0.1"/></geometry></collision>'
    urdf = _wheely(
        tmp_path,
        '<inertial><mass value="4.0"/><inertia ixx="0.03" iyy="0.04" izz="0.05"/></inertial>' + box + roof,
    )
    setup = prepare("indoor_room", str(urdf), "teleop")
    from navlog.recorder.sim import SimNode, SimOptions

    sim = SimNode(setup.world, setup.robot, SimOptions(sensor_worker=False))
    try:
        names = [sim.model.geom(i).name for i in range(sim.model.ngeom)]
    finally:
        sim.close()
    assert {"base_link/c#0", "base_link/c#1"} <= set(names)


def test_a_drive_with_wheels_of_no_size_is_an_error_naming_the_plugin(tmp_path, capsys):
    robot = _wheely(tmp_path, "").read_text()
    (tmp_path / "wheely.urdf").write_text(
        robot.replace("<wheel_radius>0.05</wheel_radius>", "<wheel_radius>0</wheel_radius>")
    )
    code, out = _record(tmp_path, tmp_path / "wheely.urdf")
    err = capsys.readouterr().err
    assert code == 2 and not out.exists()
    assert (
        "wheely.urdf: the diff drive's wheel radius (0 m) must be positive" in err and "gz-sim-diff-drive-system" in err
    )


@pytest.mark.parametrize(
    ("spoil", "found"),
    [
        (lambda d: d.qvel.__setitem__(slice(None), 1e11), "a velocity"),  # MuJoCo's BADQVEL
        (lambda d: d.qpos.__setitem__(7, math.nan), "a position of joint 'wheel_left_joint'"),  # BADQPOS
    ],
)
def test_every_kind_of_divergence_mujoco_resets_on_stops_the_simulation(tmp_path, spoil, found):
    from navlog.errors import SimulationError
    from navlog.recorder.sim import SimNode, SimOptions

    setup = prepare("indoor_room", str(_wheely(tmp_path, "")), "teleop")
    sim = SimNode(setup.world, setup.robot, SimOptions(sensor_worker=False))
    try:
        spoil(sim.data)
        with pytest.raises(SimulationError, match=found):
            sim._tick(5_000_000)
    finally:
        sim.close()


def test_two_mesh_collisions_of_a_link_named_alike_are_both_simulated(tmp_path):
    import trimesh

    trimesh.creation.box(extents=(0.1, 0.1, 0.1)).export(tmp_path / "box.stl")
    mesh = '<collision name="m"><origin xyz="0 0 {z}"/><geometry><mesh filename="box.stl"/></geometry></collision>'
    urdf = _wheely(
        tmp_path,
        '<inertial><mass value="4.0"/><inertia ixx="0.03" iyy="0.04" izz="0.05"/></inertial>'
        + mesh.format(z=0.15)
        + mesh.format(z=0.3),
    )
    setup = prepare("indoor_room", str(urdf), "teleop")
    from navlog.recorder.sim import SimNode, SimOptions

    sim = SimNode(setup.world, setup.robot, SimOptions(sensor_worker=False))
    try:
        names = [sim.model.geom(i).name for i in range(sim.model.ngeom)]
        meshes = [sim.model.mesh(i).name for i in range(sim.model.nmesh)]
    finally:
        sim.close()
    assert {"base_link/m#0", "base_link/m#1"} <= set(names)
    assert {"mesh:base_link/m#0", "mesh:base_link/m#1"} <= set(meshes)


def test_a_joint_whose_child_link_is_not_in_the_file_names_the_joint_and_the_link(tmp_path, capsys):
    """A misspelt child link left its joint out, and the error said the robot had two root links; it names the
    joint and the link, and the closest link of the file."""
    err = _refused_urdf(
        tmp_path,
        capsys,
        '<link name="base_link"/>\n<link name="caster"/>\n'
        '<joint name="caster_joint" type="fixed"><parent link="base_link"/><child link="castor"/></joint>\n',
    )
    assert (
        f"{tmp_path / 'bad.urdf'}: joint 'caster_joint': child link 'castor' is not in the file (did you mean 'caster'?)"
        in err
    )


def test_robot_args_and_a_drive_for_a_robot_yaml_without_a_description_are_refused(tmp_path, capsys):
    """--robot-arg and --drive change a robot from a description file; a robot YAML that is the whole robot
    ignored them without a word (a plain URDF refuses a xacro argument)."""
    for extra, said in (
        (["--drive", "diff_drive"], "--drive diff_drive"),
        (["--robot-arg", "p:=r1_"], "--robot-arg p:=r1_"),
    ):
        code, out = _record(tmp_path, Path("kibot"), *extra)
        err = capsys.readouterr().err
        assert code == 2 and not out.exists() and f"kibot.yaml: {said}: for a robot from a description file" in err
