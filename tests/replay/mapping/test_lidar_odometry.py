"""The 3D LiDAR mapper on a ray-cast room with exact ground truth (see tests/replay/lidar_scene.py)."""

from __future__ import annotations

import hashlib

import numpy as np
import open3d as o3d
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from navlog.errors import ConfigError
from navlog.replay import messages
from navlog.replay.config import from_mapping
from navlog.replay.mapping.lidar_odometry import GyroTrack, LidarOdometry, LidarOdometryParams, MotionPrior, PoseTrack
from navlog.replay.nodes.lidar_mapper import LidarMapperNode, LidarMapperParams
from navlog.replay.pointcloud import make_cloud, xyz
from navlog.replay.runtime.executor import Envelope, Executor
from tests.replay import lidar_scene as scene

SWEEP_NS = 100_000_000
cloud_msg = scene.cloud_msg
envelopes = scene.envelopes


# ---------------------------------------------------------------- helpers


class Recorder:
    def __init__(self) -> None:
        self.items: list[tuple[str, int, bytes]] = []

    def write(self, env: Envelope) -> None:
        if env.topic in ("/Odometry", "/cloud_registered", "/lidar_mapper/path"):
            self.items.append((env.topic, env.time_ns, messages.serialize(env.msg, env.typename)))

    def digest(self) -> str:
        h = hashlib.sha256()
        for topic, t, data in self.items:
            h.update(f"{topic}:{t}:".encode())
            h.update(data)
        return h.hexdigest()


def run_node(
    seq: scene.Sequence, params: LidarMapperParams, extra: list[Envelope] = ()
) -> tuple[LidarMapperNode, Recorder]:
    ex = Executor()
    node = LidarMapperNode(params)
    ex.add_node(node)
    rec = Recorder()
    ex.add_sink(rec)
    ex.add_source(envelopes(seq, extra))
    ex.run()
    ex.finish()
    return node, rec


def initial_pose_params(seq: scene.Sequence, **odometry) -> LidarMapperParams:
    g = seq.ground_truth([seq.frames[0].stamp_ns])[0]
    rpy = Rotation.from_matrix(g[:3, :3]).as_euler("xyz")
    return LidarMapperParams(initial_pose=(*g[:3, 3], *rpy), odometry=LidarOdometryParams(**odometry))


def ate_rmse(stamps: np.ndarray, poses: np.ndarray, seq: scene.Sequence) -> float:
    gt = seq.ground_truth(stamps)
    return float(np.sqrt(np.mean(np.sum((poses[:, :3, 3] - gt[:, :3, 3]) ** 2, axis=1))))


def share_within(points: np.ndarray, tau: float, mesh_scene) -> float:
    d = mesh_scene.compute_distance(o3d.core.Tensor(np.asarray(points, dtype=np.float32))).numpy()
    return float(np.mean(d <= tau))


# ---------------------------------------------------------------- fixtures


@pytest.fixture(scope="module")
def room():
    return scene.raycasting_scene(scene.room_mesh())


@pytest.fixture(scope="module")
def loop_seq(room) -> scene.Sequence:
    # 0.3 m/s on a 0.6 m circle from rest: 12 s closes the loop (plus the 1 s ramp)
    return scene.make_sequence(scene.loop_trajectory(speed=0.3, radius=0.6), 130, scene=room)


@pytest.fixture(scope="module")
def loop_run(loop_seq, tmp_path_factory):
    node, rec = run_node(loop_seq, initial_pose_params(loop_seq))
    pcd = tmp_path_factory.mktemp("map") / "map.pcd"
    node.save_pcd(pcd)
    return node, rec, pcd


# ---------------------------------------------------------------- behaviour


def test_loop_trajectory_error_within_3cm(loop_seq, loop_run):
    node, rec, _ = loop_run
    stamps, poses = node.poses()
    assert len(stamps) == len(loop_seq.frames)
    assert ate_rmse(stamps, poses, loop_seq) <= 0.03
    # closing the loop: the last pose is still within 3 cm of the truth
    gt_last = loop_seq.ground_truth(stamps[-1:])[0]
    assert np.linalg.norm(poses[-1, :3, 3] - gt_last[:3, 3]) <= 0.03
    assert node.skipped_counts() == {}


def test_published_outputs(loop_seq, loop_run):
    node, rec, _ = loop_run
    topics = [t for t, _, _ in rec.items]
    assert topics.count("/Odometry") == len(loop_seq.frames)
    assert topics.count("/cloud_registered") == -(-len(loop_seq.frames) // 5)  # every 5th frame, the first included
    assert topics.count("/lidar_mapper/path") == len(loop_seq.frames) // 50 + 1
    odo = [messages.deserialize(d, messages.ODOMETRY) for t, _, d in rec.items if t == "/Odometry"]
    assert (odo[0].header.frame_id, odo[0].child_frame_id) == ("map", "base_link")
    assert [messages.to_ns(o.header.stamp) for o in odo] == [f.stamp_ns for f in loop_seq.frames]
    # the registered cloud lies on the room's surfaces
    cloud = messages.deserialize(
        next(d for t, _, d in reversed(rec.items) if t == "/cloud_registered"), messages.POINT_CLOUD2
    )
    assert cloud.header.frame_id == "map"
    path = messages.deserialize(next(d for t, _, d in reversed(rec.items) if t == "/lidar_mapper/path"), messages.PATH)
    assert len(path.poses) == len(loop_seq.frames)


def test_registered_cloud_and_saved_map_lie_on_the_true_surfaces(room, loop_run):
    node, rec, pcd_path = loop_run
    cloud = messages.deserialize(
        next(d for t, _, d in reversed(rec.items) if t == "/cloud_registered"), messages.POINT_CLOUD2
    )
    assert share_within(xyz(cloud), 0.05, room) >= 0.95
    header = pcd_path.read_bytes()[:300]
    assert b"SIZE 4 4 4" in header and b"TYPE F F F" in header and b"DATA binary" in header
    pcd = o3d.io.read_point_cloud(str(pcd_path))
    pts = np.asarray(pcd.points)
    assert len(pts) > 10_000
    assert share_within(pts, 0.05, room) >= 0.95
    # voxel-filtered at save_voxel: no two points closer than a small fraction of it
    d, _ = cKDTree(pts).query(pts, k=2)
    assert np.median(d[:, 1]) >= 0.5 * LidarOdometryParams().save_voxel


def test_two_runs_give_identical_bytes(loop_seq, loop_run, tmp_path):
    node1, rec1, pcd1 = loop_run
    seq = scene.Sequence(
        loop_seq.frames[:60], loop_seq.imu_ns, loop_seq.gyro, loop_seq.accel, loop_seq.trajectory, loop_seq.extrinsic
    )
    node2, rec2 = run_node(seq, initial_pose_params(seq))
    node3, rec3 = run_node(seq, initial_pose_params(seq))
    assert rec2.digest() == rec3.digest()
    node2.save_pcd(tmp_path / "a.pcd")
    node3.save_pcd(tmp_path / "b.pcd")
    assert (tmp_path / "a.pcd").read_bytes() == (tmp_path / "b.pcd").read_bytes()
    # a prefix of the long run gives the same /Odometry bytes as the short run
    odo1 = [d for t, _, d in rec1.items if t == "/Odometry"][:60]
    odo2 = [d for t, _, d in rec2.items if t == "/Odometry"]
    assert odo1 == odo2


def test_deskew_reduces_error_on_a_fast_rotating_sweep(room):
    seq = scene.make_sequence(scene.spin_trajectory(rate=1.5, speed=0.2), 30, scene=room)
    gt0 = seq.ground_truth([0])[0]
    results = {}
    for deskew in (True, False):
        gyro, j = GyroTrack(), 0
        odo = LidarOdometry(LidarOdometryParams(deskew=deskew), seq.extrinsic, gt0)
        for f in seq.frames:
            while j < len(seq.imu_ns) and seq.imu_ns[j] <= f.stamp_ns + SWEEP_NS:
                gyro.add(int(seq.imu_ns[j]), seq.gyro[j])
                j += 1
            odo.process(f.stamp_ns, f.points, f.times, MotionPrior(gyro=gyro))
        stamps, poses = odo.poses()
        results[deskew] = (ate_rmse(stamps, poses, seq), share_within(odo.global_map(), 0.02, room))
    (ate_on, acc_on), (ate_off, acc_off) = results[True], results[False]
    assert ate_on <= 0.03
    assert ate_on < 0.5 * ate_off
    assert acc_on > acc_off + 0.1


def test_gicp_and_odometry_prior(room):
    seq = scene.make_sequence(scene.loop_trajectory(), 40, scene=room)
    gt = seq.ground_truth([f.stamp_ns for f in seq.frames])
    odom = PoseTrack()
    drift = Rotation.from_euler("z", 0.05).as_matrix()  # a drifting odometry frame: only relative motion is used
    for t in np.arange(0, 4.1, 0.02):
        g = seq.ground_truth([int(round(t * 1e9))])[0]
        g[:3, :3] = drift @ g[:3, :3]
        g[:3, 3] = drift @ g[:3, 3] + [1.0, 2.0, 0.0]
        odom.add(int(round(t * 1e9)), g)
    odo = LidarOdometry(LidarOdometryParams(method="gicp"), seq.extrinsic, gt[0])
    for f in seq.frames:
        odo.process(f.stamp_ns, f.points, f.times, MotionPrior(odom=odom))
    stamps, poses = odo.poses()
    assert len(stamps) == 40
    assert ate_rmse(stamps, poses, seq) <= 0.03


def test_chunks_every_n_frames(room):
    seq = scene.make_sequence(scene.loop_trajectory(), 12, scene=room)
    odo = LidarOdometry(LidarOdometryParams(save_every_n_frames=5), seq.extrinsic, seq.ground_truth([0])[0])
    for f in seq.frames:
        odo.process(f.stamp_ns, f.points, f.times)
    chunks = odo.finish_chunks()
    assert len(chunks) == 3  # frames 1-5, 6-10, 11-12
    assert all(share_within(c, 0.05, room) >= 0.95 for c in chunks)
    full = odo.global_map()
    assert max(len(c) for c in chunks) <= len(full)


# ---------------------------------------------------------------- bad input


def test_bad_clouds_are_counted_not_fatal(room):
    seq = scene.make_sequence(scene.loop_trajectory(), 12, scene=room)
    bad = []
    # an empty cloud
    bad.append(
        Envelope(
            "/livox/lidar",
            messages.POINT_CLOUD2,
            250_000_000,
            make_cloud(150_000_000, "livox_frame", {"x": np.zeros(0, np.float32)}),
        )
    )
    # a cloud without x/y/z
    no_xyz = make_cloud(350_000_000, "livox_frame", {"intensity": np.ones(5, np.float32)}, (("intensity", 0, 7),), 4)
    bad.append(Envelope("/livox/lidar", messages.POINT_CLOUD2, 450_000_000, no_xyz))
    # a cloud in a frame with no transform to base_link
    f = seq.frames[3]
    bad.append(
        Envelope(
            "/livox/lidar",
            messages.POINT_CLOUD2,
            650_000_000,
            cloud_msg(scene.Frame(f.stamp_ns + 50_000_000, f.points, f.times, f.rings), "unknown_frame"),
        )
    )
    # NaN points inside an otherwise good frame
    g = seq.frames[6]
    pts = g.points.copy()
    pts[:100, 0] = np.nan
    seq.frames[6] = scene.Frame(g.stamp_ns, pts, g.times, g.rings)
    node, rec = run_node(seq, initial_pose_params(seq), bad)
    counts = node.skipped_counts()
    assert counts == {"cloud_empty": 1, "cloud_without_xyz": 1, "cloud_missing_extrinsic": 1, "points_not_finite": 100}
    stamps, poses = node.poses()
    assert len(stamps) == 12  # every good frame was still registered
    assert ate_rmse(stamps, poses, seq) <= 0.03


def test_all_nan_and_too_few_points_are_counted():
    odo = LidarOdometry(LidarOdometryParams())
    assert odo.process(0, np.full((50, 3), np.nan)) is None
    assert odo.process(1, np.ones((3, 3))) is None
    assert odo.process(2, np.ones((10, 3)), np.zeros(4)) is None
    assert odo.skipped == {"too_few_points": 2, "time_field_length_mismatch": 1}
    assert len(odo.poses()[0]) == 0


def test_parameters_are_validated_with_names():
    with pytest.raises(ConfigError, match="scan_voxl.*did you mean 'scan_voxel'"):
        from_mapping(LidarMapperParams, {"odometry": {"scan_voxl": 0.2}})
    with pytest.raises(ConfigError, match="method.*'gicp'"):
        from_mapping(LidarMapperParams, {"odometry": {"method": "gicpp"}})
    with pytest.raises(ConfigError, match="scan_voxel must be positive"):
        from_mapping(LidarOdometryParams, {"scan_voxel": 0.0})
    params = from_mapping(
        LidarMapperParams, {"cloud_every_n_frames": 5, "odometry": {"method": "gicp", "deskew": False}}
    )
    assert params.odometry.method == "gicp" and params.cloud_every_n_frames == 5


def test_gyro_track_integrates_a_known_rate():
    gyro = GyroTrack()
    for k in range(41):  # 0.5 rad/s about z for 0.2 s
        gyro.add(k * 5_000_000, (0.0, 0.0, 0.5))
    rel = gyro.relative_rotations(50_000_000, np.array([150_000_000, 0]))
    angles = Rotation.from_matrix(rel).as_rotvec()
    np.testing.assert_allclose(angles, [[0, 0, 0.05], [0, 0, -0.025]], atol=1e-12)
    assert gyro.relative_rotations(0, np.array([300_000_000])) is None  # beyond the data: no guess


def test_node_uses_drifting_odom_without_imu(room):
    seq = scene.make_sequence(scene.loop_trajectory(), 30, scene=room)
    drift = Rotation.from_euler("z", 0.1).as_matrix()
    odom = []
    for k in range(0, 3100_000_000 + 1, 20_000_000):
        g = seq.ground_truth([k])[0]
        p, r = drift @ g[:3, 3] + [0.5, -0.2, -0.32], drift @ g[:3, :3]  # odom -> base_footprint, rotated and offset
        msg = messages.odometry(
            k, "odom", "base_footprint", p, messages.matrix_to_quat(r), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        )
        odom.append(Envelope("/odom", messages.ODOMETRY, k, msg))
    params = initial_pose_params(seq)
    params = LidarMapperParams(initial_pose=params.initial_pose, use_imu=False)
    node, rec = run_node(
        scene.Sequence(seq.frames, seq.imu_ns[:0], seq.gyro[:0], seq.accel[:0], seq.trajectory, seq.extrinsic),
        params,
        odom,
    )
    assert node.skipped_counts() == {"odom_base_transform_assumed_identity": 1}
    assert node.odom.last_ns == 3_100_000_000
    stamps, poses = node.poses()
    assert len(stamps) == 30
    assert ate_rmse(stamps, poses, seq) <= 0.03
