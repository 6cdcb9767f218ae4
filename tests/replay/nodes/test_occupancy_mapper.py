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
    assert node.skipped_counts()["/scan: pose or ranges too far off (the map would exceed its cell budget)"] == 1
    # the refused scan is a skip, not in the grid or its counts
    assert node.grid.stats.scans == 3 and (node.grid.to_map().data == 100).sum() > 50


def _drive(beams: int, seconds: float) -> list[Envelope]:
    """A robot driving 0.5 m/s along x in a ring of range 8 m: ground truth and scans at 10 Hz."""
    envs = []
    for k in range(int(seconds * 10)):
        t = (k + 1) * 100_000_000
        odom = m.odometry(t, "map", "base_link", (0.05 * k, 0.0, 0.0), (0.0, 0.0, 0.0, 1.0), (0, 0, 0), (0, 0, 0))
        envs.append(Envelope("/odom/ground_truth", m.ODOMETRY, t, odom))
        scan = m.msg_class(m.LASER_SCAN)(
            header=m.header(t, "base_link"),
            angle_min=-math.pi,
            angle_max=math.pi,
            angle_increment=2 * math.pi / beams,
            time_increment=0.0,
            scan_time=0.1,
            range_min=0.1,
            range_max=20.0,
            ranges=np.full(beams, 8.0, dtype=np.float32),
            intensities=np.zeros(0, dtype=np.float32),
        )
        envs.append(Envelope("/scan", m.LASER_SCAN, t, scan))
    return envs


def _scan_run(read_map: bool, beams: int, seconds: float) -> tuple[list, occupancy_mapper.OccupancyMapperNode]:
    """``_drive`` with ``beams`` beams per scan, the grid in a child process; every message the sink saw (topic, time, CDR bytes of /map). With ``read_map`` a node
    subscribes to /map (the mapper then publishes each map as it asks for it)."""
    from navlog.replay.runtime.executor import Node

    node = occupancy_mapper.OccupancyMapperNode(
        occupancy_mapper.OccupancyMapperParams(minimum_travel_distance=0.0), grid_process=True
    )
    ex = Executor()
    ex.add_node(node)
    if read_map:

        class Reader(Node):
            def setup(self):
                self.subscribe("/map", lambda msg, t: None)

        ex.add_node(Reader())
    seen: list = []

    class Sink:
        def write(self, env):
            seen.append((env.topic, env.time_ns, m.serialize(env.msg, env.typename) if env.topic == "/map" else b""))

    ex.add_sink(Sink())
    ex.add_source(_drive(beams, seconds))
    ex.run()
    ex.finish()
    return seen, node


def test_maps_filled_in_later_reach_the_sink_as_maps_waited_for():
    waited, node_waited = _scan_run(read_map=True, beams=360, seconds=9.0)
    later, node_later = _scan_run(read_map=False, beams=360, seconds=9.0)
    assert [t for t, _, _ in later].count("/map") == 5  # every 2 s and at the end
    assert later == waited
    assert len(node_later.trajectory) == len(node_waited.trajectory) == 90


def test_a_map_reply_larger_than_the_pipe_does_not_stall_the_scans_behind_it():
    # 2 s of 3600-beam scans between maps is more than the 1 MiB pipe to the child holds, and each map of the
    # 16 m ring is more than its reply pipe holds: the mapper takes a reply whenever the child writes one
    import threading

    done: list = []
    run = threading.Thread(target=lambda: done.append(_scan_run(read_map=False, beams=3600, seconds=5.0)), daemon=True)
    run.start()
    run.join(timeout=120)
    assert done, "the replay stalled: the mapper and its grid process each waited for the other"
    seen, node = done[0]
    assert [t for t, _, _ in seen].count("/map") == 3 and len(node.trajectory) == 50


def test_a_map_the_child_has_sent_goes_out_with_the_next_scan():
    """A /map filled in later holds back what follows it until it is in place: the mapper takes it at
    the next scan once the child has sent it, not at the next /map two seconds of log later."""
    import select

    node = occupancy_mapper.OccupancyMapperNode(
        occupancy_mapper.OccupancyMapperParams(minimum_travel_distance=0.0), grid_process=True
    )
    ex = Executor()
    ex.add_node(node)
    seen: list[str] = []
    ex.add_sink(type("Sink", (), {"write": lambda self, env: seen.append(env.topic)})())
    ex.add_source(_drive(90, 3.0))
    ex.run(until_ns=1_000_000_000)
    child = node._updates._child
    assert child is not None and select.select([child.process.stdout], [], [], 30.0)[0], "the child did not start"
    ex.run(until_ns=2_000_000_000)  # the scan at 1.1 s hands the grid over; /map at 2 s is asked for
    assert node._updates.in_child and "/map" not in seen and ex._held
    for _ in range(3000):  # up to 30 s for the child's reply
        if child.reply_ready():
            break
        select.select([], [], [], 0.01)
    ex.run(until_ns=2_100_000_000)
    assert "/map" in seen and not ex._held
    ex.run()
    ex.finish()
    assert seen.count("/map") == 2
