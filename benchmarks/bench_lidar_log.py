"""The 3D mapper and KISS-ICP side by side on one recorded navlog log (default: the mapping tour).

Both read the same /livox/lidar sweeps (per-point times, for their deskew); navlog's mapper also gets
/imu/data, /odom and /tf_static as it does in `navlog replay`. Printed: frames/s of each, the ratio,
and the ATE (SE(3)-aligned) of the LiDAR frame's trajectory against the ground truth, with the ratio.

KISS-ICP is a benchmark-only tool, NOT a dependency of navlog: `.venv/bin/pip install kiss-icp`.

    .venv/bin/python benchmarks/bench_lidar_log.py [--log run.mcap] [--kiss-voxel 0.15]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from navlog.analysis.metrics.trajectory import Trajectory, absolute_trajectory_error
from navlog.replay import messages
from navlog.replay.geometry import make_transform
from navlog.replay.io import open_log
from navlog.replay.nodes.lidar_mapper import LidarMapperNode
from navlog.replay.pointcloud import read_points
from navlog.replay.runtime.executor import Executor
from navlog.replay.runtime.tf import TFBuffer
from navlog.replay.session import pipeline_params


def lidar_frame_ground_truth(log: Path, frame: str) -> tuple[Trajectory, np.ndarray]:
    """Ground truth of the LiDAR frame (world) and the base_link -> LiDAR mount."""
    tf = TFBuffer()
    times, mats = [], []
    with open_log(log) as r:
        for env in r.messages(["/tf_static"]):
            tf.add_message(env.msg, static=True)
        mount = tf.lookup("base_link", frame, None)
        for env in r.messages(["/odom/ground_truth"]):
            p, q = env.msg.pose.pose.position, env.msg.pose.pose.orientation
            times.append(messages.to_ns(env.msg.header.stamp))
            mats.append(make_transform((p.x, p.y, p.z), (q.x, q.y, q.z, q.w)) @ mount)
    return Trajectory.from_matrices(np.array(times, dtype=np.int64), np.array(mats)), mount


def run_navlog(log: Path) -> tuple[float, int, np.ndarray, np.ndarray]:
    params = pipeline_params("mapping").lidar
    topics = [params.lidar_topic, params.imu_topic, params.odom_topic, "/tf_static", "/tf"]
    with open_log(log) as r:
        envs = list(r.messages([t for t in topics if t in r.topics]))
    ex = Executor(start_ns=envs[0].time_ns)
    ex.add_source(envs)
    node = ex.add_node(LidarMapperNode(params))
    t0 = time.perf_counter()
    ex.run()
    ex.finish()
    wall = time.perf_counter() - t0
    stamps, poses = node.poses()
    return wall, len(stamps), np.asarray(stamps, dtype=np.int64), np.asarray(poses)


def run_kiss(log: Path, voxel: float):
    from kiss_icp.config import KISSConfig
    from kiss_icp.kiss_icp import KissICP

    cfg = KISSConfig()
    cfg.data.max_range = 30.0
    cfg.data.min_range = 0.3
    cfg.data.deskew = True
    cfg.mapping.voxel_size = voxel
    cfg.registration.max_num_threads = 1
    frames = []
    with open_log(log) as r:
        for env in r.messages(["/livox/lidar"]):
            pts = read_points(env.msg)
            xyz = np.stack([pts["x"], pts["y"], pts["z"]], axis=1).astype(np.float64)
            t = pts["time"].astype(np.float64)
            frames.append((messages.to_ns(env.msg.header.stamp), xyz, (t - t.min()) / max(np.ptp(t), 1e-9)))
    odom = KissICP(config=cfg)
    stamps, poses = [], []
    t0 = time.perf_counter()
    for stamp, xyz, t in frames:
        odom.register_frame(xyz, t)
        stamps.append(stamp)
        poses.append(odom.last_pose.copy())
    return time.perf_counter() - t0, np.asarray(stamps, dtype=np.int64), np.asarray(poses)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--log", type=Path, help="a navlog log with /livox/lidar (default: record the mapping tour)")
    ap.add_argument("--kiss-voxel", type=float, default=0.15, help="KISS-ICP voxel size (indoors: 0.1-0.2)")
    args = ap.parse_args()
    try:
        import kiss_icp  # noqa: F401
    except ImportError:
        print("KISS-ICP is not installed (`.venv/bin/pip install kiss-icp`); it is a benchmark-only peer.")
        return 1
    work = None
    log = args.log
    if log is None:
        work = tempfile.mkdtemp(prefix="navlog-bench-")
        log = Path(work) / "mapping.mcap"
        subprocess.run(
            [sys.executable, "-m", "navlog", "-q", "record", "--scenario", "mapping", "--seed", "7", "-o", str(log)],
            check=True,
        )
    frame = "livox_frame"
    gt, mount = lidar_frame_ground_truth(log, frame)

    wall_n, n_n, st_n, poses_n = run_navlog(log)
    est_n = Trajectory.from_matrices(st_n, poses_n @ mount)  # base_link poses -> LiDAR frame
    ate_n = absolute_trajectory_error(gt, est_n).translation.rmse

    wall_k, st_k, poses_k = run_kiss(log, args.kiss_voxel)
    est_k = Trajectory.from_matrices(st_k, poses_k)  # KISS-ICP poses are of the LiDAR frame
    ate_k = absolute_trajectory_error(gt, est_k).translation.rmse

    fps_n, fps_k = n_n / wall_n, len(st_k) / wall_k
    print(f"log {log} ({len(st_k)} sweeps), load average {os.getloadavg()[0]:.2f}")
    print(f"navlog 3D mapper: {fps_n:6.1f} frames/s, ATE {ate_n * 100:.2f} cm (SE(3)-aligned, LiDAR frame)")
    print(f"KISS-ICP (voxel {args.kiss_voxel}, 1 thread, deskew): {fps_k:6.1f} frames/s, ATE {ate_k * 100:.2f} cm")
    print(
        f"ratios: frames/s navlog / KISS-ICP = {fps_n / fps_k:.2f} (target >= 1); "
        f"ATE KISS-ICP / navlog = {ate_k / ate_n:.1f} (target > 1)"
    )
    if work:
        import shutil

        shutil.rmtree(work, ignore_errors=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
