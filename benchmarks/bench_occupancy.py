"""The occupancy grid's NumPy ray update against the tests' compiled per-beam form of it, in the same run.

Run: .venv/bin/python benchmarks/bench_occupancy.py [NAME ...] [--shared DIR] [--runs 3]

Each CARMEN dataset of the external data (``external-data/carmen/NAME``, default: all four) is drawn whole into
one ``OccupancyGrid2D`` (0.05 m, navlog's defaults) at its reference poses (``NAME.reference.tum``, the scans'
stamps), once with the grid's own update (NumPy, beams in groups of similar length) and once with the tests'
per-beam oracle compiled by numba (``tests/replay/mapping/occupancy_oracle.py``), alternated, after one untimed
pass of each (the compilation). Prints per dataset the median CPU time a scan over ``--runs`` passes, of the whole
insertion and of the update alone (the setup before it is the same code both ways), the updates' ratio, and
checks that both grids hold the same bits: what a compiled update would save per scan,
to set against what loading numba costs a process that has not (the grid's child process, a short 2D replay).
The machine and its load average are printed with the table.
"""

from __future__ import annotations

import argparse
import functools
import hashlib
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from navlog.replay.geometry import planar_matrix
from navlog.replay.mapping.occupancy import OccupancyGrid2D, OccupancyParams

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # the repository: tests/ holds the oracle and readers
from benchmarks.bench_costmap import cpu_name
from tests.replay.mapping.occupancy_oracle import per_beam_update
from tests.replay.mapping.planar_logs import planar_tum, read_bag
from tests.shared_data import default_shared_dir

DATASETS = ["intel", "aces", "seattle", "fhw"]


def per_beam(grid: OccupancyGrid2D, t, last, d2c, g0, end_cells, box) -> None:
    """The grid's update by the compiled per-beam oracle, its cell marks kept between scans as the grid keeps its
    own (the oracle's test wrapper makes them afresh and checks the cells outside the box: not timed here)."""
    mask = grid._buffers.get("per-beam mask")
    if mask is None or mask.size != grid.logodds.size:
        mask = grid._buffers["per-beam mask"] = np.zeros(grid.logodds.size, dtype=np.int8)
    per_beam_update(grid, mask, t, last, d2c, g0, end_cells)


def draw(scans: list[tuple], poses: np.ndarray, oracle: bool) -> tuple[float, float, str]:
    """(CPU seconds of the scans' insertion, of which in the update, sha256 of the log-odds and seen arrays) of
    every scan drawn at its pose."""
    grid = OccupancyGrid2D(OccupancyParams())
    update = functools.partial(per_beam, grid) if oracle else grid._update
    in_update = [0.0]

    def timed(*args) -> None:
        start = time.process_time()
        update(*args)
        in_update[0] += time.process_time() - start

    grid._update = timed  # type: ignore[method-assign]
    start = time.process_time()
    for (angles, ranges, range_min, range_max), (x, y, yaw) in zip(scans, poses, strict=True):
        grid.insert_scan(planar_matrix(x, y, yaw), angles, ranges, range_min, range_max)
    spent = time.process_time() - start
    return spent, in_update[0], hashlib.sha256(grid.logodds.tobytes() + grid.seen.tobytes()).hexdigest()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("names", nargs="*", default=DATASETS, help="datasets (default: the four shared)")
    ap.add_argument("--shared", type=Path, default=default_shared_dir(), help="the external data folder")
    ap.add_argument("--runs", type=int, default=3)
    args = ap.parse_args()
    print(f"machine: {cpu_name()}, {os.cpu_count()} cores; load average before: {os.getloadavg()[0]:.2f}")
    print("ms a scan: the whole insertion (the update and the setup both share) and the update alone")
    print(f"{'dataset':10s} {'scans':>6s} {'NumPy':>7s} {'update':>7s} {'compiled':>9s} {'update':>7s} {'updates':>8s}")
    for name in args.names:
        folder = args.shared / "external-data" / "carmen"
        by_stamp, _ = read_bag(folder / name)
        stamps, poses = planar_tum(folder / f"{name}.reference.tum")
        scans = [by_stamp[int(t)] for t in stamps]
        times: dict[bool, list[tuple[float, float]]] = {False: [], True: []}
        digests = set()
        for oracle in (False, True):
            draw(scans, poses, oracle)
        for _ in range(args.runs):  # alternated
            for oracle in (False, True):
                spent, updating, digest = draw(scans, poses, oracle)
                times[oracle].append((spent, updating))
                digests.add(digest)
        if len(digests) != 1:
            raise SystemExit(f"{name}: the grid's update and the per-beam oracle drew different grids")
        per = 1e3 / len(scans)
        (own, own_update), (compiled, compiled_update) = (
            (statistics.median(t for t, _ in times[k]) * per, statistics.median(u for _, u in times[k]) * per)
            for k in (False, True)
        )
        print(
            f"{name:10s} {len(scans):6d} {own:7.2f} {own_update:7.2f} {compiled:9.2f} {compiled_update:7.2f} "
            f"{own_update / compiled_update:7.1f}x"
        )
    print(f"load average after: {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
