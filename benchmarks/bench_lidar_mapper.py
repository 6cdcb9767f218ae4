"""3D LiDAR mapper speed and accuracy, side by side with KISS-ICP, on one synthetic sequence.

The sequence is the ray-cast room of tests/replay/lidar_scene.py (10 x 10 x 2.5 m, four boxes),
a 16 x 900 Velodyne-like sweep at 10 Hz with per-point times and 1 cm range noise, a loop driven
at 0.3 m/s from rest with body sway, and a 200 Hz IMU. Prints:

- navlog's mapper replayed through the executor (messages deserialized from CDR as a log reader
  would, then the node: deskew, registration, map, /Odometry, /cloud_registered): frames/s and the
  real-time factor (simulated seconds / wall seconds; the issue's target is >= 5x);
- KISS-ICP on the same frames (voxel set for indoors, per-point times for its deskew): frames/s;
- ATE RMSE of both against the ground truth, with no alignment (both start from the true pose),
  and the ratios.

KISS-ICP is a benchmark-only tool, NOT a dependency of navlog: `.venv/bin/pip install kiss-icp`.
Without it, its part is skipped with a message.

    .venv/bin/python benchmarks/bench_lidar_mapper.py [--frames 300] [--kiss-voxel 0.15]
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np
import open3d as o3d
from scipy.spatial.transform import Rotation

from navlog.analysis.metrics.trajectory import umeyama
from navlog.replay import messages
from navlog.replay.mapping.lidar_odometry import LidarOdometryParams
from navlog.replay.nodes.lidar_mapper import LidarMapperNode, LidarMapperParams
from navlog.replay.runtime.executor import Envelope, Executor
from tests.replay import lidar_scene as scene


def ate(positions: np.ndarray, truth: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum((positions - truth) ** 2, axis=1))))


def ate_aligned(positions: np.ndarray, truth: np.ndarray) -> float:
    """ATE RMSE after the SE(3) Umeyama alignment (evo's `-a`)."""
    a = umeyama(positions, truth)
    return ate(positions @ a.rotation.T + a.translation, truth)


def run_navlog(seq: scene.Sequence, params: LidarMapperParams) -> tuple[float, np.ndarray, np.ndarray, LidarMapperNode]:
    raw = [(e.topic, e.typename, e.time_ns, messages.serialize(e.msg, e.typename)) for e in scene.envelopes(seq)]

    def source():
        for topic, typename, t, data in raw:
            yield Envelope(topic, typename, t, messages.deserialize(data, typename))

    ex = Executor()
    node = LidarMapperNode(params)
    ex.add_node(node)
    t0, c0 = time.perf_counter(), time.process_time()
    ex.add_source(source())
    ex.run()
    ex.finish()
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    stamps, poses = node.poses()
    return wall, cpu, stamps, poses, node


def run_kiss(seq: scene.Sequence, voxel: float, threads: int):
    try:
        from kiss_icp.config import KISSConfig
        from kiss_icp.kiss_icp import KissICP
    except ImportError:
        return None
    cfg = KISSConfig()
    cfg.data.max_range = 30.0
    cfg.data.min_range = 0.3
    cfg.data.deskew = True
    cfg.mapping.voxel_size = voxel
    cfg.registration.max_num_threads = threads
    odom = KissICP(config=cfg)
    poses = []
    frames = [(f.points.astype(np.float64), f.times.astype(np.float64)) for f in seq.frames]
    t0 = time.perf_counter()
    for pts, times in frames:
        odom.register_frame(pts, times)
        poses.append(odom.last_pose.copy())
    return time.perf_counter() - t0, np.asarray(poses)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--frames", type=int, default=300, help="10 Hz frames (default 300 = 30 s)")
    ap.add_argument("--kiss-voxel", type=float, default=0.15, help="KISS-ICP voxel (0.1-0.2 indoors)")
    ap.add_argument("--kiss-threads", type=int, default=1, help="KISS-ICP threads (navlog's mapper uses 1)")
    ap.add_argument("--method", default="point_to_plane", choices=("point_to_plane", "gicp"))
    args = ap.parse_args()

    room = scene.raycasting_scene(scene.room_mesh())
    t0 = time.perf_counter()
    seq = scene.make_sequence(scene.loop_trajectory(speed=0.3, radius=1.5), args.frames, scene=room)
    n = len(seq.frames)
    sim_s = n * scene.SWEEP_S
    print(
        f"sequence: {n} frames ({sim_s:.1f} s), {np.mean([len(f.points) for f in seq.frames]):.0f} points/frame, "
        f"generated in {time.perf_counter() - t0:.1f} s"
    )

    g0 = seq.ground_truth([0])[0]
    rpy = Rotation.from_matrix(g0[:3, :3]).as_euler("xyz")
    params = LidarMapperParams(initial_pose=(*g0[:3, 3], *rpy), odometry=LidarOdometryParams(method=args.method))
    wall, cpu, stamps, poses, node = run_navlog(seq, params)
    gt = seq.ground_truth(stamps)
    ate_nav = ate(poses[:, :3, 3], gt[:, :3, 3])
    d = room.compute_distance(o3d.core.Tensor(node.map_points().astype(np.float32))).numpy()
    fps_nav = len(stamps) / wall
    print(
        f"navlog lidar_mapper ({args.method}): {fps_nav:.1f} frames/s, real-time factor {sim_s / wall:.1f}x "
        f"(target >= 5x; CPU time of this process: {sim_s / cpu:.1f}x, load average {os.getloadavg()[0]:.1f} "
        f"on {os.cpu_count()} cores), ATE RMSE {ate_nav * 100:.2f} cm "
        f"({ate_aligned(poses[:, :3, 3], gt[:, :3, 3]) * 100:.2f} cm SE(3)-aligned), map {len(d)} points, "
        f"{np.mean(d <= 0.05) * 100:.2f} % within 5 cm, {np.mean(d <= 0.02) * 100:.2f} % within 2 cm, skipped {node.skipped_counts()}"
    )

    kiss = run_kiss(seq, args.kiss_voxel, args.kiss_threads)
    if kiss is None:
        print("KISS-ICP: skipped (not installed; it is a benchmark-only tool: .venv/bin/pip install kiss-icp)")
        return
    kwall, kposes = kiss
    # KISS-ICP's poses are the sensor's, starting at identity, at the middle of each sweep
    mid = np.array([f.stamp_ns + int(round(0.5 * (f.times.min() + f.times.max()) * 1e9)) for f in seq.frames])
    g_mid = seq.ground_truth(mid)
    ext = seq.extrinsic
    est = (g_mid[0] @ ext) @ kposes @ np.linalg.inv(ext)
    ate_kiss = ate(est[:, :3, 3], g_mid[:, :3, 3])
    ate_kiss_al = ate_aligned(est[:, :3, 3], g_mid[:, :3, 3])
    fps_kiss = n / kwall
    print(
        f"KISS-ICP 1.x (voxel {args.kiss_voxel}, {args.kiss_threads} thread(s), deskew on): {fps_kiss:.1f} frames/s, "
        f"ATE RMSE {ate_kiss * 100:.2f} cm ({ate_kiss_al * 100:.2f} cm SE(3)-aligned)"
    )
    print(
        f"ratios: navlog/KISS-ICP frames/s = {fps_nav / fps_kiss:.2f} (includes navlog's message decoding and publishing); "
        f"KISS-ICP ATE / navlog ATE = {ate_kiss / ate_nav:.2f} (> 1: navlog more accurate)"
    )


if __name__ == "__main__":
    main()
