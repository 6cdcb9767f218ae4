"""Real robots' scans through the mapping pipeline: free space leaking through walls, before and after.

For each rosbag2 folder (default: the Neato and TurtleBot3 bags in external-data/bags/ of the external
data folder: ``--shared DIR``, default ``$NAVLOG_SHARED_DIR``, else ``shared`` beside the repository)
the mapping pipeline runs twice: with navlog's default (no-return readings mark and clear nothing)
and with the old rule (every no-return beam clears up to the scan's ``range_max``, here
``no_return_ray_length = range_max``). The building is taken as the convex hull of the occupied
cells of the default map and the robot's path (every valid return lies inside it); the leak is the
share of a map's free cells whose centre lies outside that hull. Prints the share of ``inf``
readings, free / occupied cell counts and the leak of both maps, with the load average; nothing is
asserted.

    .venv/bin/python benchmarks/bench_real_scans.py [BAG ...] [--shared DIR]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

import numpy as np
from scipy.spatial import Delaunay

from navlog.replay.io.formats import open_log
from navlog.replay.io.map_server import load_map
from navlog.replay.io.tum import read_tum
from navlog.replay.occupancy_map import OccupancyMap
from navlog.replay.session import run_replay

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: tests.shared_data
from tests.shared_data import default_shared_dir

DEFAULT = ["neato_drive_square", "tb3_gazebo_walker"]  # in external-data/bags/ of the shared folder


def scan_facts(bag: Path) -> tuple[float, float]:
    """(share of inf readings, range_max) of the bag's /scan."""
    total = inf = 0
    range_max = 0.0
    with open_log(bag) as reader:
        for env in reader.messages(["/scan"]):
            r = np.asarray(env.msg.ranges)
            total += len(r)
            inf += int(np.isinf(r).sum())
            range_max = max(range_max, float(env.msg.range_max))
    return inf / max(total, 1), range_max


def cell_centres(m: OccupancyMap) -> np.ndarray:
    xs, ys = m.cell_to_world(*np.meshgrid(np.arange(m.width), np.arange(m.height)))
    return np.stack([xs.ravel(), ys.ravel()], axis=1)


def leak(m: OccupancyMap, hull: Delaunay) -> float:
    """Share of the map's free cells outside the hull."""
    free = cell_centres(m)[m.data.ravel() == 0]
    if len(free) == 0:
        return 0.0
    return float((hull.find_simplex(free) < 0).mean())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("bags", nargs="*", type=Path, help="rosbag2 folders (default: the shared folder's two bags)")
    ap.add_argument("--shared", type=Path, default=default_shared_dir(), help="the external data folder")
    args = ap.parse_args()
    bags = args.bags or [args.shared / "external-data" / "bags" / name for name in DEFAULT]
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores")
    for bag in bags:
        inf_share, range_max = scan_facts(bag)
        with tempfile.TemporaryDirectory() as tmp:
            maps = {}
            for name, sets in (("default", []), ("old rule", [f"occupancy.grid.no_return_ray_length={range_max}"])):
                out = Path(tmp) / name.replace(" ", "_")
                # a standing robot inserts one scan only: take every scan so that cells can become free
                run_replay(
                    bag,
                    "mapping",
                    out,
                    overrides=[*sets, "occupancy.minimum_travel_distance=0"],
                    progress=False,
                )
                maps[name] = load_map(out / "map.yaml")
                if name == "default":
                    path = read_tum(out / "trajectory.tum").positions[:, :2]
            ref = maps["default"]
            occupied = cell_centres(ref)[ref.data.ravel() == 100]
            hull = Delaunay(np.vstack([occupied, path]))
            print(f"{bag.name}: inf readings {inf_share:.1%}, range_max {range_max:g} m")
            for name, m in maps.items():
                print(
                    f"  {name:9s} free cells {int((m.data == 0).sum()):6d}  occupied {int((m.data == 100).sum()):5d}"
                    f"  free outside the building {leak(m, hull):6.1%}"
                )


if __name__ == "__main__":
    main()
