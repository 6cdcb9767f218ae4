"""A robot without a footprint frame gives one pose for odom -> base on /odom and /tf; the IMU's
low-pass filter takes out the spikes of contacts resolved in one physics step."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from navlog.recorder.description import load_robot
from navlog.recorder.sim import ImuLowPass, SimNode, SimOptions
from navlog.recorder.world import load_world
from navlog.replay import messages
from navlog.replay.runtime.executor import Executor, Node
from tests.recorder.test_sensors import run_sim


def test_simple_robot_odom_and_tf_give_one_pose():
    # simple_robot has no base_footprint: /odom and /tf both carry odom -> base_link (they used to differ:
    # /odom at z = 0 and yaw only, /tf at the axle's height with the chassis' tilt)
    sim, got = run_sim(robot="simple_robot", until_ns=2_000_000_000, cmd=(0.3, 0.0, 0.4))
    tf = {}
    for ns, msg in got["/tf"]:
        for t in msg.transforms:
            if (t.header.frame_id, t.child_frame_id) == ("simple_robot/odom", "simple_robot/base_link"):
                tf[ns] = t.transform
    assert len(got["/odom"]) == len(tf) == 101  # 50 Hz over 0..2 s
    for ns, odom in got["/odom"]:
        p, q, t = odom.pose.pose.position, odom.pose.pose.orientation, tf[ns]
        assert (p.x, p.y, p.z) == (t.translation.x, t.translation.y, t.translation.z)
        assert (q.x, q.y, q.z, q.w) == (t.rotation.x, t.rotation.y, t.rotation.z, t.rotation.w)
    _, last = got["/odom"][-1]
    assert last.pose.pose.position.z == pytest.approx(0.1008, abs=5e-4)  # the axle: wheel radius 0.1 m x 1.01


def _imu(bandwidth: float) -> np.ndarray:
    """(t, ax, az) of simple_robot's IMU over 6 s: 0.5 m/s ahead from rest, a turn in place, a stop."""
    robot = load_robot("simple_robot")
    robot = dataclasses.replace(robot, imu=dataclasses.replace(robot.imu, bandwidth=bandwidth))
    ex = Executor()
    ex.add_node(SimNode(load_world("indoor_room"), robot, SimOptions(noise=False)), source=True)
    got = []

    def command(t: int) -> tuple[float, float, float]:
        return (0.5, 0.0, 0.0) if t < 2_000_000_000 else ((0.0, 0.0, 1.0) if t < 4_000_000_000 else (0.0, 0.0, 0.0))

    class Driver(Node):
        def setup(self) -> None:
            self.subscribe("/imu/data", lambda m, t: got.append((t, m.linear_acceleration.x, m.linear_acceleration.z)))
            self.create_timer(
                50_000_000, lambda t: self.publish("/cmd_vel", messages.TWIST, messages.twist(*command(t))), 0
            )

    ex.add_node(Driver())
    ex.run(until_ns=6_000_000_000)
    return np.array(got)


def test_imu_filter_takes_out_the_caster_spikes_and_keeps_the_mean():
    raw, filtered = _imu(0.0), _imu(20.0)
    assert len(raw) == len(filtered) == 1201  # 200 Hz over 0..6 s
    spike = np.hypot(raw[:, 1], raw[:, 2] - 9.81)
    smooth = np.hypot(filtered[:, 1], filtered[:, 2] - 9.81)
    # the chassis rocks on its axle and its casters hit the floor: 28 m/s² in one raw sample (nearly 3 g)
    assert spike.max() > 25.0
    assert smooth.max() < 11.0
    # what the robot does is kept: the mean specific force within 2 cm/s²
    assert filtered[:, 1].mean() == pytest.approx(raw[:, 1].mean(), abs=0.02)
    assert filtered[:, 2].mean() == pytest.approx(raw[:, 2].mean(), abs=0.02)


def test_imu_low_pass_averages_the_physics_steps_then_filters():
    lpf = ImuLowPass(20.0, 0.005, 0, 3)
    data = np.zeros(6)
    lpf.start(data)
    assert lpf.value == (0.0,) * 6
    for step in (0.0, 2.0):  # two physics steps in the tick: their mean is 1
        lpf.add(np.full(6, step))
    lpf.tick()
    alpha = 1.0 - math.exp(-2.0 * math.pi * 20.0 * 0.005)  # 0.4665
    assert lpf.value == pytest.approx((alpha,) * 6)
    assert alpha == pytest.approx(0.46651, abs=1e-5)
    lpf.add(np.full(6, 1.0))
    lpf.tick()
    assert lpf.value == pytest.approx((alpha + alpha * (1 - alpha),) * 6)


def test_imu_bandwidth_is_checked():
    with pytest.raises(ValueError, match="imu.bandwidth"):
        dataclasses.replace(load_robot("simple_robot").imu, bandwidth=-1.0)
    assert load_robot("simple_robot").imu.bandwidth == 20.0 and load_robot("go2").imu.bandwidth == 0.0
