"""The differential drives: wheels on the floor move the robot; wheel odometry drifts by the radius error."""

from __future__ import annotations

import math

import pytest

from tests.recorder.test_sensors import run_sim


def test_kibot_drives_straight_at_the_commanded_speed_and_odometry_underreads():
    sim, got = run_sim(robot="kibot", until_ns=4_000_000_000, cmd=(0.3, 0.0, 0.0))
    gt = got["/odom/ground_truth"]
    ns, last = gt[-1]
    assert last.twist.twist.linear.x == pytest.approx(0.3, abs=0.01)  # body-frame speed
    x_true = last.pose.pose.position.x
    assert 0.95 < x_true < 1.2  # 4 s at 0.3 m/s minus the start-up lag
    assert abs(last.pose.pose.position.y) < 0.01
    _, odom = got["/odom"][-1]
    # the true wheel radius is 1 % larger than the nominal one the odometry uses
    assert odom.pose.pose.position.x == pytest.approx(x_true / 1.01, rel=0.01)
    assert odom.child_frame_id == "base_footprint"


def test_simple_robot_turns_with_prefixed_frames():
    sim, got = run_sim(robot="simple_robot", until_ns=3_000_000_000, cmd=(0.0, 0.0, 0.5))
    _, last = got["/odom/ground_truth"][-1]
    q = last.pose.pose.orientation
    yaw = math.atan2(2 * (q.w * q.z + q.x * q.y), 1 - 2 * (q.y * q.y + q.z * q.z))
    assert 1.1 < yaw < 1.5  # 3 s at 0.5 rad/s minus the start-up lag
    assert last.child_frame_id == "simple_robot/base_link"
    _, odom = got["/odom"][-1]
    assert odom.header.frame_id == "simple_robot/odom" and odom.child_frame_id == "simple_robot/base_link"
    # the scan is on /lidar in the lidar frame of the article
    assert not got["/scan"]
    static = got["/tf_static"][0][1]
    assert "simple_robot/base_link/lidar" in {t.child_frame_id for t in static.transforms}


def test_a_drive_whose_wheels_have_no_size_is_refused():
    from navlog.recorder.robot import DriveConfig

    for bad in ({"wheel_radius": 0.0}, {"wheel_separation": 0.0}, {"wheel_radius_error": -1.0}):
        with pytest.raises(ValueError):
            DriveConfig("diff_drive", max_vx=0.5, max_wz=1.0, **bad)
    assert DriveConfig("diff_drive", max_vx=0.5, max_wz=1.0, wheel_radius_error=-0.5).wheel_radius == 0.1
