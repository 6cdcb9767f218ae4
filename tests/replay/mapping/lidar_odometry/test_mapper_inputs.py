"""The 3D mapper node on the clouds real drivers send: no time field (motion deskew), driver time
conventions, broken times, NaN/huge/no points, and the IMU's gravity for a level map frame."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from navlog.replay import messages
from navlog.replay.nodes.lidar_mapper import LidarMapperParams
from navlog.replay.pointcloud import make_cloud
from navlog.replay.runtime.executor import Envelope
from tests.replay import lidar_scene as scene
from tests.replay.mapping.lidar_odometry.helpers import ate_rmse, initial_pose_params, run_node

pytestmark = pytest.mark.slow

XYZ = (("x", 0, 7), ("y", 4, 7), ("z", 8, 7))


def cloud_envelopes(seq: scene.Sequence, layout, columns_of, clock_ns: int = 0) -> list[Envelope]:
    """/livox/lidar clouds of ``seq`` in another field ``layout`` (name, offset, type code), each
    frame's columns from ``columns_of(frame, stamp_ns)``, header stamps ``clock_ns`` later."""
    step = max(off for _, off, _ in layout) + 8
    return [
        Envelope(
            "/livox/lidar",
            messages.POINT_CLOUD2,
            f.stamp_ns + scene.SWEEP_NS_INT,
            make_cloud(f.stamp_ns + clock_ns, "livox_frame", columns_of(f, f.stamp_ns + clock_ns), layout, step),
        )
        for f in seq.frames
    ]


def without_clouds(seq: scene.Sequence) -> scene.Sequence:
    return scene.Sequence([], seq.imu_ns, seq.gyro, seq.accel, seq.trajectory, seq.extrinsic)


def run_with_clouds(seq: scene.Sequence, params: LidarMapperParams, clouds: list[Envelope]):
    node, _ = run_node(without_clouds(seq), params, clouds)
    return node


def xyz_columns(f: scene.Frame, stamp_ns: int = 0) -> dict[str, np.ndarray]:
    return {"x": f.points[:, 0], "y": f.points[:, 1], "z": f.points[:, 2]}


@pytest.fixture(scope="module")
def spin_seq(room) -> scene.Sequence:
    # spinning at 1.5 rad/s: a sweep turns 8.6 deg, so deskew decides the accuracy
    return scene.make_sequence(scene.spin_trajectory(rate=1.5, speed=0.3), 30, scene=room)


def test_without_a_time_field_the_motion_model_deskews_as_well_as_the_times(spin_seq):
    base = dataclasses.replace(initial_pose_params(spin_seq), use_imu=False)
    with_times = run_node(spin_seq, base)[0]
    clouds = cloud_envelopes(spin_seq, XYZ, xyz_columns)
    motion = run_with_clouds(spin_seq, base, clouds)
    off = run_with_clouds(spin_seq, dataclasses.replace(base, deskew="off"), clouds)
    ate = {name: ate_rmse(*n.poses(), spin_seq) for name, n in (("t", with_times), ("m", motion), ("off", off))}
    assert ate["t"] <= 0.02 and ate["m"] <= 0.02 and ate["off"] >= 0.05
    assert motion.notes["time_field"].startswith("no per-point time field among x, y, z: deskewing with the motion")
    assert "time_field" not in off.notes and len(off.poses()[0]) == 30


CLOCK_NS = 1_700_000_000_000_000_000  # header stamps of a real clock (2023)


@pytest.mark.parametrize(
    ("layout", "columns"),
    [
        # Ouster: t uint32 ns after the stamp
        ((*XYZ, ("t", 12, 6)), lambda f, s: {**xyz_columns(f), "t": np.round(f.times * 1e9).astype(np.uint32)}),
        # Livox: offset_time uint32 ns
        ((*XYZ, ("offset_time", 12, 6)), lambda f, s: {**xyz_columns(f), "offset_time": np.round(f.times * 1e9)}),
        # Hesai: timestamp float64 absolute seconds
        ((*XYZ, ("timestamp", 16, 8)), lambda f, s: {**xyz_columns(f), "timestamp": s * 1e-9 + f.times.astype(float)}),
    ],
    ids=["ouster", "livox", "hesai"],
)
def test_driver_time_fields_deskew_like_navlog_s(spin_seq, layout, columns):
    base = dataclasses.replace(initial_pose_params(spin_seq), use_imu=False)
    node = run_with_clouds(spin_seq, base, cloud_envelopes(spin_seq, layout, columns, CLOCK_NS))
    stamps, poses = node.poses()
    assert len(stamps) == 30 and ate_rmse(stamps - CLOCK_NS, poses, spin_seq) <= 0.02
    name = layout[-1][0]
    assert node.notes["time_field"].startswith(f"per-point time from field '{name}'")


def test_broken_times_and_coordinates_are_counted_not_fatal(room):
    seq = scene.make_sequence(scene.loop_trajectory(), 12, scene=room)
    frames = list(seq.frames)
    f = frames[4]
    times = f.times.copy()
    times[:30], times[30:40], times[40:45] = np.nan, np.inf, 3.0e30  # a bit-flipped time field
    frames[4] = scene.Frame(f.stamp_ns, f.points, times, f.rings)
    g = frames[7]
    pts = g.points.copy()
    pts[:20] = 1.0e30  # huge coordinates
    pts[20:25, 2] = -np.inf
    frames[7] = scene.Frame(g.stamp_ns, pts, g.times, g.rings)
    h = frames[9]  # a cloud whose every time is NaN
    frames[9] = scene.Frame(h.stamp_ns, h.points, np.full_like(h.times, np.nan), h.rings)
    seq = scene.Sequence(frames, seq.imu_ns, seq.gyro, seq.accel, seq.trajectory, seq.extrinsic)
    huge = scene.Frame(1_150_000_000, np.full((500, 3), 3.0e38, np.float32), np.zeros(500, np.float32), h.rings[:500])
    extra = [Envelope("/livox/lidar", messages.POINT_CLOUD2, 1_250_000_000, scene.cloud_msg(huge))]
    node, _ = run_node(seq, initial_pose_params(seq), extra)
    assert node.skipped_counts() == {
        "cloud_no_finite_points": 1,  # all NaN times
        "points_not_finite": 5,
        "points_time_invalid": 45 + len(h.times),
        "too_few_points": 1,  # every point 3e38 m away: beyond max_range
    }
    stamps, poses = node.poses()
    assert len(stamps) == 11 and ate_rmse(stamps, poses, seq) <= 0.03


def tilted_at_rest(t: np.ndarray) -> np.ndarray:
    """Standing still, body rolled 3 deg and pitched -2 deg, yaw 40 deg, then drifting at a constant 0.2 m/s."""
    t = np.asarray(t, dtype=np.float64)
    out = np.tile(np.eye(4), (len(t), 1, 1))
    out[:, :3, :3] = Rotation.from_euler("xyz", [3.0, -2.0, 40.0], degrees=True).as_matrix()
    out[:, 0, 3] = 0.2 * np.clip(t - 0.5, 0.0, None) - 1.0
    out[:, 2, 3] = 0.32
    return out


def test_the_imu_levels_the_map_frame_when_at_rest(room):
    seq = scene.make_sequence(tilted_at_rest, 10, scene=room)
    node, _ = run_node(seq, LidarMapperParams())
    _, poses = node.poses()
    roll, pitch, yaw = Rotation.from_matrix(poses[0, :3, :3]).as_euler("xyz", degrees=True)
    assert abs(roll - 3.0) < 0.05 and abs(pitch + 2.0) < 0.05 and abs(yaw) < 1e-6  # the map's yaw: the body's
    assert node.notes["gravity"].startswith("map frame levelled with the IMU's gravity")
    # the floor of the room (z = 0 in the world) is level in the map, 0.32 m below the first base_link
    map_pts = node.map_points()
    floor = map_pts[np.abs(map_pts[:, 2] + 0.32) < 0.05]
    assert len(floor) > 1000 and np.ptp(np.percentile(floor[:, 2], [5, 95])) < 0.03
    # without the IMU the map frame is the first base_link: tilted
    flat, _ = run_node(seq, LidarMapperParams(use_imu=False))
    assert np.allclose(flat.poses()[1][0], np.eye(4), atol=1e-9) and "gravity" not in flat.notes


def test_a_moving_start_does_not_tilt_the_map(room):
    # the loop starts accelerating: the accel is not gravity alone, the map stays the first base_link
    seq = scene.make_sequence(scene.loop_trajectory(), 5, scene=room)
    node, _ = run_node(seq, LidarMapperParams())
    assert node.notes["gravity"].startswith("map frame not levelled: the IMU was not at rest")
    assert np.allclose(node.poses()[1][0][:3, :3], np.eye(3), atol=1e-9)
