"""The 3D mapper and KISS-ICP side by side on the same sweeps, one thread each.

Sources (one per run):
- ``--log run.mcap``: a navlog log (the cloud topic is found as the mapper finds it); navlog's mapper
  reads the clouds, /imu/data, /odom and /tf_static as in `navlog replay` (and once more without the
  IMU); KISS-ICP reads the same clouds with their per-point times (its deskew);
- ``--record indoor`` (default): the indoor mapping tour (go2, indoor_room, 16 x 720 rays) recorded
  first; ``--record outdoor``: the town tour (outdoor_car, town_block, 64 x ``--columns`` rays;
  ``--seconds`` limits the drive);
- ``--pcd-dir DIR``: a folder of real PCD sweeps in name order, 0.1 s apart, no times, no IMU.

Printed: frames/s of both and their ratio; the ATE (SE(3)-aligned, of the LiDAR frame) against the
ground truth where there is one, else the mutual agreement of the two trajectories (n/a for fewer
than 3 sweeps: a folder of single sweeps measures speed only, by registering the sweep against
itself moved 0.5 m a frame, whose motion is then the ground truth); the map sharpness: the median
thickness of a known planar wall of the world (per 1 m x 1 m patch of the wall, the 10-90 %
spread of the points' distances to the plane) in the map each trajectory makes of the raw sweeps;
the machine and its load.

KISS-ICP is a benchmark-only tool, NOT a dependency of navlog: `.venv/bin/pip install kiss-icp`.

    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/bench_lidar_log.py [--log run.mcap | --record outdoor
        | --pcd-dir DIR] [--frames N] [--kiss-voxel V]
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import platform
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
from navlog.replay.mapping.lidar_odometry import LidarOdometry, LidarOdometryParams, PoseTrack, for_sweep
from navlog.replay.nodes.lidar_mapper import LidarMapperNode, LidarMapperParams, choose_lidar_topic
from navlog.replay.pointcloud import read_points
from navlog.replay.runtime.executor import Executor
from navlog.replay.runtime.tf import TFBuffer
from navlog.replay.workers.background import in_thread

CONFIG = Path(__file__).resolve().parents[1] / "config"
# a known planar wall per world: (axis, plane coordinate, (lo, hi) along the wall, (lo, hi) in z)
WALLS = {
    "indoor_room": ("x", 5.0, (-4.0, 4.0), (0.3, 2.2)),  # the inner face of the east wall
    "town_block": ("y", -32.0, (-13.0, -3.0), (1.0, 8.0)),  # the street face of south_inner_2
}


@dataclasses.dataclass
class Sweeps:
    """Clouds in the sensor frame: stamps (ns), points (N, 3) and times (s, relative; None when absent)."""

    stamps: list[int]
    points: list[np.ndarray]
    times: list[np.ndarray | None]
    frame: str
    ground_truth: Trajectory | None = None  # of the sensor frame
    world: str = ""
    mount: np.ndarray = dataclasses.field(default_factory=lambda: np.eye(4))  # base_link <- sensor


def machine() -> str:
    load = os.getloadavg()
    return f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, load average {load[0]:.2f} / {load[1]:.2f}"


def record(kind: str, columns: int, seconds: float, work: Path) -> Path:
    """A navlog log of the indoor mapping tour or the outdoor town tour (``columns`` per ring)."""
    log = work / f"{kind}.mcap"
    if kind == "indoor":
        args = ["--scenario", "mapping", "--seed", "7"]
    else:
        robot = (CONFIG / "robots/outdoor_car.yaml").read_text().replace("columns: 1024", f"columns: {columns}")
        scenario = (CONFIG / "scenarios/town_tour.yaml").read_text()
        scenario = scenario.replace("max_duration: 300.0", f"max_duration: {seconds}")
        (work / "outdoor_car.yaml").write_text(robot)
        (work / "town_tour.yaml").write_text(scenario)
        args = ["--scenario", str(work / "town_tour.yaml"), "--robot", str(work / "outdoor_car.yaml"), "--seed", "3"]
    cmd = [sys.executable, "-m", "navlog", "-q", "record", *args, "--localization", "none", "-o", str(log)]
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
    return log


def read_log(log: Path, topic: str, frames: int) -> Sweeps:
    tf = TFBuffer()
    stamps, points, times = [], [], []
    frame = ""
    with open_log(log) as r:
        for env in r.messages(["/tf_static"]):
            tf.add_message(env.msg, static=True)
        for env in r.messages([topic]):
            if frames and len(stamps) >= frames:
                break
            p = read_points(env.msg)
            frame = env.msg.header.frame_id
            stamps.append(messages.to_ns(env.msg.header.stamp))
            points.append(np.stack([p["x"], p["y"], p["z"]], axis=1).astype(np.float64))
            times.append(p["time"].astype(np.float64) if "time" in p.dtype.names else None)
        mount = tf.lookup("base_link", frame, None)
        gt_t, gt_m = [], []
        for env in r.messages(["/odom/ground_truth"]):
            q, o = env.msg.pose.pose.position, env.msg.pose.pose.orientation
            gt_t.append(messages.to_ns(env.msg.header.stamp))
            gt_m.append(make_transform((q.x, q.y, q.z), (o.x, o.y, o.z, o.w)) @ mount)
    gt = Trajectory.from_matrices(np.array(gt_t, dtype=np.int64), np.array(gt_m)) if gt_t else None
    world = "town_block" if frame == "lidar_top" else "indoor_room" if frame == "livox_frame" else ""
    return Sweeps(stamps, points, times, frame, gt, world, mount)


def read_pcd_dir(folder: Path, frames: int) -> Sweeps:
    """Sweeps of a folder of PCD files, in name order, 0.1 s apart. A single sweep is repeated, moved
    along a gentle arc (0.5 m and 1 degree a frame; its motion is then the ground truth)."""
    from navlog.replay.io.pcd import read_pcd

    files = sorted(folder.glob("*.pcd"))
    if not files:
        raise SystemExit(f"{folder}: no .pcd files")
    clouds = [np.asarray(read_pcd(f), dtype=np.float64) for f in files[: frames or None]]
    clouds = [c[np.isfinite(c).all(axis=1)] for c in clouds]
    stamps = [k * 100_000_000 for k in range(max(len(clouds), frames or 30))]
    if len(clouds) > 1:
        return Sweeps(stamps[: len(clouds)], clouds, [None] * len(clouds), "sensor")
    poses = [
        make_transform(
            (0.5 * k, 0.01 * k * k, 0.0), (0.0, 0.0, np.sin(np.radians(0.5 * k)), np.cos(np.radians(0.5 * k)))
        )
        for k in range(len(stamps))
    ]
    moved = [(clouds[0] - T[:3, 3]) @ T[:3, :3] for T in poses]  # the sweep seen from each pose
    return Sweeps(
        stamps,
        moved,
        [None] * len(stamps),
        "sensor",
        Trajectory.from_matrices(np.array(stamps, dtype=np.int64), np.array(poses)),
    )


def odometry_params(settings: list[str]) -> LidarOdometryParams:
    """LidarOdometryParams with ``KEY=VALUE`` settings (the value typed as the default's)."""
    params = LidarOdometryParams()
    for item in settings:
        key, value = item.split("=", 1)
        params = dataclasses.replace(params, **{key: type(getattr(params, key))(value)})
    return params


def run_navlog_log(
    log: Path, mount: np.ndarray, odometry: LidarOdometryParams, use_imu: bool, frames: int
) -> tuple[float, np.ndarray, np.ndarray]:
    """navlog's mapper node over the log (clouds, IMU, odometry, TF), timed around the executor."""
    with open_log(log) as r:
        params = LidarMapperParams(lidar_topic="auto", use_imu=use_imu, odometry=odometry)
        params = dataclasses.replace(
            params, lidar_topic=choose_lidar_topic(params, {t: i.typename for t, i in r.topics.items()}, True)
        )
        topics = [params.lidar_topic, params.imu_topic, params.odom_topic, "/tf_static"]
        envs, clouds = [], 0
        for env in r.messages([t for t in topics if t in r.topics]):
            if env.topic == params.lidar_topic:
                clouds += 1
                if frames and clouds > frames:
                    break
            envs.append(env)
    ex = Executor(start_ns=envs[0].time_ns)
    ex.add_source(envs)
    node = ex.add_node(LidarMapperNode(params))
    t0 = time.perf_counter()
    ex.run()
    ex.finish()
    wall = time.perf_counter() - t0
    stamps, poses = node.poses()
    return wall, np.asarray(stamps, dtype=np.int64), np.asarray(poses) @ mount


def run_navlog_sweeps(sw: Sweeps, odometry: LidarOdometryParams) -> tuple[float, np.ndarray, np.ndarray]:
    """navlog's LidarOdometry alone over sweeps without an IMU (sized from the first sweep)."""
    params = for_sweep(odometry, np.linalg.norm(sw.points[0], axis=1))
    odo = LidarOdometry(params, background=in_thread)  # the global map's batches beside, as the node runs them
    t0 = time.perf_counter()
    for stamp, pts in zip(sw.stamps, sw.points, strict=True):
        odo.process(stamp, pts)
    wall = time.perf_counter() - t0
    stamps, poses = odo.poses()
    return wall, stamps, poses


def run_kiss(sw: Sweeps, voxel: float | None) -> tuple[float, np.ndarray, np.ndarray, float]:
    """KISS-ICP at its defaults (voxel max_range / 100, max range 100 m; 30 m for a sweep within
    30 m) unless ``voxel`` is given, with its deskew when the sweeps have times; 1 thread."""
    from kiss_icp.config import KISSConfig
    from kiss_icp.kiss_icp import KissICP

    cfg = KISSConfig()
    reach = float(np.percentile(np.linalg.norm(sw.points[0], axis=1), 99))
    cfg.data.max_range = 30.0 if reach < 30.0 else 100.0
    cfg.data.deskew = sw.times[0] is not None
    cfg.mapping.voxel_size = voxel if voxel else cfg.data.max_range / 100.0
    cfg.registration.max_num_threads = 1
    odom = KissICP(config=cfg)
    poses = []
    t0 = time.perf_counter()
    for pts, t in zip(sw.points, sw.times, strict=True):
        rel = np.array([]) if t is None else (t - t.min()) / max(float(np.ptp(t)), 1e-9)
        odom.register_frame(pts, rel)
        poses.append(odom.last_pose.copy())
    wall = time.perf_counter() - t0
    # with deskew, KISS-ICP's pose is that of the middle of the sweep
    mid = [0 if t is None else int(round(0.5 * (float(t.min()) + float(t.max())) * 1e9)) for t in sw.times]
    stamps = np.asarray(sw.stamps, dtype=np.int64) + np.asarray(mid, dtype=np.int64)
    return wall, stamps, np.asarray(poses), cfg.mapping.voxel_size


def aligned(ref: Trajectory, stamps: np.ndarray, poses: np.ndarray) -> tuple[float, np.ndarray]:
    """(ATE RMSE in m, the 4x4 that aligns the estimate onto ``ref``)."""
    ate = absolute_trajectory_error(ref, Trajectory.from_matrices(stamps, poses))
    return ate.translation.rmse, ate.alignment.matrix()


def wall_thickness(sw: Sweeps, stamps: np.ndarray, poses: np.ndarray, align: np.ndarray) -> float:
    """Median thickness (m) of the world's known wall in the raw sweeps placed by the trajectory
    (aligned), each point at the pose interpolated at its own time (so the trajectory deskews)."""
    axis, at, along, zs = WALLS[sw.world]
    a, b = (0, 1) if axis == "x" else (1, 0)
    track = PoseTrack(keep_ns=1 << 62)
    for stamp, pose in zip(stamps, poses, strict=True):
        track.add(int(stamp), align @ pose)
    near = []
    for stamp, pts, times in zip(sw.stamps, sw.points, sw.times, strict=True):
        if not track.covers(stamp, stamp):
            continue
        T = track.poses(np.array([stamp]))[0]
        rough = pts @ T[:3, :3].T + T[:3, 3]
        keep = np.abs(rough[:, a] - at) < 3.0  # then each point at its own time
        if times is not None and keep.any():
            t_ns = stamp + np.round(times[keep] * 1e9).astype(np.int64)
            t_ns = np.clip(t_ns, int(stamps[0]), int(stamps[-1]))
            Ts = track.poses(t_ns)
            placed = np.einsum("nij,nj->ni", Ts[:, :3, :3], pts[keep]) + Ts[:, :3, 3]
        else:
            placed = rough[keep]
        sel = (np.abs(placed[:, a] - at) < 0.5) & (placed[:, b] > along[0]) & (placed[:, b] < along[1])
        near.append(placed[sel & (placed[:, 2] > zs[0]) & (placed[:, 2] < zs[1])])
    pts = np.concatenate(near) if near else np.zeros((0, 3))
    patch = np.floor(pts[:, b]).astype(np.int64) * 1000 + np.floor(pts[:, 2]).astype(np.int64)
    spreads = []
    for key in np.unique(patch):
        d = pts[patch == key, a]
        if len(d) >= 20:
            lo, hi = np.percentile(d, [10, 90])
            spreads.append(hi - lo)
    return float(np.median(spreads)) if spreads else float("nan")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    src = ap.add_mutually_exclusive_group()
    src.add_argument("--log", type=Path, help="a navlog log with a PointCloud2 topic")
    src.add_argument("--record", choices=["indoor", "outdoor"], default="indoor", help="record this tour first")
    src.add_argument("--pcd-dir", type=Path, help="a folder of PCD sweeps (no times, no IMU)")
    ap.add_argument("--columns", type=int, default=1024, help="--record outdoor: columns per ring (2048: ~130k points)")
    ap.add_argument("--seconds", type=float, default=300.0, help="--record outdoor: at most this long a drive")
    ap.add_argument("--frames", type=int, default=0, help="only the first N sweeps (0: all)")
    ap.add_argument(
        "--odometry", action="append", default=[], metavar="KEY=VALUE", help="a LidarOdometryParams value for navlog"
    )
    ap.add_argument("--kiss-voxel", type=float, default=0.0, help="KISS-ICP voxel (default: its own, max_range/100)")
    args = ap.parse_args()
    try:
        import kiss_icp  # noqa: F401
    except ImportError:
        print("KISS-ICP is not installed (`.venv/bin/pip install kiss-icp`); it is a benchmark-only peer.")
        return 1
    if os.environ.get("OMP_NUM_THREADS") != "1":
        print("note: set OMP_NUM_THREADS=1 so that every library runs on one thread")
    odometry = odometry_params(args.odometry)
    with tempfile.TemporaryDirectory(prefix="navlog-bench-") as work:
        log = args.log
        if args.pcd_dir is None and log is None:
            log = record(args.record, args.columns, args.seconds, Path(work))
        if args.pcd_dir is not None:
            sw = read_pcd_dir(args.pcd_dir, args.frames)
            runs = {"navlog (no IMU)": run_navlog_sweeps(sw, odometry)}
        else:
            with open_log(log) as r:
                topic = choose_lidar_topic(
                    LidarMapperParams(lidar_topic="auto"), {t: i.typename for t, i in r.topics.items()}, True
                )
            sw = read_log(log, topic, args.frames)
            runs = {
                "navlog (IMU)": run_navlog_log(log, sw.mount, odometry, True, args.frames),
                "navlog (no IMU)": run_navlog_log(log, sw.mount, odometry, False, args.frames),
            }
        wall_k, st_k, poses_k, voxel_k = run_kiss(sw, args.kiss_voxel or None)
        runs[f"KISS-ICP (voxel {voxel_k:g})"] = (wall_k, st_k, poses_k)
    n_points = np.mean([len(p) for p in sw.points])
    print(f"source: {args.pcd_dir or log} ({len(sw.stamps)} sweeps, {n_points:.0f} points a sweep)")
    print(f"machine: {machine()}; OMP_NUM_THREADS={os.environ.get('OMP_NUM_THREADS', 'unset')}")
    fps_k = len(st_k) / wall_k
    for name, (wall, stamps, poses) in runs.items():
        fps = len(stamps) / wall
        line = f"{name:28s} {fps:7.1f} frames/s ({fps / fps_k:.2f}x KISS-ICP)"
        if sw.ground_truth is not None:
            ate, align = aligned(sw.ground_truth, stamps, poses)
            line += f", ATE {ate * 100:6.2f} cm"
            if sw.world in WALLS:
                line += f", wall thickness {wall_thickness(sw, stamps, poses, align) * 100:.1f} cm"
        elif len(stamps) >= 3 and not name.startswith("KISS"):
            ate, _ = aligned(Trajectory.from_matrices(st_k, poses_k), stamps, poses)
            line += f", agrees with KISS-ICP to {ate * 100:.2f} cm (ATE between the two)"
        else:
            line += ", accuracy n/a (no ground truth, fewer than 3 sweeps)"
        print(line)
    return 0


if __name__ == "__main__":
    sys.exit(main())
