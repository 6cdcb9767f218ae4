"""Nav2's collision monitor: Nav2 Jazzy's own test vectors (collision_monitor_node_test.cpp,
polygons_test.cpp, kinematics_test.cpp, sources_test.cpp) and a robot driving at a wall."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from navlog.replay.nav2 import load_nav2_params, parse_nav2_text
from navlog.replay.nav2.collision_monitor import (
    INVALID_SOURCE,
    CollisionMonitor,
    CollisionMonitorParams,
    Polygon,
    Velocity,
    cloud_points,
    make_shape,
    planar_block_beyond,
    planar_points_beyond,
    project_state,
    range_points,
    scan_nearest,
    scan_points,
    scan_points_nearest,
    source_fresh,
    to_base,
    transform_points,
)
from navlog.replay.nav2.costmap import robot_footprint

DATA = Path(__file__).resolve().parent / "data"
EPSILON = 1e-5  # collision_monitor_node_test.cpp
IDENTITY = np.eye(4)


def square(s: float) -> str:
    return f'"[[{s}, {s}], [{s}, {-s}], [{-s}, {-s}], [{-s}, {s}]]"'


def monitor_params(body: str, **node) -> CollisionMonitorParams:
    """A collision_monitor block (Nav2 test constants: min_points 2, stop_pub_timeout 0.1, source_timeout 5)."""
    head = {"stop_pub_timeout": 0.1, "source_timeout": 5.0, **node}
    text = "collision_monitor:\n  ros__parameters:\n" + "".join(f"    {k}: {v}\n" for k, v in head.items()) + body
    params = parse_nav2_text(text)
    assert params.errors == [], params.errors
    assert params.collision_monitor is not None
    return params.collision_monitor


def ring(d: float, n: int = 360) -> np.ndarray:
    """The tests' scan: n beams of range d all around (1 degree apart), as base-frame points."""
    return scan_points(np.full(n, d), 0.0, 2 * math.pi / n, 0.0, 100.0)[:, :2]


def arc(d: float, fov: float = math.pi / 10, step: float = math.pi / 200) -> np.ndarray:
    pts = range_points(d, 0.0, 100.0, fov, step)
    assert pts is not None
    return pts[:, :2]


def assert_velocity(v: Velocity, expected, tol=EPSILON) -> None:
    assert v.vx == pytest.approx(expected[0], abs=tol)
    assert v.vy == pytest.approx(expected[1], abs=tol)
    assert v.wz == pytest.approx(expected[2], abs=tol)


STOP_SLOWDOWN_LIMIT = f"""\
    polygons: [Limit, SlowDown, Stop]
    observation_sources: [scan]
    scan: {{type: scan, topic: scan}}
    Limit: {{type: polygon, points: {square(3)}, action_type: limit, min_points: 2, linear_limit: 0.4, angular_limit: 0.09}}
    SlowDown: {{type: polygon, points: {square(2)}, action_type: slowdown, min_points: 2, slowdown_ratio: 0.7}}
    Stop: {{type: polygon, points: {square(1)}, action_type: stop, min_points: 2}}
"""


def test_stop_slowdown_limit_as_nav2_test_process_stop_slowdown_limit():
    cm = CollisionMonitor(monitor_params(STOP_SLOWDOWN_LIMIT))
    cmd = Velocity(0.5, 0.2, 0.1)
    steps = [
        (4.5, "none", "", (0.5, 0.2, 0.1)),
        (3.0, "limit", "Limit", (0.371391, 0.148556, 0.074278)),  # min(0.4/0.538516, 0.09/0.1) = 0.742781
        (1.5, "slowdown", "SlowDown", (0.35, 0.14, 0.07)),  # 0.7x beats the limit's 0.742781x
        (0.5, "stop", "Stop", (0.0, 0.0, 0.0)),
        (4.5, "none", "", (0.5, 0.2, 0.1)),
    ]
    for t, (d, kind, polygon, out) in enumerate(steps):
        decision = cm.process(cmd, t * 10_000_000, {"scan": ring(d)})
        assert (decision.action.action_type, decision.action.polygon) == (kind, polygon), d
        assert_velocity(decision.action.velocity, out)


def test_approach_as_nav2_test_process_approach():
    body = """\
    polygons: [Approach]
    observation_sources: [scan]
    scan: {type: scan}
    Approach: {type: circle, radius: 1.0, action_type: approach, min_points: 2, time_before_collision: 1.0, simulation_time_step: 0.01}
"""
    cm = CollisionMonitor(monitor_params(body))
    cmd = Velocity(0.5, 0.2, 0.0)
    d = cm.process(cmd, 0, {"scan": ring(1.2)})
    ratio = 0.2 / math.hypot(0.5, 0.2) / 1.0  # Nav2's expectation: 0.2 m to go at 0.538516 m/s
    assert d.action.action_type == "approach" and d.action.polygon == "Approach"
    assert d.action.velocity.vx == pytest.approx(0.5 * ratio, abs=0.5 * 0.005)  # 0.1857
    assert d.action.velocity.vy == pytest.approx(0.2 * ratio, abs=0.2 * 0.005)
    # Nav2 returns the loop time one step before the colliding pose: 0.37 s, (0.185, 0.074)
    assert d.collision_times["Approach"] == pytest.approx(0.37)
    assert_velocity(d.action.velocity, (0.185, 0.074, 0.0))
    # obstacle already inside: zero (reported as approach), however fast the command
    d = cm.process(Velocity(1e9, 0.2, 0.0), 1, {"scan": ring(0.5)})
    assert d.action.action_type == "approach" and d.action.velocity.is_zero()


def test_approach_rotation_as_nav2_test_process_approach_rotation():
    body = f"""\
    polygons: [Approach]
    observation_sources: [range]
    range: {{type: range, obstacles_angle: {math.pi / 200}}}
    Approach: {{type: polygon, points: {square(1)}, action_type: approach, min_points: 2, time_before_collision: 1.0, simulation_time_step: 0.01}}
"""
    cm = CollisionMonitor(monitor_params(body))
    d = cm.process(Velocity(0.0, 0.0, math.pi / 4), 0, {"range": arc(1.4)})
    assert d.action.action_type == "approach"
    assert d.action.velocity.wz == pytest.approx(math.pi / 5, abs=math.pi / 4 * 0.01)  # t = 0.8 s
    assert d.collision_times["Approach"] == pytest.approx(0.8)
    d = cm.process(Velocity(0.0, 0.0, math.pi / 4), 1, {"range": arc(0.5)})
    assert d.action.velocity.is_zero()


CROSS_OVER = f"""\
    polygons: [SlowDown, Approach]
    observation_sources: [pointcloud, range]
    pointcloud: {{type: pointcloud}}
    range: {{type: range}}
    SlowDown: {{type: polygon, points: {square(2)}, action_type: slowdown, min_points: 2, slowdown_ratio: 0.7}}
    Approach: {{type: circle, radius: 1.0, action_type: approach, min_points: 2, time_before_collision: 1.0, simulation_time_step: 0.01}}
"""


def test_cross_over_as_nav2_test_cross_over():
    p = monitor_params(CROSS_OVER)
    cloud = cloud_points(np.array([[2.5, 0.01, 0.2], [2.5, -0.01, 0.2]]), IDENTITY, 0.05, 0.5)
    cm = CollisionMonitor(p)
    d = cm.process(Velocity(3.0, 0.0, 0.0), 0, {"pointcloud": cloud, "range": arc(2.5)})
    assert (d.action.action_type, d.collision_times["Approach"]) == ("approach", pytest.approx(0.5))
    assert d.action.velocity.vx == pytest.approx(1.5, abs=3.0 * 0.01)
    # range 1.5: slowdown acts; approach at 0.1 m/s would need 5 s > 1 s
    d = cm.process(Velocity(0.1, 0.0, 0.0), 1, {"pointcloud": cloud, "range": arc(1.5)})
    assert d.action.action_type == "slowdown" and d.action.velocity.vx == pytest.approx(0.07, abs=EPSILON)
    assert d.collision_times["Approach"] == -1.0
    # at 1.0 m/s approach (0.5) is safer than slowdown (0.7)
    d = cm.process(Velocity(1.0, 0.0, 0.0), 2, {"pointcloud": cloud, "range": arc(1.5)})
    assert d.action.action_type == "approach" and d.action.velocity.vx == pytest.approx(0.5, abs=0.01)


def test_source_timeout_and_override_as_nav2():
    body = f"""\
    polygons: [Stop]
    observation_sources: [range]
    range: {{type: range, source_timeout: %s}}
    Stop: {{type: polygon, points: {square(1)}, action_type: stop, min_points: 2}}
"""
    cm = CollisionMonitor(monitor_params(body % 5.0))
    d = cm.process(Velocity(0.5, 0.0, 0.0), 0, {"range": None})  # configured, never published
    assert (d.action.action_type, d.action.polygon, d.invalid_source) == ("stop", INVALID_SOURCE, "range")
    assert d.action.velocity.is_zero()
    cm = CollisionMonitor(monitor_params(body % 0.0))  # 0 disables the invalid-source stop
    d = cm.process(Velocity(0.5, 0.0, 0.0), 0, {"range": None})
    assert (d.action.action_type, d.action.velocity) == ("none", Velocity(0.5, 0.0, 0.0))


def test_source_staleness_rule():
    assert source_fresh(0, 5_000_000_000, 5.0)  # now - stamp == timeout: still valid
    assert not source_fresh(0, 5_000_000_001, 5.0)
    assert source_fresh(0, 10**12, 0.0)


def test_cease_publish_zero_velocity_as_nav2():
    cm = CollisionMonitor(monitor_params(STOP_SLOWDOWN_LIMIT))
    cmd, ms = Velocity(0.5, 0.2, 0.1), 1_000_000
    assert cm.process(cmd, 0, {"scan": ring(4.5)}).publish
    assert cm.process(cmd, 10 * ms, {"scan": ring(0.5)}).publish  # first zero: stop stamp
    assert cm.process(cmd, 60 * ms, {"scan": ring(0.5)}).publish  # 50 ms <= 0.1 s
    assert not cm.process(cmd, 150 * ms, {"scan": ring(0.5)}).publish  # 140 ms > 0.1 s: nothing published
    assert cm.process(cmd, 160 * ms, {"scan": ring(4.5)}).publish  # moving again


VELOCITY_POLYGON = f"""\
    polygons: [VelocityPolygonStop]
    observation_sources: [pointcloud]
    pointcloud: {{type: pointcloud}}
    VelocityPolygonStop:
      type: velocity_polygon
      action_type: stop
      min_points: 2
      holonomic: false
      velocity_polygons: [Forward, Backward]
      Forward: {{points: {square(4)}, linear_min: 0.0, linear_max: 0.5, theta_min: 0.0, theta_max: 1.0}}
      Backward: {{points: {square(2)}, linear_min: -0.5, linear_max: 0.0, theta_min: 0.0, theta_max: 1.0}}
"""


def test_velocity_polygon_stop_as_nav2_test_velocity_polygon_stop():
    cm = CollisionMonitor(monitor_params(VELOCITY_POLYGON))

    def cloud(x):
        return cloud_points(np.array([[x, 0.01, 0.2], [x, -0.01, 0.2]]), IDENTITY, 0.05, 0.5)

    assert cm.process(Velocity(0.4, 0.0, 0.0), 0, {"pointcloud": cloud(3.0)}).action.action_type == "stop"
    d = cm.process(Velocity(-0.4, 0.0, 0.0), 1, {"pointcloud": cloud(3.0)})  # Backward: s 2, x = 3 is outside
    assert (d.action.action_type, d.action.velocity) == ("none", Velocity(-0.4, 0.0, 0.0))
    assert cm.process(Velocity(-0.4, 0.0, 0.0), 2, {"pointcloud": cloud(-1.5)}).action.action_type == "stop"
    assert cm.process(Velocity(0.4, 0.0, 0.0), 3, {"pointcloud": cloud(4.5)}).action.action_type == "none"
    # no sub-polygon covers 0.8 m/s: the previous (Forward) shape is kept
    shape = cm.shapes[0]
    assert cm.process(Velocity(0.8, 0.0, 0.0), 4, {"pointcloud": cloud(3.0)}).action.action_type == "stop"
    assert (shape.current, shape.unmatched) == ("Forward", 1)


def test_source_associated_to_polygon_as_nav2():
    body = f"""\
    polygons: [Stop, SlowDown]
    observation_sources: [scan, range]
    scan: {{type: scan}}
    range: {{type: range}}
    Stop: {{type: polygon, points: {square(1)}, action_type: stop, min_points: 2, sources_names: [range]}}
    SlowDown: {{type: polygon, points: {square(2)}, action_type: slowdown, min_points: 2, slowdown_ratio: 0.7}}
"""
    cm = CollisionMonitor(monitor_params(body))
    d = cm.process(Velocity(0.5, 0.2, 0.1), 0, {"scan": ring(0.5), "range": arc(4.5)})
    assert (d.action.action_type, d.action.polygon) == ("slowdown", "SlowDown")
    assert_velocity(d.action.velocity, (0.35, 0.14, 0.07))


@pytest.mark.parametrize(
    ("velocity", "points", "expected"),
    [
        (Velocity(0.5, 0.0, 0.0), [(0.7, 0.01), (0.7, -0.01)], 0.4),
        (Velocity(-0.5, 0.0, 0.0), [(-0.7, 0.01), (-0.7, -0.01)], 0.4),
        (Velocity(0.0, 0.5, 0.0), [(0.01, 0.6), (-0.01, 0.6)], 0.2),
        (Velocity(0.5, 0.0, 0.0), [(0.1, 0.01), (0.1, -0.01)], 0.0),
    ],
)
def test_collision_time_as_nav2_polygons_test(velocity, points, expected):
    body = "    polygons: [Footprint]\n    observation_sources: [scan]\n    scan: {type: scan}\n"
    body += f"    Footprint: {{type: polygon, points: {square(0.5)}, action_type: approach, min_points: 2, "
    body += "time_before_collision: 1.0, simulation_time_step: 0.01}\n"
    p = monitor_params(body)
    shape = make_shape("Footprint", p.polygon_params["Footprint"], p.observation_sources)
    assert shape.collision_time(np.array(points), velocity) == pytest.approx(expected, abs=0.01)
    assert shape.collision_time(np.array([(1.1, 0.01), (1.1, -0.01)]), Velocity(0.5, 0.0, 0.0)) < 0.0


def test_kinematics_as_nav2_kinematics_test():
    out = transform_points((2.0, 1.0, math.pi / 6), np.array([[3.0, 2.0]]))
    a = math.pi / 4 - math.pi / 6
    assert out[0] == pytest.approx([math.sqrt(2) * math.cos(a), math.sqrt(2) * math.sin(a)])
    pose, vel = project_state(1.0, (2.0, 1.0, math.pi / 4), Velocity(0.0, 1.0, math.pi / 4))
    assert pose == pytest.approx((2.0, 2.0, math.pi / 2))
    assert tuple(vel) == pytest.approx((math.cos(3 * math.pi / 4), math.sin(3 * math.pi / 4), math.pi / 4))


def test_pointcloud_min_range_and_heights_as_nav2_sources_test():
    pts = np.array([[0.0, 0.0, 0.158], [0.0, 0.1, 0.17], [1.0, 0.0, 0.04], [1.0, 0.0, 0.5], [1.0, 0.0, 0.51]])
    out = cloud_points(pts, IDENTITY, 0.05, 0.5, min_range=0.16)
    assert out.tolist() == [[0.0, 0.1], [1.0, 0.0]]  # 0.158 m is nearer than min_range; heights inclusive


def test_scan_range_max_is_inclusive_and_range_out_of_bounds_is_invalid():
    pts = scan_points(np.array([1.0, 4.0, np.inf, np.nan, 0.05], dtype=np.float32), 0.0, 0.1, 0.1, 4.0)
    assert len(pts) == 2  # 4.0 == range_max is kept (an obstacle for the monitor), inf/NaN/short are not
    assert range_points(math.inf, 0.1, 4.0, 0.5, 0.1) is None
    assert range_points(0.05, 0.1, 4.0, 0.5, 0.1) is None
    arc_pts = range_points(1.0, 0.1, 4.0, math.pi / 10, math.pi / 200)
    assert arc_pts is not None and len(arc_pts) == 21  # -fov/2 .. below fov/2 every pi/200, plus fov/2
    assert np.hypot(arc_pts[:, 0], arc_pts[:, 1]) == pytest.approx(np.ones(21))


def test_scan_points_nearest_is_the_least_range_kept():
    ranges = np.array([2.5, 0.05, np.nan, 0.3, np.inf, 4.0], dtype=np.float32)
    pts, nearest = scan_points_nearest(ranges, 0.0, 0.1, 0.1, 4.0)
    assert pts.tobytes() == scan_points(ranges, 0.0, 0.1, 0.1, 4.0).tobytes() and len(pts) == 3
    assert nearest == float(np.float32(0.3)) == pytest.approx(np.hypot(pts[:, 0], pts[:, 1]).min(), rel=1e-15)
    none, nowhere = scan_points_nearest(np.array([np.nan, 9.0], dtype=np.float32), 0.0, 0.1, 0.1, 4.0)
    assert none.shape == (0, 3) and nowhere == math.inf
    # the least range alone, without the points: the same number (the range limits inclusive)
    assert scan_nearest(ranges, 0.1, 4.0) == nearest and scan_nearest(ranges, 0.3, 4.0) == nearest
    assert scan_nearest(ranges, 0.31, 4.0) == 2.5 and scan_nearest(np.array([np.nan, 9.0]), 0.1, 4.0) == math.inf


def test_polygon_edges_follow_nav2_ray_casting():
    p = monitor_params(STOP_SLOWDOWN_LIMIT)
    shape = make_shape("Stop", p.polygon_params["Stop"], ("scan",))
    inside = shape.inside(np.array([[0.0, 0.0], [1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0], [0.999, 0.999]]))
    # half-open in y, strict in x: the right and bottom edges are outside, the left and top inside
    assert inside.tolist() == [True, False, True, True, False, True]
    with pytest.raises(ValueError, match="at least 3 vertices"):
        Polygon("dyn", p.polygon_params["Stop"], ("scan",)).set_vertices([(0.0, 0.0), (1.0, 0.0)])


# ---------------------------------------------------------------------- parameters


@pytest.mark.parametrize("points", ["[[1, 1], [1, -1], [-1, -1]]", "[[1, 1], [1, -1]]"])
def test_polygon_points_need_four_vertices(points):
    text = f"""collision_monitor:
  ros__parameters:
    polygons: [Stop]
    observation_sources: [scan]
    scan: {{type: scan}}
    Stop: {{type: polygon, points: "{points}", action_type: stop}}
"""
    errors = {e.path: e.message for e in parse_nav2_text(text).errors}
    assert "at least 4" in errors["collision_monitor.ros__parameters.Stop.points"]
    assert parse_nav2_text(text.replace(points, "[[1, 1], [1, -1], [-1, -1], [-1, 1]]")).errors == []


def test_max_points_is_read_as_min_points_plus_one_and_said_so():
    text = f"""collision_monitor:
  ros__parameters:
    polygons: [Stop, Both]
    observation_sources: [scan]
    scan: {{type: scan}}
    Stop: {{type: polygon, points: {square(1)}, action_type: stop, max_points: 3}}
    Both: {{type: polygon, points: {square(1)}, action_type: stop, max_points: 3, min_points: 2}}
"""
    p = parse_nav2_text(text)
    assert p.errors == []
    assert p.collision_monitor.polygon_params["Stop"].min_points == 4
    assert p.collision_monitor.polygon_params["Both"].min_points == 4  # max_points overrides, as in Jazzy
    by_path = {q.path: (q.severity, q.message) for q in p.problems}
    severity, message = by_path["collision_monitor.ros__parameters.Stop.max_points"]
    assert severity == "note" and "max_points 3 read as min_points 4" in message
    severity, message = by_path["collision_monitor.ros__parameters.Both.max_points"]
    assert severity == "warning" and "overrides min_points 2" in message


def test_jazzy_faithfulness_checks_on_sources():
    text = """collision_monitor:
  ros__parameters:
    polygons: [Stop]
    observation_sources: [scan, map]
    scan: {type: scan, min_height: 0.1}
    map: {type: costmap}
    Stop: {type: circle, radius: 0.5, action_type: stop, sources_names: [scna]}
"""
    p = parse_nav2_text(text)
    errors = {e.path: e.message for e in p.errors}
    assert "Kilted" in errors["collision_monitor.ros__parameters.map.type"]
    assert "did you mean 'scan'?" in errors["collision_monitor.ros__parameters.Stop.sources_names"]
    warnings = {w.path: w.message for w in p.warnings}
    assert "never reads" in warnings["collision_monitor.ros__parameters.scan.min_height"]


def test_velocity_polygon_sub_polygons_are_read_and_checked():
    p = monitor_params(VELOCITY_POLYGON)
    vp = p.polygon_params["VelocityPolygonStop"]
    assert vp.velocity_polygons == ("Forward", "Backward")
    assert vp.velocity_polygon_params["Backward"].linear_min == -0.5
    bad = VELOCITY_POLYGON.replace("linear_max: 0.5, ", "").replace("[Forward, Backward]", "[Forward, Backwards]")
    text = "collision_monitor:\n  ros__parameters:\n" + bad
    errors = {e.path: e.message for e in parse_nav2_text(text).errors}
    base = "collision_monitor.ros__parameters.VelocityPolygonStop"
    assert "missing linear_max" in errors[base + ".Forward"]
    assert "did you mean 'Backward'?" in errors[base + ".velocity_polygons"]


# ---------------------------------------------------------------------- a robot driving at a wall


def wall_scan(robot_x: float, wall_x: float = 1.0, n: int = 720) -> np.ndarray:
    """A 720-beam scan (from the base origin) of a wall across the robot's path at ``wall_x``."""
    angles = -math.pi + np.arange(n) * (2 * math.pi / n)
    ranges = np.full(n, np.inf)
    ahead = np.cos(angles) > 0.1
    ranges[ahead] = (wall_x - robot_x) / np.cos(angles[ahead])
    ranges[ranges > 6.0] = np.inf
    return ranges.astype(np.float32)


def wall_points(robot_x: float) -> np.ndarray:
    return scan_points(wall_scan(robot_x), -math.pi, 2 * math.pi / 720, 0.12, 6.0)[:, :2]


def test_kibot_footprint_approach_slows_for_a_wall_keeping_contact_1_2_s_away():
    p = load_nav2_params(DATA / "kibot_nav2_fragments.yaml")
    footprint = robot_footprint(p.global_costmap)  # robot_radius 0.34 + padding 0.01: a 16-gon of 0.35 m
    cm = CollisionMonitor(p.collision_monitor, footprint)
    cmd = Velocity(0.45, 0.0, 0.0)
    # robot at 0.2 m, wall at 1.0 m: 0.8 m ahead, 0.45 m of it inside the 0.35 m footprint after
    # 11 steps of 0.045 m (0.495 m); Nav2 reports the 11th step's start, t = 1.0 s, so 0.45 * 1.0 / 1.2
    d = cm.process(cmd, 0, {"scan": wall_points(0.2)})
    assert d.collision_times["FootprintApproach"] == pytest.approx(1.0)
    assert (d.action.action_type, d.action.velocity.vx) == ("approach", pytest.approx(0.375))
    # at 0.1 m the contact is 1.2 s away: no slower than the command, so nothing changes
    d = cm.process(cmd, 1, {"scan": wall_points(0.1)})
    assert d.collision_times["FootprintApproach"] == pytest.approx(1.2)
    assert (d.action.action_type, d.action.velocity.vx) == ("none", 0.45)

    # drive from x = 0 at 20 Hz with the command let through
    shape = cm.shapes[0]
    x, dt = 0.0, 0.05
    outputs = []
    for k in range(200):
        points = wall_points(x)
        d = cm.process(cmd, k, {"scan": points})
        v = d.action.velocity.vx
        if v > 0.0:  # at the speed let through, contact (4 points inside) stays >= 1.2 s away
            assert contact_distance(shape, points) / v >= 1.2
        if 0.0 < v < 0.45:  # reduced by the approach model's own prediction
            assert v == pytest.approx(0.45 * d.collision_times["FootprintApproach"] / 1.2)
        outputs.append(v)
        x += v * dt
    assert outputs[0] == 0.45 and min(outputs) == 0.0
    assert 0.0 < 1.0 - 0.35 - x <= 0.45 * 0.1  # stopped short of the wall, within one 0.1 s step at 0.45 m/s


def contact_distance(shape, points: np.ndarray) -> float:
    """How far the footprint moves straight ahead before min_points wall points are inside (bisection)."""
    lo, hi = 0.0, 2.0
    for _ in range(60):
        mid = (lo + hi) / 2
        if shape.count_inside(points - [mid, 0.0]) >= shape.min_points:
            hi = mid
        else:
            lo = mid
    return lo


def test_a_new_footprint_replaces_the_kept_edges_and_reach():
    body = "    polygons: [Footprint]\n    observation_sources: [scan]\n    scan: {type: scan}\n"
    body += "    Footprint: {type: polygon, action_type: approach, min_points: 2, time_before_collision: 1.0, "
    body += "simulation_time_step: 0.1}\n"
    p = monitor_params(body)
    shape = make_shape(
        "Footprint",
        p.polygon_params["Footprint"],
        p.observation_sources,
        [(0.5, 0.5), (0.5, -0.5), (-0.5, -0.5), (-0.5, 0.5)],
    )
    assert isinstance(shape, Polygon)
    near = np.array([[0.72, 0.01], [0.72, -0.01]])
    assert shape.reach() == pytest.approx(math.sqrt(0.5))
    assert shape.count_inside(near) == 0
    # a 0.22 m gap closed at 0.05 m per step: the pose after the 5th step, loop time 0.4 s
    assert shape.collision_time(near, Velocity(0.5, 0.0, 0.0)) == pytest.approx(0.4)
    shape.set_vertices([(1.0, 1.0), (1.0, -1.0), (-1.0, -1.0), (-1.0, 1.0)])
    assert shape.reach() == pytest.approx(math.sqrt(2.0))
    assert shape.count_inside(near) == 2
    # inside now: 0, whatever far points come with them (they are left out before counting)
    far = np.vstack([near, [[9.0, 0.0], [-9.0, 3.0], [np.nan, 0.0], [np.inf, 0.0]]])
    assert shape.collision_time(far, Velocity(0.5, 0.0, 0.0)) == 0.0
    assert shape.collision_time(far[2:], Velocity(0.5, 0.0, 0.0)) == -1.0


def test_points_reach_is_the_farthest_a_point_can_count_for_the_command():
    # stop, slowdown, limit: the largest polygon's farthest vertex, whatever the command
    cm = CollisionMonitor(monitor_params(STOP_SLOWDOWN_LIMIT))
    assert cm.points_reach(Velocity(0.0, 0.0, 0.0)) == cm.points_reach(Velocity(0.5, 0.0, 1.0)) == math.hypot(3, 3)
    # a velocity polygon: its largest sub-polygon (square(4)), before any command picked one and after
    cm = CollisionMonitor(monitor_params(VELOCITY_POLYGON))
    assert cm.points_reach(Velocity(-0.4, 0.0, 0.0)) == math.hypot(4, 4)
    cm.process(Velocity(-0.4, 0.0, 0.0), 0, {"pointcloud": np.zeros((0, 2))})  # Backward (square(2)) now
    assert cm.shapes[0].reach() == math.hypot(2, 2) and cm.points_reach(Velocity(-0.4, 0.0, 0.0)) == math.hypot(4, 4)
    # approach: the footprint's reach plus |v| * dt * (int(T / dt) + 2): 0.5 m/s * 0.1 s * 12 steps
    body = "    polygons: [Footprint]\n    observation_sources: [scan]\n    scan: {type: scan}\n"
    body += "    Footprint: {type: polygon, action_type: approach, min_points: 2, time_before_collision: 1.0, "
    body += f"simulation_time_step: 0.1, points: {square(0.5)}}}\n"
    cm = CollisionMonitor(monitor_params(body))
    assert cm.points_reach(Velocity(0.3, 0.4, 2.0)) == pytest.approx(math.sqrt(0.5) + 0.6, abs=1e-8)
    assert cm.points_reach(Velocity(0.0, 0.0, 2.0)) == pytest.approx(math.sqrt(0.5), abs=1e-8)
    # points just beyond it are left out of the simulation; 0.5 m in front of the footprint, the last
    # step (loop time 1.0 s, the 11th pose, 0.55 m ahead) meets them
    reach = cm.points_reach(Velocity(0.5, 0.0, 0.0))
    shape = cm.shapes[0]
    assert shape.collision_time(np.array([[reach + 1e-6, 0.0]] * 2), Velocity(0.5, 0.0, 0.0)) == -1.0
    assert shape.collision_time(np.array([[0.5 + 0.5 + 1e-6, 0.0]] * 2), Velocity(0.5, 0.0, 0.0)) == pytest.approx(1.0)


def test_planar_points_beyond_is_a_true_bound_with_a_margin():
    yaw = math.radians(30.0)
    c, s = math.cos(yaw), math.sin(yaw)
    base_sensor = np.array([[c, -s, 0.0, 0.3], [s, c, 0.0, 0.4], [0.0, 0.0, 1.0, 0.2], [0.0, 0.0, 0.0, 1.0]])
    ring2 = scan_points(np.full(3600, 2.0), -math.pi, 2 * math.pi / 3600, 0.1, 10.0)  # 2 m all around
    nearest = float(np.hypot(ring2[:, 0], ring2[:, 1]).min())
    # the sensor 0.5 m from the base origin: the ring's nearest point in the base frame is 2 - 0.5 = 1.5 m away
    closest = float(np.hypot(*to_base(ring2, base_sensor)[:, :2].T).min())
    assert closest == pytest.approx(1.5, abs=1e-6)
    assert planar_points_beyond(base_sensor, nearest, 1.499)
    assert not planar_points_beyond(base_sensor, nearest, 1.5 - 1e-7)  # within the 1 um margin: no answer
    assert not planar_points_beyond(base_sensor, nearest, 1.6)
    # a sensor rolled 90 degrees (its scan plane vertical) gives no bound in x, y; nor does a NaN
    rolled = base_sensor @ np.array([[1.0, 0, 0, 0], [0, 0.0, -1.0, 0], [0, 1.0, 0.0, 0], [0, 0, 0, 1]])
    assert not planar_points_beyond(rolled, nearest, 0.1)
    assert not planar_points_beyond(np.full((4, 4), np.nan), nearest, 0.1)
    assert planar_points_beyond(base_sensor, math.inf, 100.0)  # no points at all
    # the same test from the transform's 2x2 block and shift as floats
    block = (c, -s, s, c, 0.3, 0.4)
    assert planar_block_beyond(block, nearest, 1.499) and not planar_block_beyond(block, nearest, 1.5 - 1e-7)
