"""Sensors against analytic geometry: a scan from a known pose, LiDAR points on true surfaces."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navlog.recorder.robot import load_robot
from navlog.recorder.sim import SimNode, SimOptions
from navlog.recorder.world import load_world, world_mesh
from navlog.replay import messages
from navlog.replay.geometry import quat_to_matrix
from navlog.replay.pointcloud import read_points
from navlog.replay.runtime.executor import Executor, Node
from navlog.replay.runtime.tf import TFBuffer


def ray_to_boxes(origin: np.ndarray, direction: np.ndarray, boxes: list[tuple[np.ndarray, np.ndarray]]) -> float:
    """Nearest hit of a ray with axis-aligned boxes (slab method), inf when none."""
    best = math.inf
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / direction
    for lo, hi in boxes:
        t1, t2 = (lo - origin) * inv, (hi - origin) * inv
        t1 = np.where(np.isnan(t1), -np.inf, t1)
        t2 = np.where(np.isnan(t2), np.inf, t2)
        tmin, tmax = np.max(np.minimum(t1, t2)), np.min(np.maximum(t1, t2))
        if tmax >= max(tmin, 0.0) and tmin > 0:
            best = min(best, tmin)
    return best


def world_aabbs(world) -> list[tuple[np.ndarray, np.ndarray]]:
    out = []
    for s in world.solids:
        assert s.shape == "box"
        quarter = round(s.yaw / (math.pi / 2))
        assert abs(s.yaw - quarter * math.pi / 2) < 1e-4, "analytic check handles axis-aligned boxes only"
        sx, sy, sz = s.size if quarter % 2 == 0 else (s.size[1], s.size[0], s.size[2])
        c = np.array(s.center)
        half = np.array([sx, sy, sz]) / 2
        out.append((c - half, c + half))
    return out


class _Collect(Node):
    def __init__(self, topics):
        super().__init__()
        self.topics = topics
        self.got: dict[str, list] = {t: [] for t in topics}

    def setup(self):
        for t in self.topics:
            self.subscribe(t, lambda msg, ns, t=t: self.got[t].append((ns, msg)))


def run_sim(world="indoor_room", robot="go2", start=(0.0, 0.0, 0.0), until_ns=0, cmd=None, noise=False):
    ex = Executor()
    sim = SimNode(load_world(world), load_robot(robot), SimOptions(seed=1, noise=noise, start=start))
    ex.add_node(sim, source=True)
    col = _Collect(["/scan", "/lidar", "/livox/lidar", "/odom/ground_truth", "/tf", "/tf_static", "/odom", "/imu/data"])
    ex.add_node(col)
    if cmd is not None:

        class Drive(Node):
            def setup(self):
                self.create_timer(
                    50_000_000, lambda t: self.publish("/cmd_vel", messages.TWIST, messages.twist(*cmd)), 0
                )

        ex.add_node(Drive())
    ex.run(until_ns=until_ns)
    return sim, col.got


@pytest.mark.parametrize("start", [(0.0, 0.0, 0.0), (-1.0, 0.5, 0.7), (3.0, -3.0, -2.0)])
def test_scan_matches_analytic_distances(start):
    sim, got = run_sim(start=start)
    ns, scan = got["/scan"][0]
    assert ns == 0 and scan.header.frame_id == "front_laser"
    cfg = sim.robot.scan
    boxes = world_aabbs(sim.world)
    x, y, yaw = start
    c, s = math.cos(yaw), math.sin(yaw)
    mx, my, mz = cfg.mount[:3]
    origin = np.array([x + c * mx - s * my, y + s * mx + c * my, sim.robot.body.height + mz])
    ranges = np.asarray(scan.ranges, dtype=np.float64)
    assert len(ranges) == 720
    assert scan.range_min == pytest.approx(0.12) and scan.range_max == pytest.approx(6.0)
    errors = []
    for i, r in enumerate(ranges):
        a = yaw + scan.angle_min + i * scan.angle_increment
        expected = ray_to_boxes(origin, np.array([math.cos(a), math.sin(a), 0.0]), boxes)
        if expected > cfg.range_max:
            assert r == np.inf, f"beam {i}: expected no return, got {r}"
        else:
            errors.append(abs(r - expected))
    assert len(errors) > 400
    assert max(errors) < 1e-3, f"worst beam error {max(errors) * 1000:.3f} mm"


def test_known_beam_hits_wooden_case_side_panel():
    # from (0, 1, yaw 90°) the beam straight ahead meets the case's -y side panel at y = 3 - 0.282575 - 0.009525
    sim, got = run_sim(start=(0.0, 1.0 - 0.225, math.pi / 2))  # laser at (0, 1)
    scan = got["/scan"][0][1]
    i = int(round((0.0 - scan.angle_min) / scan.angle_increment))
    assert float(scan.ranges[i]) == pytest.approx(3.0 - 0.282575 - 0.009525 - 1.0, abs=1e-3)


def test_lidar_points_lie_on_world_surfaces():
    import open3d as o3d

    sim, got = run_sim(until_ns=3_000_000_000, cmd=(0.3, 0.0, 0.4))
    tf = TFBuffer()
    for ns, msg in got["/odom/ground_truth"]:
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        tf.add("world", "base_link", ns, (p.x, p.y, p.z), (q.x, q.y, q.z, q.w))
    mount = sim._mounts["livox_frame"]
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.t.geometry.TriangleMesh.from_legacy(world_mesh(sim.world)))
    ns, cloud = got["/livox/lidar"][-1]
    pts = read_points(cloud)
    assert len(pts) >= 10_000
    assert set(pts.dtype.names) == {"x", "y", "z", "intensity", "ring", "time"}
    assert cloud.point_step == 22 and pts["time"].min() >= -0.1 - 1e-6 and pts["time"].max() <= 0.0
    world_pts = np.empty((len(pts), 3))
    for t in np.unique(pts["time"]):
        sel = pts["time"] == t
        pose = tf.lookup("world", "base_link", ns + int(round(float(t) * 1e9))) @ mount
        local = np.stack([pts["x"][sel], pts["y"][sel], pts["z"][sel]], axis=1).astype(np.float64)
        world_pts[sel] = local @ pose[:3, :3].T + pose[:3, 3]
    dist = scene.compute_distance(o3d.core.Tensor(world_pts.astype(np.float32))).numpy()
    assert np.mean(dist < 0.02) >= 0.99


def test_ground_truth_equals_mujoco_body_pose_and_tf_is_consistent():
    sim, got = run_sim(until_ns=2_000_000_000, cmd=(0.3, 0.1, 0.3))
    ns, gt = got["/odom/ground_truth"][-1]
    assert ns == 2_000_000_000
    base = sim.base_pose()
    p, q = gt.pose.pose.position, gt.pose.pose.orientation
    assert np.allclose([p.x, p.y, p.z], base[:3, 3], atol=1e-12)
    assert np.allclose(quat_to_matrix((q.x, q.y, q.z, q.w)), base[:3, :3], atol=1e-9)
    assert gt.header.frame_id == "world" and gt.child_frame_id == "base_link"
    tf = TFBuffer()
    for _, m in got["/tf_static"]:
        tf.add_message(m, static=True)
    for _, m in got["/tf"]:
        tf.add_message(m)
    assert set(tf.frames()) == {
        "world",
        "map",
        "odom",
        "base_footprint",
        "base_link",
        "front_laser",
        "livox_frame",
        "imu_link",
    }
    # map -> base_link through map -> odom -> base_footprint -> base_link is the true pose
    assert np.allclose(tf.lookup("map", "base_link", ns), base, atol=1e-9)
    assert np.allclose(tf.lookup("map", "livox_frame", ns), base @ sim._mounts["livox_frame"], atol=1e-9)
    # /odom drifts from the truth but stays close after 2 s
    _, odom = got["/odom"][-1]
    assert odom.header.frame_id == "odom" and odom.child_frame_id == "base_footprint"
    drift = math.hypot(odom.pose.pose.position.x - p.x, odom.pose.pose.position.y - p.y)
    assert 0.0 < drift < 0.1


def test_legged_base_tracks_limits_sways_and_stops_on_timeout():
    sim, got = run_sim(until_ns=6_000_000_000, cmd=(1.0, 0.0, 0.0))
    speeds = [m.twist.twist.linear.x for _, m in got["/odom/ground_truth"]]
    assert max(speeds) == pytest.approx(0.3, abs=0.01)  # clamped to CHAMP's max_vx
    # 63 % of the step after about one response time (0.25 s) from the first command
    t63 = next(ns for ns, m in got["/odom/ground_truth"] if m.twist.twist.linear.x >= 0.63 * 0.3)
    assert 0.15e9 <= t63 <= 0.45e9
    rolls = [abs(m.angular_velocity.x) for _, m in got["/imu/data"][200:]]
    assert max(rolls) > 0.01  # the gait sway reaches the IMU


def test_cmd_vel_timeout_stops_robot():
    ex = Executor()
    sim = SimNode(load_world("indoor_room"), load_robot("go2"), SimOptions(seed=0, noise=False))
    ex.add_node(sim, source=True)

    class OneShot(Node):
        def setup(self):
            self.create_timer(50_000_000, self.tick, 0)

        def tick(self, t):
            if t <= 2_000_000_000:
                self.publish("/cmd_vel", messages.TWIST, messages.twist(0.3, 0.0, 0.0))

    ex.add_node(OneShot())
    ex.run(until_ns=2_400_000_000)
    lin, _ = sim.base_velocity()
    assert lin[0] > 0.25  # still walking 0.4 s after the last command
    ex.run(until_ns=4_500_000_000)
    lin, _ = sim.base_velocity()
    assert abs(lin[0]) < 0.005  # stopped after cmd_vel_timeout (0.5 s) and the response


def test_livox_pattern_is_non_repetitive_and_on_surfaces():
    import dataclasses

    import open3d as o3d

    go2 = load_robot("go2")
    robot = dataclasses.replace(
        go2, lidar=dataclasses.replace(go2.lidar, pattern="livox_mid360", points=20000, vertical_fov=(-7.0, 52.0))
    )
    ex = Executor()
    sim = SimNode(load_world("indoor_room"), robot, SimOptions(seed=1, noise=False))
    ex.add_node(sim, source=True)
    col = _Collect(["/livox/lidar"])
    ex.add_node(col)
    ex.run(until_ns=300_000_000)
    (t1, c1), (t2, c2) = col.got["/livox/lidar"][:2]
    p1, p2 = read_points(c1), read_points(c2)
    assert len(p1) > 8000 and len(p2) > 8000  # of 20000 rays: those above the 2.5 m walls find nothing (no ceiling)
    d1 = np.stack([p1["x"], p1["y"], p1["z"]], 1)
    d2 = np.stack([p2["x"], p2["y"], p2["z"]], 1)
    assert not np.allclose(d1[:1000], d2[:1000])  # successive frames cover other directions
    elev = np.degrees(np.arctan2(d1[:, 2], np.hypot(d1[:, 0], d1[:, 1])))
    assert elev.min() >= -7.01 and elev.max() <= 52.01
    # standing still: every point lies on a surface of the world
    pose = sim.base_pose() @ sim._mounts["livox_frame"]
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.t.geometry.TriangleMesh.from_legacy(world_mesh(sim.world)))
    world_pts = d1 @ pose[:3, :3].T + pose[:3, 3]
    dist = scene.compute_distance(o3d.core.Tensor(world_pts.astype(np.float32))).numpy()
    assert np.mean(dist < 0.005) >= 0.999
