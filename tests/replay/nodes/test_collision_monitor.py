"""The collision monitor node on the executor: built from the KiBot and Jazzy article files, driving
at a wall in closed loop, the invalid-source stop, its events, stamped output and summary."""

from __future__ import annotations

import dataclasses
import functools
import math
from pathlib import Path

import numpy as np
import pytest

from navlog.errors import ConfigError
from navlog.replay import messages as m
from navlog.replay.geometry import rigid_inverse
from navlog.replay.nav2 import load_nav2_params, parse_nav2_text
from navlog.replay.nav2.collision_monitor import CollisionMonitor, Velocity, points_in_polygon, scan_points, to_base
from navlog.replay.nav2.costmap import robot_footprint
from navlog.replay.nodes import CollisionMonitorNode
from navlog.replay.nodes.collision_monitor import POLYGON_STAMPED, polygon_pub_topic, polygon_stamped
from navlog.replay.runtime.executor import Envelope, Executor, Node
from navlog.replay.runtime.tf import TFBuffer, relative_pose
from tests.replay.nav2.test_collision_monitor import wall_points, wall_scan
from tests.replay.pipelines.test_mapping_replay import scan_msg as mapping_scan_msg

DATA = Path(__file__).resolve().parents[1] / "nav2" / "data"
JAZZY_ARTICLE = Path(__file__).resolve().parents[3] / "config" / "nav2" / "simple_robot_jazzy.yaml"  # seed 001's file
MS = 1_000_000


def scan_msg(ns: int, ranges, frame: str):
    return mapping_scan_msg(ns, ranges, frame, rmin=0.12, rmax=6.0)  # Go2's laser limits


class WallRobot(Node):
    """A robot at x on a line driving at a wall at x = 1 m: every 50 ms it moves with the last /cmd_vel,
    publishes odom -> base TF, a scan from its base and asks for 0.45 m/s on /cmd_vel_smoothed."""

    name = "wall_robot"

    def __init__(self, base: str, odom: str = "odom", scan_topic: str = "/scan", with_scan: bool = True) -> None:
        super().__init__()
        self.base, self.odom, self.scan_topic, self.with_scan = base, odom, scan_topic, with_scan
        self.x, self.v = 0.0, 0.0
        self.outputs: list[tuple[int, float, float]] = []  # (t, x when commanded, v let through)
        self.events: list[tuple[int, str, str, float]] = []

    def setup(self) -> None:
        self.subscribe("/cmd_vel", self._on_cmd)
        self.subscribe("/navlog/events", lambda e, t: self.events.append((t, e.kind, e.detail, e.value)))
        self.create_timer(50 * MS, self._tick)

    def _on_cmd(self, msg, t: int) -> None:
        self.v = m.twist_values(msg)[0]
        self.outputs.append((t, self.x, self.v))

    def _tick(self, t: int) -> None:
        if t > 0:
            self.x += self.v * 0.05
        tf = m.transform_stamped(t, self.odom, self.base, (self.x, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0))
        self.publish("/tf", m.TF_MESSAGE, m.tf_message([tf]))
        if self.with_scan:
            self.publish(self.scan_topic, m.LASER_SCAN, scan_msg(t, wall_scan(self.x), self.base))
        self.publish("/cmd_vel_smoothed", m.TWIST, m.twist(0.45, 0.0, 0.0))


def run(node: CollisionMonitorNode, robot: WallRobot, until_s: float) -> None:
    ex = Executor()
    ex.add_node(robot, source=True)
    ex.add_node(node)
    ex.run(until_ns=int(until_s * 1e9))


def test_kibot_node_slows_the_robot_before_the_wall():
    p = load_nav2_params(DATA / "kibot_nav2_fragments.yaml")
    node = CollisionMonitorNode(p.collision_monitor, footprint=robot_footprint(p.global_costmap))
    robot = WallRobot("base_link")
    run(node, robot, 10.0)
    assert robot.outputs[0][2] == 0.45
    # closing in, the speed let through only goes down (in steps of 0.45 * 0.1 / 1.2 = 0.0375 m/s)
    reduced = [(t, x, v) for t, x, v in robot.outputs if 0.0 < v < 0.45]
    assert reduced and all(v <= prev for (_, _, prev), (_, _, v) in zip(reduced, reduced[1:], strict=False))
    front = robot.x + 0.35
    assert 0.0 < 1.0 - front <= 0.045  # wedged within one 0.1 s step of the wall at 0.45 m/s, never through it
    # the approach started once, on the footprint polygon, with Nav2's action code 3
    assert [e[1:] for e in robot.events] == [("collision_monitor_approach", "FootprintApproach", 3.0)]
    s = node.summary()
    assert s["min_time_to_collision_s"] == 0.0
    assert s["actions"]["FootprintApproach"]["approach"] == s["commands"] - sum(v == 0.45 for *_, v in robot.outputs)
    # held at zero from the first zero output to the end; zeros stop after stop_pub_timeout (1 s default)
    first_zero = next(t for t, _, v in robot.outputs if v == 0.0)
    assert s["stopped_s"] == pytest.approx(10.0 - first_zero / 1e9)
    assert s["not_published"] > 0 and robot.outputs[-1][0] - first_zero <= 1000 * MS + 50 * MS
    assert node.skipped_counts() == {}


def test_scans_beyond_the_shapes_reach_go_untransformed_and_decide_the_same():
    """A scan whose points all lie beyond ``points_reach`` gives the monitor no points: the robot driving
    at the wall from 3 m away gets, bit for bit, the commands and events of a node that transforms
    every scan, and both kinds of command occur."""
    p = load_nav2_params(DATA / "kibot_nav2_fragments.yaml")
    fp = robot_footprint(p.global_costmap)
    counted: list[int] = []

    class Counting(CollisionMonitorNode):
        def source_points(self, name: str, now: int, reach: float | None = None) -> np.ndarray | None:
            pts = super().source_points(name, now, reach)
            counted.append(-1 if pts is None else len(pts))
            return pts

    class Every(CollisionMonitorNode):
        def source_points(self, name: str, now: int, reach: float | None = None) -> np.ndarray | None:
            return super().source_points(name, now)

    robots = []
    for node in (Counting(p.collision_monitor, footprint=fp), Every(p.collision_monitor, footprint=fp)):
        robot = WallRobot("base_link")
        robot.x = -2.0
        run(node, robot, 8.0)
        robots.append((robot, node.summary()))
    (cut, cut_summary), (every, every_summary) = robots
    assert cut.outputs == every.outputs and cut.events == every.events and cut_summary == every_summary
    assert [e[1] for e in cut.events] == ["collision_monitor_approach"] and cut.outputs[-1][2] < 0.05
    # the wall 3 m ahead at first: no points; within reach (1.2 s at 0.45 m/s ahead of the footprint): all
    assert counted[0] == 0 and counted.count(0) > 20 and counted[-1] > 100 and -1 not in counted


def test_node_decisions_match_the_algorithm_at_the_same_pose():
    p = load_nav2_params(DATA / "kibot_nav2_fragments.yaml")
    fp = robot_footprint(p.global_costmap)
    node = CollisionMonitorNode(p.collision_monitor, footprint=fp)
    robot = WallRobot("base_link")
    run(node, robot, 3.0)
    for t, x, v in robot.outputs:
        cm = CollisionMonitor(p.collision_monitor, fp)
        pts = scan_points(wall_scan(x), -math.pi, 2 * math.pi / 720, 0.12, 6.0)[:, :2]
        assert cm.process(Velocity(0.45, 0.0, 0.0), t, {"scan": pts}).action.velocity.vx == pytest.approx(v, abs=1e-12)


def test_jazzy_article_node_uses_the_published_footprint_and_prefixed_frames():
    p = load_nav2_params(JAZZY_ARTICLE)
    cmp = p.collision_monitor
    node = CollisionMonitorNode(cmp, input_topic="/cmd_vel_smoothed", output_topic="/cmd_vel")
    assert "/local_costmap/published_footprint" in node.shape_topics and node.sources["scan"].topic == "lidar"
    robot = WallRobot("simple_robot/base_link", odom="simple_robot/odom", scan_topic="/lidar")

    class Footprint(Node):
        name = "footprint"

        def setup(self) -> None:
            self.create_timer(500 * MS, self._tick, start_ns=1000 * MS)

        def _tick(self, t: int) -> None:  # a 0.4 m square published in odom at the robot's pose, as a costmap does
            x = robot.x
            pts = [(x + 0.2, 0.2), (x + 0.2, -0.2), (x - 0.2, -0.2), (x - 0.2, 0.2)]
            P32 = m.msg_class("geometry_msgs/msg/Point32")
            poly = m.msg_class("geometry_msgs/msg/Polygon")(points=[P32(x=a, y=b, z=0.0) for a, b in pts])
            msg = m.msg_class("geometry_msgs/msg/PolygonStamped")(header=m.header(t, "simple_robot/odom"), polygon=poly)
            self.publish("/local_costmap/published_footprint", "geometry_msgs/msg/PolygonStamped", msg)

    ex = Executor()
    ex.add_node(robot, source=True)
    ex.add_node(Footprint(), source=True)
    ex.add_node(node)
    ex.run(until_ns=6000 * MS)
    shape = node.monitor.shapes[0]
    assert shape.vertices is not None and np.abs(shape.vertices).max() == pytest.approx(0.2)  # in base frame
    # no shape for the first second: counted, the robot passes at full speed meanwhile
    assert node.skipped_counts() == {
        "FootprintApproach: no shape on /local_costmap/published_footprint yet (the polygon cannot act)": 20
    }
    assert robot.outputs[19][2] == 0.45
    # min_points 6 and time_before_collision 1.2: the robot stops short of the wall with its 0.2 m front
    assert 0.0 < 1.0 - (robot.x + 0.2) <= 0.045


def test_missing_scan_is_an_invalid_source_stop_and_counted():
    p = load_nav2_params(DATA / "kibot_nav2_fragments.yaml")
    node = CollisionMonitorNode(p.collision_monitor, footprint=robot_footprint(p.global_costmap))
    robot = WallRobot("base_link", with_scan=False)
    run(node, robot, 1.0)
    assert all(v == 0.0 for *_, v in robot.outputs) and robot.x == 0.0
    assert [e[1:3] for e in robot.events] == [("collision_monitor_stop", "invalid source")]
    assert node.skipped_counts() == {"scan: no message on /scan yet": 21}
    assert node.summary()["actions"] == {"invalid source": {"stop": 21}}


def test_missing_transform_and_stale_scan_are_invalid_source_stops():
    p = load_nav2_params(DATA / "kibot_nav2_fragments.yaml")
    node = CollisionMonitorNode(p.collision_monitor, footprint=robot_footprint(p.global_costmap))
    ex = Executor()
    ex.add_node(node)
    tf_static = m.transform_stamped(0, "base_link", "laser", (0.1, 0.0, 0.2), (0.0, 0.0, 0.0, 1.0))
    odom = [m.transform_stamped(t * MS, "odom", "base_link", (0.0, 0.0, 0.0), (0, 0, 0, 1)) for t in (0, 50)]
    for t, topic, typename, msg in [
        (0, "/scan", m.LASER_SCAN, scan_msg(0, np.full(720, np.inf), "laser")),  # nothing in sight
        (10, "/cmd_vel_smoothed", m.TWIST, m.twist(0.3, 0.0, 0.0)),  # no TF yet: invalid source
        (20, "/tf_static", m.TF_MESSAGE, m.tf_message([tf_static])),
        (20, "/tf", m.TF_MESSAGE, m.tf_message(odom)),
        (30, "/cmd_vel_smoothed", m.TWIST, m.twist(0.3, 0.0, 0.0)),  # valid: passes
        (2100, "/cmd_vel_smoothed", m.TWIST, m.twist(0.3, 0.0, 0.0)),  # the scan is 2.1 s old > 2.0 s
    ]:
        ex.publish(Envelope(topic, typename, t * MS, msg), 0)
    got = []
    ex.subscribe("/cmd_vel", lambda msg, t: got.append(m.twist_values(msg)[0]))
    ex.run()
    assert got == [0.0, 0.3, 0.0]
    assert node.skipped_counts() == {
        "scan: data older than source_timeout 2.0 s": 1,
        "scan: no transform base_link <- laser": 1,
    }
    assert node.summary()["actions"] == {"invalid source": {"stop": 2}}


def test_stamped_output_carries_the_input_header():
    p = parse_nav2_text("""collision_monitor:
  ros__parameters:
    enable_stamped_cmd_vel: true
    source_timeout: 0.0
    polygons: [Stop]
    observation_sources: [scan]
    scan: {type: scan}
    Stop: {type: circle, radius: 0.3, action_type: stop}
""")
    node = CollisionMonitorNode(p.collision_monitor, input_topic="/in", output_topic="/out")
    ex = Executor()
    ex.add_node(node)
    got = []
    ex.subscribe("/out", lambda msg, t: got.append(msg))
    stamped = m.msg_class(m.TWIST_STAMPED)(m.header(7 * MS, "base_footprint"), m.twist(0.2, 0.0, 0.1))
    ex.publish(Envelope("/in", m.TWIST_STAMPED, 10 * MS, stamped), 0)
    ex.publish(Envelope("/in", m.TWIST, 20 * MS, m.twist(0.1, 0.0, 0.0)), 0)
    bad = m.twist(float("nan"), 0.0, 0.0)
    ex.publish(Envelope("/in", m.TWIST, 30 * MS, bad), 0)
    ex.run()
    assert [m.to_ns(g.header.stamp) for g in got] == [7 * MS, 0]
    assert [m.twist_values(g) for g in got] == [(0.2, 0.0, 0.1), (0.1, 0.0, 0.0)]
    # source_timeout 0: no scan is no stop, yet still counted
    assert node.skipped_counts() == {
        "command with NaN or infinity (ignored, as Nav2 does)": 1,
        "scan: no message on /scan yet": 2,
    }


def test_polygon_sources_are_refused_with_a_way_out():
    p = parse_nav2_text("""collision_monitor:
  ros__parameters:
    polygons: [Stop]
    observation_sources: [zones]
    zones: {type: polygon, topic: zones}
    Stop: {type: circle, radius: 0.3, action_type: stop}
""")
    with pytest.raises(ConfigError, match=r"source 'zones'.*zones.enabled: false"):
        CollisionMonitorNode(p.collision_monitor)


# ---------------------------------------------------------------- polygons for the view (visualize: true)


def _visualized(params, **changes):
    """``params`` with every polygon's ``visualize`` set (and other polygon fields changed)."""
    polys = {n: dataclasses.replace(pp, visualize=True, **changes) for n, pp in params.polygon_params.items()}
    return dataclasses.replace(params, polygon_params=polys)


class PolygonProbe(Node):
    """Records (time, frame, stamp, vertices) of PolygonStamped topics."""

    name = "polygon_probe"

    def __init__(self, topics) -> None:
        super().__init__()
        self.got: dict[str, list] = {t: [] for t in topics}

    def setup(self) -> None:
        for topic in self.got:
            self.subscribe(topic, functools.partial(self._on, topic))

    def _on(self, topic, msg, t: int) -> None:
        xy = [(p.x, p.y) for p in msg.polygon.points]
        self.got[topic].append((t, msg.header.frame_id, m.to_ns(msg.header.stamp), np.array(xy).reshape(-1, 2)))


def test_visualized_approach_polygon_and_its_predicted_collision_footprint():
    p = load_nav2_params(DATA / "kibot_nav2_fragments.yaml")
    fp = robot_footprint(p.global_costmap)
    plain = WallRobot("base_link")
    run(CollisionMonitorNode(p.collision_monitor, footprint=fp), plain, 4.0)
    node = CollisionMonitorNode(_visualized(p.collision_monitor), footprint=fp)
    robot = WallRobot("base_link")
    pred = "/navlog/collision_monitor/FootprintApproach/collision_footprint"
    probe = PolygonProbe(["/FootprintApproach", pred])
    ex = Executor()
    ex.add_node(robot, source=True)
    ex.add_node(node)
    ex.add_node(probe)
    ex.run(until_ns=4000 * MS)
    # visualizing changes no decision, no command and no event
    assert robot.outputs == plain.outputs and robot.events == plain.events
    # Nav2 publishes the polygon (in the base frame, stamped now) after every decision
    shapes = probe.got["/FootprintApproach"]
    assert [s[0] for s in shapes] == [t for t, *_ in robot.outputs] == [s[2] for s in shapes]
    outline = np.array(fp, dtype=np.float32).astype(np.float64)
    assert all(s[1] == "base_link" and np.array_equal(s[3], outline) for s in shapes)
    predicted = probe.got[pred]
    assert len(predicted) == len(shapes)
    seen = 0
    for (t, x, _), (_, frame, _, xy) in zip(robot.outputs, predicted, strict=True):
        cm = CollisionMonitor(p.collision_monitor, fp)
        ttc = cm.process(Velocity(0.45, 0.0, 0.0), t, {"scan": wall_points(x)}).collision_times["FootprintApproach"]
        if ttc < 0:
            assert xy.shape == (0, 2)  # no collision within 1.2 s: nothing predicted
            continue
        seen += 1
        # the footprint 0.45 m/s * (ttc + one 0.1 s step) ahead (where it stands if the wall is in it
        # already): it holds min_points (4) of the wall's points, one step before it held fewer
        pts = wall_points(x)
        inside_now = np.count_nonzero(points_in_polygon(outline, pts)) >= 4
        ahead = 0.0 if inside_now else 0.45 * (ttc + 0.1)
        assert frame == "base_link" and xy[:, 0] - outline[:, 0] == pytest.approx(ahead, abs=1e-6)
        assert np.count_nonzero(points_in_polygon(xy, pts)) >= 4
        assert inside_now or np.count_nonzero(points_in_polygon(xy - (0.045, 0.0), pts)) < 4
    assert seen > 10


def test_visualized_stop_and_circle_polygons_on_nav2_topics():
    p = parse_nav2_text("""collision_monitor:
  ros__parameters:
    source_timeout: 0.0
    polygons: [PolygonStop, Slow, Hidden]
    observation_sources: [scan]
    scan: {type: scan}
    PolygonStop: {type: polygon, action_type: stop, points: "[[0.4, 0.3], [0.4, -0.3], [0.0, -0.3], [0.0, 0.3]]",
                  visualize: true}
    Slow: {type: circle, radius: 0.8, action_type: slowdown, visualize: true, polygon_pub_topic: "~/slow_zone"}
    Hidden: {type: circle, radius: 0.5, action_type: stop}
""")
    node = CollisionMonitorNode(p.collision_monitor)
    assert [topic for _, topic in node.visualized] == ["/PolygonStop", "/collision_monitor/slow_zone"]
    probe = PolygonProbe(["/PolygonStop", "/collision_monitor/slow_zone", "/Hidden"])
    ex = Executor()
    ex.add_node(node)
    ex.add_node(probe)
    for k in range(3):
        ex.publish(Envelope("/cmd_vel_smoothed", m.TWIST, (k + 1) * 10 * MS, m.twist(0.2, 0.0, 0.0)), 0)
    ex.run()
    stop, slow = probe.got["/PolygonStop"], probe.got["/collision_monitor/slow_zone"]
    assert [s[0] for s in stop] == [s[0] for s in slow] == [10 * MS, 20 * MS, 30 * MS]
    assert probe.got["/Hidden"] == []  # visualize: false publishes nothing
    square = np.array([[0.4, 0.3], [0.4, -0.3], [0.0, -0.3], [0.0, 0.3]], dtype=np.float32)
    assert stop[0][1] == "base_footprint" and np.array_equal(stop[0][3], square)
    ring = slow[0][3]  # Nav2's 16-vertex circle from angle 0
    assert ring.shape == (16, 2) and np.hypot(ring[:, 0], ring[:, 1]) == pytest.approx(np.full(16, 0.8), abs=1e-7)
    assert ring[0] == pytest.approx([0.8, 0.0]) and ring[4] == pytest.approx([0.0, 0.8], abs=1e-7)


def test_polygon_stamped_goes_through_the_typestore():
    msg = polygon_stamped(1500 * MS, "base_link", np.array([[0.5, 0.3], [0.5, -0.3], [-0.1, 0.0]]))
    back = m.deserialize(m.serialize(msg, POLYGON_STAMPED), POLYGON_STAMPED)
    assert m.to_ns(back.header.stamp) == 1500 * MS and back.header.frame_id == "base_link"
    assert [(q.x, q.y, q.z) for q in back.polygon.points] == [(q.x, q.y, q.z) for q in msg.polygon.points]
    assert back.polygon.points[0].y == m.f32(0.3)  # float32 already in memory: live equals replayed
    assert "geometry_msgs/Point32" in m.msgdef(POLYGON_STAMPED)
    assert polygon_pub_topic("collision_monitor", "FootprintApproach", "") == "/FootprintApproach"
    assert polygon_pub_topic("collision_monitor", "Stop", "zones/stop") == "/zones/stop"


def _odom_tf(t_ms: int, x: float, yaw: float):
    return m.tf_message(
        [
            m.transform_stamped(
                t_ms * MS, "odom", "base_link", (x, 0.5 * x, 0.0), (0, 0, math.sin(yaw / 2), math.cos(yaw / 2))
            )
        ]
    )


def _mount_tf(x: float):
    return m.tf_message([m.transform_stamped(0, "base_link", "laser", (x, 0.0, 0.2), (0.0, 0.0, 0.0, 1.0))])


def _tf_story():
    """Commands, scans and TF whose history changes under the node (ms, topic, type, message): new
    samples, a sample at an already buffered stamp changing its value, a new static mount, a sample
    inserted before a scan's stamp."""
    cmd = (m.TWIST, m.twist(0.3, 0.0, 0.1))
    return [
        (0, "/tf_static", m.TF_MESSAGE, _mount_tf(0.1)),
        (0, "/tf", m.TF_MESSAGE, _odom_tf(0, 0.0, 0.0)),
        (100, "/tf", m.TF_MESSAGE, _odom_tf(100, 0.05, 0.1)),
        (100, "/scan", m.LASER_SCAN, scan_msg(100 * MS, wall_scan(0.2), "laser")),
        (150, "/tf", m.TF_MESSAGE, _odom_tf(150, 0.08, 0.15)),
        (150, "/cmd_vel_smoothed", *cmd),
        (200, "/tf", m.TF_MESSAGE, _odom_tf(200, 0.1, 0.2)),
        (200, "/cmd_vel_smoothed", *cmd),  # same scan, newer TF only: the kept transform holds
        (210, "/tf", m.TF_MESSAGE, _odom_tf(100, 0.06, 0.12)),  # the 100 ms sample again, changed
        (250, "/tf", m.TF_MESSAGE, _odom_tf(250, 0.13, 0.25)),
        (250, "/cmd_vel_smoothed", *cmd),
        (260, "/tf_static", m.TF_MESSAGE, _mount_tf(0.15)),  # the laser remounted
        (300, "/tf", m.TF_MESSAGE, _odom_tf(300, 0.16, 0.3)),
        (300, "/cmd_vel_smoothed", *cmd),
        (300, "/scan", m.LASER_SCAN, scan_msg(300 * MS, wall_scan(0.3), "laser")),
        (350, "/tf", m.TF_MESSAGE, _odom_tf(350, 0.19, 0.35)),
        (350, "/cmd_vel_smoothed", *cmd),
        (360, "/tf", m.TF_MESSAGE, _odom_tf(280, 0.2, 0.5)),  # inserted before the scan's stamp
        (400, "/tf", m.TF_MESSAGE, _odom_tf(400, 0.22, 0.4)),
        (400, "/cmd_vel_smoothed", *cmd),
    ]


def test_cached_scan_points_and_transforms_equal_a_fresh_computation_for_every_command():
    """The node keeps a scan's points and its odom <- laser transform between commands. Whatever the TF
    does meanwhile (new samples, a sample at an already buffered stamp changing its value, a new static
    mount, a sample inserted into the history), each command's points equal, bit for bit, those
    computed from scratch from the TF delivered so far."""
    p = load_nav2_params(DATA / "kibot_nav2_fragments.yaml")
    seen: list[tuple[int, np.ndarray | None]] = []

    class Recording(CollisionMonitorNode):
        def source_points(self, name: str, now: int, reach: float | None = None) -> np.ndarray | None:
            pts = super().source_points(name, now)  # every point, however far (no reach)
            seen.append((now, pts))
            return pts

    node = Recording(p.collision_monitor, footprint=robot_footprint(p.global_costmap))
    stream = _tf_story()
    ex = Executor()
    ex.add_node(node)
    for t, topic, typename, msg in stream:
        ex.publish(Envelope(topic, typename, t * MS, msg), 0)
    ex.run()

    def fresh(i: int, sensor_tf_from: int | None = None) -> np.ndarray:
        """The points of the command at stream[i] from a new buffer (odom <- laser as of stream[:sensor_tf_from])."""

        def buffer(n: int) -> TFBuffer:
            tf = TFBuffer()
            for _, topic, _, msg in stream[:n]:
                if topic in ("/tf", "/tf_static"):
                    tf.add_message(msg, static=topic == "/tf_static")
            return tf

        scan = [msg for _, topic, _, msg in stream[:i] if topic == "/scan"][-1]
        stamp = m.to_ns(scan.header.stamp)
        base_odom = rigid_inverse(buffer(i).lookup("odom", "base_link", stream[i][0] * MS))
        odom_laser = buffer(sensor_tf_from or i).lookup("odom", "laser", stamp)
        sensor = scan_points(scan.ranges, scan.angle_min, scan.angle_increment, scan.range_min, scan.range_max)
        return to_base(sensor, base_odom @ odom_laser)[:, :2]

    commands = [i for i, (_, topic, _, _) in enumerate(stream) if topic == "/cmd_vel_smoothed"]
    assert [t for t, _ in seen] == [stream[i][0] * MS for i in commands]
    for (_, got), i in zip(seen, commands, strict=True):
        assert got is not None and len(got) > 100
        expected = fresh(i)
        assert got.shape == expected.shape and got.tobytes() == expected.tobytes()
    # the rewritten sample and the new mount do move the points: a transform kept across them would be wrong
    at_250, at_300 = commands[2], commands[3]
    assert fresh(at_250, sensor_tf_from=commands[1]).tobytes() != fresh(at_250).tobytes()
    assert fresh(at_300, sensor_tf_from=at_250).tobytes() != fresh(at_300).tobytes()
    assert node.skipped_counts() == {}


def test_the_bound_is_tested_on_the_transform_the_points_would_take_through_every_tf_change():
    """With ``base_shift_correction`` a command's reach test uses base <- laser as floats (``_beyond_now``):
    at every command of the changing TF story it equals, to rounding, the matrix the points would be
    transformed with, so a float transform kept past a change (a stale cache) would fail here."""
    p = load_nav2_params(DATA / "kibot_nav2_fragments.yaml")
    gaps: list[float] = []

    class Comparing(CollisionMonitorNode):
        def source_points(self, name: str, now: int, reach: float | None = None) -> np.ndarray | None:
            msg = self.latest[name]
            stamp, frame = m.to_ns(msg.header.stamp), msg.header.frame_id
            floats = relative_pose(self._base_pose(now), self._sensor_to_odom(name, msg, frame, stamp, pose=True))
            matrix = self._to_base(name, msg, frame, stamp, now)
            tx, ty, _, x, y, z, w = floats
            block = [
                [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), tx],
                [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), ty],
            ]
            gaps.append(float(np.abs(np.array(block) - matrix[:2, [0, 1, 3]]).max()))
            return super().source_points(name, now, reach)

    node = Comparing(p.collision_monitor, footprint=robot_footprint(p.global_costmap))
    assert node.params.base_shift_correction
    ex = Executor()
    ex.add_node(node)
    for t, topic, typename, msg in _tf_story():
        ex.publish(Envelope(topic, typename, t * MS, msg), 0)
    ex.run()
    assert len(gaps) == 6 and max(gaps) < 1e-12
    assert node.skipped_counts() == {}
