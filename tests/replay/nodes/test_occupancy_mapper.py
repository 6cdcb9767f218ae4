"""The occupancy mapper node: its grid in a child process gives the replay the same outputs as in one process."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navlog.replay import messages as m
from navlog.replay.nodes import occupancy_mapper
from navlog.replay.runtime.executor import Envelope, Executor
from navlog.replay.session import run_replay


def test_the_grid_in_a_child_process_gives_the_same_outputs(teleop_log, tmp_path, monkeypatch):
    hashes = {}
    for cpus in ({0}, {0, 1}):
        monkeypatch.setattr(occupancy_mapper, "usable_cpus", lambda cpus=cpus: len(cpus))
        spawned = []
        original = occupancy_mapper.GridWorker

        def worker(*args, spawned=spawned, original=original, **kw):
            spawned.append(kw.get("spawn", True))
            return original(*args, **kw)

        monkeypatch.setattr(occupancy_mapper, "GridWorker", worker)
        res = run_replay(
            teleop_log, "mapping", tmp_path / f"cpus{len(cpus)}", overrides=["lidar_mapper=off"], progress=False
        )
        assert spawned[-1] == (len(cpus) > 1)
        hashes[len(cpus)] = {k: v["sha256"] for k, v in res.manifest["outputs"].items()}
        assert res.manifest["published"]["/map"] >= 8
    assert hashes[1] == hashes[2]
    assert set(hashes[1]) == {"map_pgm", "map_yaml", "replay_mcap", "trajectory_tum"}


@pytest.mark.parametrize("grid_process", [False, True])
def test_a_scan_far_off_is_counted_and_left_out_of_the_trajectory(grid_process):
    node = occupancy_mapper.OccupancyMapperNode(
        occupancy_mapper.OccupancyMapperParams(minimum_travel_distance=0.0), grid_process=grid_process
    )
    ex = Executor()
    ex.add_node(node)
    envs = []
    for k, x in enumerate((0.0, 0.5, 4e6, 1.0)):  # the third pose is far off: the grid refuses its scan
        t = (k + 1) * 100_000_000
        odom = m.odometry(t, "map", "base_link", (x, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0), (0, 0, 0), (0, 0, 0))
        envs.append(Envelope("/odom/ground_truth", m.ODOMETRY, t, odom))
        scan = m.msg_class(m.LASER_SCAN)(
            header=m.header(t, "base_link"),
            angle_min=-math.pi,
            angle_max=math.pi,
            angle_increment=2 * math.pi / 90,
            time_increment=0.0,
            scan_time=0.1,
            range_min=0.1,
            range_max=10.0,
            ranges=np.full(90, 2.0, dtype=np.float32),
            intensities=np.zeros(0, dtype=np.float32),
        )
        envs.append(Envelope("/scan", m.LASER_SCAN, t, scan))
    ex.add_source(envs)
    ex.run()
    ex.finish()
    assert [round(float(p[0, 3]), 3) for _, p in node.trajectory] == [0.0, 0.5, 1.0]
    assert node.counts()["/scan: pose or ranges too far off (the map would exceed its cell budget)"] == 1
    assert node.grid.stats.scans == 4 and (node.grid.to_map().data == 100).sum() > 50
