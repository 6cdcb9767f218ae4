"""2D logs read as planar poses, for measuring the SLAM on real buildings: their scans and odometry, their
trajectories, and their odometry made worse than their own.

``read_bag`` reads a 2D log's scans and its odometry at their stamps; ``planar_tum`` reads a trajectory
file as planar poses; ``degraded_odometry`` degrades each increment of an odometry in the robot's frame
(``ODOMETRY_ERRORS``: turns or step lengths scaled, a heading drift per metre, seeded Gaussian noise) and
composes them again from the first pose; ``driven_back`` reverses a log (a robot reversing over its path);
``slam_on_odometry`` runs the SLAM (``Slam2D``, in this process)
on the scans with any such odometry. Used by ``benchmarks/bench_slam_datasets.py``,
``benchmarks/bench_slam_long.py`` and the tests of ``tests/replay/mapping/``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from navlog.replay.io.formats import open_log
from navlog.replay.io.tum import read_tum
from navlog.replay.mapping.slam2d import LaserScan2D, SlamParams
from navlog.replay.mapping.slam2d.slam import Slam2D
from tests.replay.mapping.lap_logs import yaw_of

ODOMETRY_ERRORS = {
    "turn": "every turn scaled by 1 + VALUE (each step keeps its direction in the robot's frame)",
    "length": "every step's length scaled by 1 + VALUE",
    "drift": "VALUE rad of heading added per metre travelled",
    "noise": "each step's length and turn perturbed by Gaussian noise of VALUE times their size (seeded)",
}


def degraded_odometry(odom: np.ndarray, kind: str, value: float) -> np.ndarray:
    """``odom`` (n, 3) with its increments (in the robot's frame) degraded as ``ODOMETRY_ERRORS[kind]`` says and
    composed again from its first pose: wheel odometry worse than the dataset's own."""
    if kind not in ODOMETRY_ERRORS:
        raise ValueError(f"odometry error {kind!r}: one of {', '.join(ODOMETRY_ERRORS)}")
    rng = np.random.default_rng(0)
    out = [odom[0].copy()]
    for a, b in zip(odom[:-1], odom[1:], strict=True):
        c, s = math.cos(a[2]), math.sin(a[2])
        dx, dy = b[0] - a[0], b[1] - a[1]
        lx, ly = c * dx + s * dy, -s * dx + c * dy
        turn = math.remainder(b[2] - a[2], 2 * math.pi)
        step = math.hypot(lx, ly)
        if kind == "turn":
            turn *= 1 + value
        elif kind == "length":
            lx, ly = lx * (1 + value), ly * (1 + value)
        elif kind == "drift":
            turn += value * step
        elif kind == "noise":
            lx, ly = lx + rng.normal() * value * step, ly + rng.normal() * value * step
            turn += rng.normal() * value * (abs(turn) + 0.2 * step)
        o = out[-1]
        co, so = math.cos(o[2]), math.sin(o[2])
        out.append(np.array([o[0] + co * lx - so * ly, o[1] + so * lx + co * ly, o[2] + turn]))
    return np.array(out)


def read_bag(bag: Path) -> tuple[dict[int, tuple], dict[int, np.ndarray]]:
    """Scans by stamp (angles, ranges, range_min, range_max) and the odometry pose at each scan stamp."""
    scans: dict[int, tuple] = {}
    odom_t: list[int] = []
    odom_p: list[np.ndarray] = []
    with open_log(bag) as reader:
        for env in reader.messages(["/scan", "/odom"]):
            m = env.msg
            stamp = m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec
            if env.topic == "/scan":
                r = np.asarray(m.ranges, dtype=np.float64)
                a = m.angle_min + m.angle_increment * np.arange(len(r))
                scans[stamp] = (a, r, float(m.range_min), float(m.range_max))
            else:
                p = m.pose.pose.position
                odom_t.append(stamp)
                odom_p.append(np.array([p.x, p.y, yaw_of(m.pose.pose.orientation)]))
    ts = np.asarray(odom_t)
    ps = np.asarray(odom_p)
    odom = {}
    for stamp in scans:
        i = int(np.clip(np.searchsorted(ts, stamp), 1, len(ts) - 1))
        odom[stamp] = ps[i] if abs(ts[i] - stamp) < abs(ts[i - 1] - stamp) else ps[i - 1]
    return scans, odom


def driven_back(
    stamps: np.ndarray, scans: dict[int, tuple], odom: np.ndarray
) -> tuple[np.ndarray, dict[int, tuple], np.ndarray]:
    """A 2D log driven back over its path: its scans and odometry poses (at ``stamps``) in reverse order, one
    scan a second from its first stamp: a robot reversing with the same laser. A trajectory at ``stamps``
    reversed (``poses[::-1]``) is its trajectory."""
    back = stamps[0] + np.arange(len(stamps), dtype=np.int64) * 1_000_000_000
    reversed_scans = {int(t): scans[int(s)] for t, s in zip(back.tolist(), stamps[::-1].tolist(), strict=True)}
    return back, reversed_scans, odom[::-1].copy()


def slam_on_odometry(odom: np.ndarray, stamps: np.ndarray, scans: dict[int, tuple], params: SlamParams) -> np.ndarray:
    """The SLAM's poses (``Slam2D`` in this process) given ``odom`` as the odometry at the scan stamps."""
    slam = Slam2D(params)
    for t, pose in zip(stamps.tolist(), odom, strict=True):
        slam.add_scan(t, pose, LaserScan2D(*scans[t], np.eye(4)))
    placed, poses = slam.trajectory()
    if placed != stamps.tolist():
        raise RuntimeError("a scan was left unplaced")
    return poses


def planar_tum(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(stamps ns, (n, 3) x y yaw) of a TUM trajectory file."""
    t = read_tum(path)
    q = t.quaternions
    yaw = np.arctan2(2 * (q[:, 3] * q[:, 2] + q[:, 0] * q[:, 1]), 1 - 2 * (q[:, 1] ** 2 + q[:, 2] ** 2))
    return t.times_ns, np.column_stack([t.positions[:, :2], yaw])
