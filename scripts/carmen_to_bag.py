"""CARMEN logs (the Radish / Freiburg collection's "corrected" files) as ROS 2 bags, the way the four in the
external data's ``carmen/`` folder were made: the collection's other logs, for
``benchmarks/bench_slam_datasets.py NAME --shared DIR``.

    .venv/bin/python scripts/carmen_to_bag.py LOG [LOG ...] --out DIR

writes ``DIR/external-data/carmen/NAME/`` (rosbag2, MCAP storage) and ``DIR/external-data/carmen/NAME.reference.tum``
for each ``LOG`` (``NAME-corrected.log``, gzipped or not). A corrected file holds, per laser scan, an ``FLASER``
line (the readings, the scan's corrected pose, its timestamp) followed by an ``ODOM`` line that resets the
odometry to that corrected pose (the same numbers; its timestamp is 0 or garbage); the ``ODOM`` lines between
two resets are the wheels' own motion. So:

- **odometry**: the wheels' steps chained from the first scan (the odometry frame's origin): between two
  scans, the motion from the reset to the last ``ODOM`` line before the next scan; where the file holds no
  reset or no ``ODOM`` line between two scans, the corrected step between them stands in. Written on
  ``/odom`` and ``/tf`` (``odom -> base_footprint``) at every scan stamp and every 0.1 s between, the pose
  interpolated linearly between the two scans around it;
- **scans**: ``/scan`` (frame ``base_scan``, ``/tf_static`` ``base_footprint -> base_scan`` identity),
  stamped with the ``FLASER`` line's timestamp (made increasing by 10 ms where the file's goes back; one a
  second where the file has no times); N
  readings ``pi / (N - N mod 2)`` apart from ``-pi/2`` (180 readings a degree apart, 361 half a degree
  apart); the log's no-return code (the most frequent reading within 1 m of its largest) and any reading
  within 0.1 m below it written as ``+inf`` (REP 117), ``range_max`` that code less 0.1 m;
- **reference**: the corrected pose of every scan, as TUM (``t x y z qx qy qz qw``), its position to the
  micrometre as in the shared references.

Each bag is written under a temporary name and moved into place; a write that fails leaves neither the bag
nor its reference.

Scans are not thinned: the corrected files hold one per metre or large turn already.
"""

from __future__ import annotations

import argparse
import gzip
import math
import shutil
import sys
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from navlog.errors import NavlogError
from navlog.replay.geometry import quat_from_yaw, se2_compose
from navlog.replay.io.atomic import replace_output, temp_path, write_error
from navlog.replay.io.tum import write_tum

ODOM_PERIOD_NS = 100_000_000  # /odom and /tf every 0.1 s between scans
MONOTONIC_STEP_NS = 10_000_000  # a scan stamped at or before the one before it moves to 10 ms after it
NO_RETURN_BAND = 0.1  # m: readings this close below the no-return code are no return either


@dataclass
class CarmenLog:
    """A corrected CARMEN log: per scan its stamp (ns), readings, corrected pose and wheel-odometry pose."""

    stamps: np.ndarray  # (N,) int64, increasing
    ranges: list[np.ndarray]  # N arrays of the readings, as in the file
    corrected: np.ndarray  # (N, 3) x, y, yaw
    odometry: np.ndarray  # (N, 3) x, y, yaw: the wheels' steps chained, the first scan at the origin


def _relative(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Pose ``b`` in the frame of pose ``a`` (x, y, yaw)."""
    c, s = math.cos(a[2]), math.sin(a[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    return np.array([c * dx + s * dy, -s * dx + c * dy, math.remainder(b[2] - a[2], math.tau)])


def parse_carmen(lines: Iterable[str], source: str = "log") -> CarmenLog:
    """The scans and odometry of a corrected CARMEN log's lines (module docstring); ``ValueError`` naming
    ``source`` and the line for a line that is not one."""
    raw: list[float] = []  # the FLASER lines' timestamps (s)
    ranges: list[np.ndarray] = []
    corrected: list[np.ndarray] = []
    steps: list[np.ndarray | None] = []  # the wheels' motion since the scan before (None: none in the file)
    base: np.ndarray | None = None  # the odometry's pose after the last scan's reset
    last: np.ndarray | None = None  # the last ODOM line's pose since that reset
    for lineno, line in enumerate(lines, 1):
        fields = line.split()
        if not fields or fields[0] not in ("FLASER", "ODOM"):
            continue
        try:
            if fields[0] == "FLASER":
                n = int(fields[1])
                readings = np.array([float(v) for v in fields[2 : 2 + n]])
                x, y, yaw = (float(v) for v in fields[2 + n : 5 + n])
                stamp = float(fields[8 + n])
                if len(readings) != n or not math.isfinite(stamp):
                    raise ValueError
            else:
                pose = np.array([float(v) for v in fields[1:4]])
        except (ValueError, IndexError):
            raise ValueError(f"{source}:{lineno}: not a {fields[0]} line of a CARMEN log: {line[:80]!r}") from None
        if fields[0] == "FLASER":
            raw.append(stamp)
            ranges.append(readings)
            corrected.append(np.array([x, y, yaw]))
            steps.append(None if base is None or last is None else _relative(base, last))
            base, last = None, None
        elif corrected and base is None and np.array_equal(pose, corrected[-1]):  # the reset after a scan
            base = pose
        elif base is not None:
            last = pose
    if not raw:
        raise ValueError(f"{source}: no FLASER line: not a CARMEN laser log")
    stamps = scan_stamps(raw)
    odometry = [np.zeros(3)]
    for k in range(1, len(stamps)):
        step = steps[k] if steps[k] is not None else _relative(corrected[k - 1], corrected[k])
        odometry.append(np.array(se2_compose(odometry[-1], step)))
    return CarmenLog(stamps, ranges, np.array(corrected), np.array(odometry))


def scan_stamps(raw: list[float]) -> np.ndarray:
    """The scans' stamps (ns, increasing) from the file's timestamps (s): each as it is, or ``MONOTONIC_STEP_NS``
    after the one before where it is not later; a file whose timestamps are no times (negative, or going back at
    more than half of its scans: the infinite corridor's are all 4294967295) one scan a second from 1 s."""
    back = sum(b <= a for a, b in zip(raw, raw[1:]))
    if min(raw) < 0 or back > len(raw) / 2:
        return np.arange(1, len(raw) + 1, dtype=np.int64) * 1_000_000_000
    stamps: list[int] = []
    for stamp in raw:
        t = round(stamp * 1e9)
        stamps.append(t if not stamps or t > stamps[-1] else stamps[-1] + MONOTONIC_STEP_NS)
    return np.array(stamps, dtype=np.int64)


def no_return_code(ranges: list[np.ndarray]) -> float:
    """The log's no-return reading: the most frequent one within 1 m of its largest."""
    values = np.concatenate(ranges)
    top = float(values.max())
    counts = Counter(values[values >= top - 1.0].tolist())
    return max(counts, key=lambda v: (counts[v], v))


def write_bag(log: CarmenLog, out: Path) -> None:
    """``log`` as a rosbag2 folder (MCAP storage) at ``out`` (module docstring)."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    code = no_return_code(log.ranges)
    limit = code - NO_RETURN_BAND

    def header(t: int, frame: str):
        return T["std_msgs/msg/Header"](
            stamp=T["builtin_interfaces/msg/Time"](sec=t // 10**9, nanosec=t % 10**9), frame_id=frame
        )

    def quat(yaw: float):
        x, y, z, w = quat_from_yaw(yaw)
        return T["geometry_msgs/msg/Quaternion"](x=x, y=y, z=z, w=w)

    def transform(t: int, parent: str, child: str, x: float, y: float, yaw: float):
        return T["geometry_msgs/msg/TransformStamped"](
            header=header(t, parent),
            child_frame_id=child,
            transform=T["geometry_msgs/msg/Transform"](
                translation=T["geometry_msgs/msg/Vector3"](x=x, y=y, z=0.0), rotation=quat(yaw)
            ),
        )

    # odometry samples: every scan stamp and every ODOM_PERIOD_NS between, interpolated between the scans
    unwrapped = log.odometry.copy()
    unwrapped[:, 2] = np.unwrap(unwrapped[:, 2])
    grid = np.arange(log.stamps[0] - log.stamps[0] % ODOM_PERIOD_NS, log.stamps[-1], ODOM_PERIOD_NS)
    times = np.union1d(log.stamps, grid[(grid > log.stamps[0]) & (grid < log.stamps[-1])])
    odom = np.column_stack([np.interp(times, log.stamps, unwrapped[:, i]) for i in range(3)])
    scan_at = {int(t): k for k, t in enumerate(log.stamps)}
    cov = np.zeros(36)
    with Writer(out, version=9, storage_plugin=StoragePlugin.MCAP) as bag:
        static = bag.add_connection("/tf_static", "tf2_msgs/msg/TFMessage", typestore=ts)
        tf = bag.add_connection("/tf", "tf2_msgs/msg/TFMessage", typestore=ts)
        odom_c = bag.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=ts)
        scan_c = bag.add_connection("/scan", "sensor_msgs/msg/LaserScan", typestore=ts)
        first = int(log.stamps[0])
        mount = T["tf2_msgs/msg/TFMessage"](transforms=[transform(first, "base_footprint", "base_scan", 0.0, 0.0, 0.0)])
        bag.write(static, first, ts.serialize_cdr(mount, "tf2_msgs/msg/TFMessage"))
        for t, (x, y, yaw) in zip(times.tolist(), odom.tolist(), strict=True):
            msg = T["nav_msgs/msg/Odometry"](
                header=header(t, "odom"),
                child_frame_id="base_footprint",
                pose=T["geometry_msgs/msg/PoseWithCovariance"](
                    pose=T["geometry_msgs/msg/Pose"](
                        position=T["geometry_msgs/msg/Point"](x=x, y=y, z=0.0), orientation=quat(yaw)
                    ),
                    covariance=cov,
                ),
                twist=T["geometry_msgs/msg/TwistWithCovariance"](
                    twist=T["geometry_msgs/msg/Twist"](
                        linear=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                        angular=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                    ),
                    covariance=cov,
                ),
            )
            bag.write(odom_c, t, ts.serialize_cdr(msg, "nav_msgs/msg/Odometry"))
            tree = T["tf2_msgs/msg/TFMessage"](transforms=[transform(t, "odom", "base_footprint", x, y, yaw)])
            bag.write(tf, t, ts.serialize_cdr(tree, "tf2_msgs/msg/TFMessage"))
            k = scan_at.get(t)
            if k is None:
                continue
            r = log.ranges[k]
            n = len(r)
            increment = math.pi / (n - n % 2) if n > 1 else 0.0
            ranges = np.where(r >= limit, np.inf, r).astype(np.float32)
            scan = T["sensor_msgs/msg/LaserScan"](
                header=header(t, "base_scan"),
                angle_min=-math.pi / 2,
                angle_max=-math.pi / 2 + increment * (n - 1),
                angle_increment=increment,
                time_increment=0.0,
                scan_time=0.0,
                range_min=0.0,
                range_max=limit,
                ranges=ranges,
                intensities=np.zeros(0, dtype=np.float32),
            )
            bag.write(scan_c, t, ts.serialize_cdr(scan, "sensor_msgs/msg/LaserScan"))


def write_reference(log: CarmenLog, out: Path) -> None:
    """The corrected pose of every scan, as TUM (written whole or not at all), its positions to the micrometre as
    in the shared references."""
    micrometres = [[float(f"{v:.6f}") for v in xy] for xy in log.corrected[:, :2].tolist()]  # (rounded as printed)
    positions = np.column_stack([np.array(micrometres).reshape(-1, 2), np.zeros(len(log.corrected))])
    write_tum(out, log.stamps, positions, np.array([quat_from_yaw(yaw) for yaw in log.corrected[:, 2]]), header=False)


def bag_name(path: Path) -> str:
    """``fr079`` for ``fr079-corrected.log.gz``."""
    name = path.name
    for suffix in (".gz", ".log", "-corrected"):
        name = name.removesuffix(suffix)
    return name


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("logs", nargs="+", type=Path, help="corrected CARMEN logs (NAME-corrected.log[.gz])")
    ap.add_argument("--out", type=Path, required=True, help="DIR: writes DIR/external-data/carmen/NAME/")
    args = ap.parse_args(argv)
    folder = args.out / "external-data" / "carmen"
    folder.mkdir(parents=True, exist_ok=True)
    for path in args.logs:
        name = bag_name(path)
        bag, reference = folder / name, folder / f"{name}.reference.tum"
        if bag.exists() or reference.exists():
            print(f"{bag}: exists; remove it (and {reference.name}) to convert {path} again", file=sys.stderr)
            return 2
        opener = gzip.open if path.suffix == ".gz" else open
        try:
            with opener(path, "rt", encoding="ascii", errors="replace") as f:
                log = parse_carmen(f, str(path))
        except (OSError, ValueError) as e:
            print(f"{path}: {e}", file=sys.stderr)
            return 2
        tmp = temp_path(bag)  # the bag is written in a folder of its own name inside it, then moved into place
        try:
            tmp.mkdir()
            write_bag(log, tmp / name)
            replace_output(tmp / name, bag)
            write_reference(log, reference)
        except (OSError, NavlogError) as e:  # a full disk, a read-only folder, a special file at the output
            shutil.rmtree(bag, ignore_errors=True)  # no bag without its reference
            print(e if isinstance(e, NavlogError) else write_error(bag, e), file=sys.stderr)
            return 2
        finally:
            shutil.rmtree(tmp, ignore_errors=True)
        travel = float(np.sum(np.linalg.norm(np.diff(log.corrected[:, :2], axis=0), axis=1)))
        print(f"{name}: {len(log.stamps)} scans, {travel:.0f} m -> {bag}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
