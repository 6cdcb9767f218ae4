"""The velocity smoother node on the executor: KiBot's parameters, ramps per tick, timeout, Twist and TwistStamped."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import pytest

from navlog.replay import messages as m
from navlog.replay.nav2 import load_nav2_params
from navlog.replay.nav2.velocity_smoother import VelocitySmootherParams
from navlog.replay.nodes import VelocitySmootherNode
from navlog.replay.runtime.executor import Envelope, Executor, Node

DATA = Path(__file__).resolve().parents[1] / "nav2" / "data"
MS = 1_000_000
KIBOT = VelocitySmootherParams(
    max_velocity=(0.45, 0.0, 1.2),
    min_velocity=(-0.20, 0.0, -1.2),
    max_accel=(0.8, 0.0, 1.5),
    max_decel=(-0.8, 0.0, -1.5),
)


class Capture(Node):
    """Records (time, message) of every message on one topic."""

    name = "capture"

    def __init__(self, topic: str) -> None:
        super().__init__()
        self.topic, self.got = topic, []

    def setup(self) -> None:
        self.subscribe(self.topic, lambda msg, t: self.got.append((t, msg)))


def _stamped(ns: int, vx: float, wz: float = 0.0, frame: str = "base_link"):
    return m.msg_class(m.TWIST_STAMPED)(m.header(ns, frame), m.twist(vx, 0.0, wz))


def _run(params, commands, *, end_ms=3000, extra=(), node_kwargs=None):
    """Run the node over ``commands`` [(ms, msg)] (Twist or TwistStamped on /cmd_vel_nav); its outputs."""
    ex = Executor(start_ns=0)
    envs = [Envelope("/cmd_vel_nav", type(msg).__msgtype__, t * MS, msg) for t, msg in commands]
    envs += list(extra)
    envs.append(Envelope("/clock", m.CLOCK, end_ms * MS, m.clock(end_ms * MS)))  # keeps the run going
    ex.add_source(sorted(envs, key=lambda e: e.time_ns))
    node = ex.add_node(VelocitySmootherNode(params, **(node_kwargs or {})))
    cap = ex.add_node(Capture("/cmd_vel_smoothed"))
    ex.run()
    assert isinstance(node, VelocitySmootherNode) and isinstance(cap, Capture)
    return node, cap.got


def test_kibot_parameters_build_the_node():
    nav2 = load_nav2_params(DATA / "kibot_nav2_fragments.yaml").require_valid(("velocity_smoother",))
    vs = nav2.velocity_smoother
    assert vs == KIBOT
    node = VelocitySmootherNode(vs)
    assert (node.period_ns, node.input_topics(), node.output_type) == (50 * MS, ["/cmd_vel_nav"], m.TWIST)


def test_step_ramps_at_kibot_accel_then_times_out_and_falls_silent():
    node, got = _run(KIBOT, [(0, m.twist(0.45, 0.0, 0.0))])
    times = [t // MS for t, _ in got]
    vx = [msg.linear.x for _, msg in got]
    # 0.8 m/s^2 at 20 Hz: +0.04 per tick to the 0.45 limit, held until 1.0 s after the command
    up = [0.04 * k for k in range(1, 12)] + [0.45] * 10
    # 1.05 s: more than velocity_timeout (1.0 s) since the command: zero is commanded, -0.04 per tick
    down = [0.45 - 0.04 * k for k in range(1, 12)] + [0.0]
    assert vx == pytest.approx(up + down, abs=1e-12)
    assert times == list(range(0, 1650, 50))  # one message per 50 ms tick, none after the zero
    assert vx[-1] == 0.0 and node.published == 33 and node.skipped_counts() == {}
    assert all(type(msg).__msgtype__ == m.TWIST for _, msg in got)


def test_command_stream_resets_the_timeout():
    stream = [(t, m.twist(0.2, 0.0, -1.5)) for t in range(0, 501, 100)]  # 10 Hz until 0.5 s
    _, got = _run(KIBOT, stream)
    vx = [msg.linear.x for _, msg in got]
    wz = [msg.angular.z for _, msg in got]
    assert vx[:5] == pytest.approx([0.04, 0.08, 0.12, 0.16, 0.2], abs=1e-12)
    # wz: -1.5 clamped to min_velocity -1.2, reached at 1.5 / 20 = 0.075 rad/s per tick
    assert wz[:17] == pytest.approx([-0.075 * k for k in range(1, 17)] + [-1.2], abs=1e-12)
    t_last = got[-1][0] // MS
    # last command at 0.5 s: the ramp down starts at 1.55 s; wz falls at 1.5 / 20 = 0.075 per tick
    first_down = next(i for i, (t, _) in enumerate(got) if t > 1500 * MS)
    assert got[first_down][0] == 1550 * MS and wz[first_down] == pytest.approx(-1.125)
    # 16 steps of 0.075 leave -3e-16 in floating point (as in Nav2): a 17th tick lands on zero, then silence
    assert wz[first_down : first_down + 15] == pytest.approx([-1.2 + 0.075 * k for k in range(1, 16)], abs=1e-12)
    assert wz[-2] == pytest.approx(0.0, abs=1e-12) and wz[-2] != 0.0
    assert (vx[-1], wz[-1]) == (0.0, 0.0) and t_last == 1550 + 16 * 50


def test_stamped_in_and_out_keeps_stamp_and_frame():
    params = replace(KIBOT, enable_stamped_cmd_vel=True)
    _, got = _run(params, [(0, _stamped(0, 0.3)), (100, m.twist(0.3, 0.0, 0.0))], end_ms=200)
    assert all(type(msg).__msgtype__ == m.TWIST_STAMPED for _, msg in got)
    stamps = [(m.to_ns(msg.header.stamp) // MS, msg.header.frame_id) for _, msg in got]
    # the TwistStamped's stamp and frame; then the unstamped Twist at 100 ms: its receive time, no frame
    assert stamps == [(0, "base_link"), (0, "base_link"), (100, ""), (100, ""), (100, "")]
    assert [msg.twist.linear.x for _, msg in got] == pytest.approx([0.04, 0.08, 0.12, 0.16, 0.2], abs=1e-12)


def test_stamped_in_twist_out_and_smoothing_time_stamps():
    _, got = _run(KIBOT, [(0, _stamped(0, 0.3))], end_ms=100)
    assert [type(msg).__msgtype__ for _, msg in got] == [m.TWIST] * 3
    params = replace(KIBOT, enable_stamped_cmd_vel=True, stamp_smoothed_velocity_with_smoothing_time=True)
    _, got = _run(params, [(0, _stamped(0, 0.3))], end_ms=100)
    assert [m.to_ns(msg.header.stamp) // MS for _, msg in got] == [0, 50, 100]


def test_nan_commands_are_skipped_and_counted():
    cmds = [(0, m.twist(0.45, 0.0, 0.0)), (20, m.twist(math.nan, 0.0, 0.0)), (30, _stamped(30 * MS, 0.1, math.inf))]
    node, got = _run(KIBOT, cmds, end_ms=200)
    assert node.skipped_counts() == {"/cmd_vel_nav: NaN or infinite commands (skipped)": 2}
    assert [msg.linear.x for _, msg in got] == pytest.approx([0.04, 0.08, 0.12, 0.16, 0.2], abs=1e-12)


def _odom(stamp_ns: int, vx: float):
    return m.odometry(stamp_ns, "odom", "base_link", (0, 0, 0), (0, 0, 0, 1), (vx, 0, 0), (0, 0, 0))


class OdomFeedback(Node):
    """Publishes /odom every 10 ms with the last smoothed command as its twist (a perfect robot)."""

    name = "odom_feedback"

    def __init__(self) -> None:
        super().__init__()
        self.vx = 0.0

    def setup(self) -> None:
        self.subscribe("/cmd_vel_smoothed", lambda msg, t: setattr(self, "vx", msg.linear.x))
        self.create_timer(10 * MS, self._tick, start_ns=10 * MS)

    def _tick(self, t: int) -> None:
        self.publish("/odom", m.ODOMETRY, _odom(t, self.vx))


def test_closed_loop_on_the_executor_nav2_vector():
    """approxClosedLoopTestTimer: 30 zero odometries, cmd 1.0 once, odometry echoing the output."""
    ex = Executor(start_ns=0)
    zero = [Envelope("/odom", m.ODOMETRY, 0, _odom(i * 10 * MS, 0.0)) for i in range(30)]  # stamps 0..290 ms
    cmd = Envelope("/cmd_vel_nav", m.TWIST, 0, m.twist(1.0, 0.0, 0.0))
    ex.add_source([*zero, cmd, Envelope("/clock", m.CLOCK, 1500 * MS, m.clock(1500 * MS))])
    node = VelocitySmootherNode(VelocitySmootherParams(feedback="CLOSED_LOOP"))
    ex.add_node(node)
    ex.add_node(OdomFeedback())
    cap = Capture("/cmd_vel_smoothed")
    ex.add_node(cap)
    ex.run(until_ns=1500 * MS)
    assert node.input_topics() == ["/cmd_vel_nav", "/odom"]
    vx = [msg.linear.x for _, msg in cap.got]
    assert 19 < len(vx) < 30
    assert vx[-1] == 0.0
    assert all(b - a < 0.126 for a, b in zip(vx, vx[1:], strict=False))  # 2.5 / 20 = 0.125
    assert all(v <= 0.5 for v in vx)
    # the first step starts from rest; the next from the mean odometry (zeros still in its 0.1 s window)
    assert vx[0] == 0.125 and 0.125 < vx[1] < 0.25


def test_replay_gives_the_same_bytes():
    cmds = [(t, m.twist(0.45 * math.sin(t / 300), 0.0, 0.9)) for t in range(0, 1200, 33)]
    runs = [_run(replace(KIBOT, scale_velocities=True), cmds)[1] for _ in range(2)]
    assert [(t, m.serialize(msg, m.TWIST)) for t, msg in runs[0]] == [
        (t, m.serialize(msg, m.TWIST)) for t, msg in runs[1]
    ]
    assert len(runs[0]) > 40
