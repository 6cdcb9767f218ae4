"""The 3D LiDAR mapper node on a ray-cast room with exact ground truth (see tests/replay/lidar_scene.py):
accuracy, published topics, the saved map, determinism, and inputs it cannot use."""

from __future__ import annotations

import dataclasses
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from navlog.replay import messages
from navlog.replay.io.pcd import read_pcd
from navlog.replay.mapping.lidar_odometry import LidarOdometryParams
from navlog.replay.nodes.lidar_mapper import LidarMapperNode, LidarMapperParams
from navlog.replay.pointcloud import make_cloud, xyz
from navlog.replay.runtime.executor import Envelope, Executor, Node
from tests.replay import lidar_scene as scene
from tests.replay.mapping.lidar_odometry.helpers import Recorder, ate_rmse, initial_pose_params, run_node, share_within

pytestmark = pytest.mark.slow

cloud_msg = scene.cloud_msg


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
    pts = read_pcd(pcd_path)
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
    # a cloud whose stamp's nanosec is a second or more (4294967295): not a time, it would carry into sec
    f = seq.frames[4]
    not_a_time = cloud_msg(scene.Frame(f.stamp_ns + 50_000_000, f.points, f.times, f.rings), "livox_frame")
    not_a_time = dataclasses.replace(
        not_a_time,
        header=dataclasses.replace(
            not_a_time.header, stamp=dataclasses.replace(not_a_time.header.stamp, nanosec=4_294_967_295)
        ),
    )
    bad.append(Envelope("/livox/lidar", messages.POINT_CLOUD2, 850_000_000, not_a_time))
    # NaN points inside an otherwise good frame
    g = seq.frames[6]
    pts = g.points.copy()
    pts[:100, 0] = np.nan
    seq.frames[6] = scene.Frame(g.stamp_ns, pts, g.times, g.rings)
    node, rec = run_node(seq, initial_pose_params(seq), bad)
    counts = node.skipped_counts()
    assert counts == {
        "cloud_empty": 1,
        "cloud_without_xyz": 1,
        "cloud_missing_extrinsic": 1,
        "cloud_stamp_invalid": 1,
        "points_not_finite": 100,
    }
    stamps, poses = node.poses()
    assert len(stamps) == 12  # every good frame was still registered
    assert ate_rmse(stamps, poses, seq) <= 0.03


def odom_envelopes(seq: scene.Sequence, until_ns: int, yaw: float = 0.1) -> list[Envelope]:
    """/odom at 50 Hz up to ``until_ns``: odom -> base_footprint, rotated by ``yaw`` and offset from the truth."""
    drift = Rotation.from_euler("z", yaw).as_matrix()
    odom = []
    for k in range(0, until_ns + 1, 20_000_000):
        g = seq.ground_truth([k])[0]
        p, r = drift @ g[:3, 3] + [0.5, -0.2, -0.32], drift @ g[:3, :3]
        msg = messages.odometry(
            k, "odom", "base_footprint", p, messages.matrix_to_quat(r), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
        )
        odom.append(Envelope("/odom", messages.ODOMETRY, k, msg))
    return odom


def without_imu(seq: scene.Sequence) -> scene.Sequence:
    return scene.Sequence(seq.frames, seq.imu_ns[:0], seq.gyro[:0], seq.accel[:0], seq.trajectory, seq.extrinsic)


def test_node_uses_drifting_odom_without_imu(room):
    seq = scene.make_sequence(scene.loop_trajectory(), 30, scene=room)
    params = LidarMapperParams(initial_pose=initial_pose_params(seq).initial_pose, use_imu=False)
    node, rec = run_node(without_imu(seq), params, odom_envelopes(seq, 3_100_000_000))
    assert node.skipped_counts() == {"odom_base_transform_assumed_identity": 1}
    assert node.odom.last_ns == 3_100_000_000
    stamps, poses = node.poses()
    assert len(stamps) == 30
    assert ate_rmse(stamps, poses, seq) <= 0.03


@pytest.mark.parametrize(
    ("odom_until_ns", "imu"), [(3_100_000_000, False), (1_500_000_000, False), (1_500_000_000, True)]
)
def test_sweeps_prepared_ahead_give_the_same_bytes(room, tmp_path, odom_until_ns, imu):
    """With the odometry's motion known when a sweep is ready, the sweep is prepared in the sweep process
    while the one before registers, and its outputs take their place when planned: the same messages,
    in the same order, and the same map as one sweep after another. Where /odom stops (half-way), the
    motion needs the constant velocity of the frames before: they complete first (with the gyro's
    rotation over the sweep, where there is an IMU)."""
    seq = scene.make_sequence(scene.loop_trajectory(), 30, scene=room)
    initial = initial_pose_params(seq).initial_pose
    params = LidarMapperParams(initial_pose=initial, use_imu=imu, path_every_n_frames=7)
    runs, mids = [], []
    for ahead in (False, True):
        ex = Executor()
        node = LidarMapperNode(params, sweep_process=ahead)
        ex.add_node(node)
        rec = Recorder()
        ex.add_sink(rec)
        ex.add_source(scene.envelopes(seq if imu else without_imu(seq), odom_envelopes(seq, odom_until_ns)))
        ex.run(until_ns=seq.frames[20].stamp_ns)
        mid = node.map_points()  # before the end: the frames in flight complete first
        ex.run()
        ex.finish()
        node.save_pcd(tmp_path / f"{ahead}.pcd")
        runs.append((node, rec, (tmp_path / f"{ahead}.pcd").read_bytes()))
        mids.append(mid)
    (one, rec_one, pcd_one), (two, rec_two, pcd_two) = runs
    assert mids[0].tobytes() == mids[1].tobytes() and 0 < len(mids[0]) < len(one.map_points())
    assert one._frames._maps is None and two._frames._maps is not None  # the second ran in the child
    assert two._frames.frames == len(two.odometry.stamps) > 5
    assert len(one.poses()[0]) == 30
    assert [(t, n) for t, n, _ in rec_one.items] == [(t, n) for t, n, _ in rec_two.items]
    assert rec_one.digest() == rec_two.digest() and pcd_one == pcd_two


def test_outputs_a_node_reads_are_published_when_the_sweep_is_registered(room):
    """A node reading /Odometry gets it at once: sweeps are then not prepared ahead."""
    seq = scene.make_sequence(scene.loop_trajectory(), 10, scene=room)
    params = LidarMapperParams(initial_pose=initial_pose_params(seq).initial_pose, use_imu=False)
    ex = Executor()
    node = LidarMapperNode(params, sweep_process=True)
    ex.add_node(node)
    heard: list[int] = []

    class Listener(Node):
        def setup(self) -> None:
            self.subscribe("/Odometry", lambda msg, t: heard.append(messages.to_ns(msg.header.stamp)))

    ex.add_node(Listener())
    ex.add_source(scene.envelopes(without_imu(seq), odom_envelopes(seq, 1_100_000_000)))
    ex.run()
    ex.finish()
    assert node._frames is not None and not node._frames.offloaded
    assert heard == [f.stamp_ns for f in seq.frames]


def test_path_is_the_same_bytes_as_its_message_whether_or_not_a_node_reads_it(room):
    """Where no node reads the path, its CDR is made straight from the poses; where one does, the node
    gets the message: the two give the same bytes, and the path holds every pose in order."""
    seq = scene.make_sequence(scene.loop_trajectory(), 12, scene=room)
    params = LidarMapperParams(initial_pose=initial_pose_params(seq).initial_pose, use_imu=False, path_every_n_frames=5)
    paths, heard = [], []

    class Listener(Node):
        def setup(self) -> None:
            self.subscribe("/lidar_mapper/path", lambda msg, t: heard.append(msg))

    for read in (False, True):
        ex = Executor()
        node = LidarMapperNode(params, sweep_process=False)
        ex.add_node(node)
        if read:
            ex.add_node(Listener())
        rec = Recorder()
        ex.add_sink(rec)
        kinds: list[bool] = []  # whether the sinks got the path as bytes
        ex.add_sink(
            SimpleNamespace(
                write=lambda env, kinds=kinds: kinds.append(isinstance(env.msg, bytes)) if "path" in env.topic else None
            )
        )
        ex.add_source(scene.envelopes(without_imu(seq), odom_envelopes(seq, 1_300_000_000)))
        ex.run()
        ex.finish()
        paths.append([d for t, _, d in rec.items if t == "/lidar_mapper/path"])
        assert kinds == [not read] * 3
        if read:
            assert [len(m.poses) for m in heard] == [5, 10, 12]
    assert len(paths[0]) == 3 and paths[0] == paths[1]
    last = messages.deserialize(paths[0][-1], messages.PATH)
    stamps, poses = node.poses()
    assert [messages.to_ns(p.header.stamp) for p in last.poses] == stamps.tolist()
    assert messages.to_ns(last.header.stamp) == stamps[-1] and last.header.frame_id == "map"
    assert np.array_equal(
        [[p.pose.position.x, p.pose.position.y, p.pose.position.z] for p in last.poses], poses[:, :3, 3]
    )
    q = [[p.pose.orientation.x, p.pose.orientation.y, p.pose.orientation.z, p.pose.orientation.w] for p in last.poses]
    assert np.allclose(Rotation.from_quat(q).as_matrix(), poses[:, :3, :3], atol=1e-12)
