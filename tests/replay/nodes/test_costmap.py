"""The costmap node: a scan whose transform comes after it waits for it, as Nav2's message filter holds it."""

from __future__ import annotations

import math
from pathlib import Path

from navlog.replay import messages as m
from navlog.replay.nav2 import load_nav2_params
from navlog.replay.nav2.costmap.cost_values import LETHAL
from navlog.replay.nodes.costmap import CostmapNode
from navlog.replay.runtime.executor import Envelope, Executor

MS = 1_000_000


def _tf(t_ms: int, parent: str, child: str, z: float = 0.0) -> Envelope:
    msg = m.tf_message([m.transform_stamped(t_ms * MS, parent, child, (0.0, 0.0, z), (0.0, 0.0, 0.0, 1.0))])
    return Envelope("/tf_static" if parent == "base_link" else "/tf", m.TF_MESSAGE, t_ms * MS, msg)


def _scan(t_ms: int) -> Envelope:
    """One beam straight ahead, 1 m: a wall at (1, 0) in odom."""
    msg = m.msg_class(m.LASER_SCAN)(
        header=m.header(t_ms * MS, "laser"),
        angle_min=0.0,
        angle_max=0.0,
        angle_increment=math.pi / 180,
        time_increment=0.0,
        scan_time=0.1,
        range_min=0.1,
        range_max=10.0,
        ranges=[1.0],
        intensities=[],
    )
    return Envelope("/scan", m.LASER_SCAN, t_ms * MS, msg)


def _run(odometry_until_ms: int, end_ms: int, scans_ms: tuple[int, ...] = (190,)) -> tuple[CostmapNode, list[int]]:
    """The local costmap of nav_go2.yaml (odom <- base_link, 5 Hz updates at 0, 200, 400 ms ...) given one scan
    at 190 ms and the robot at rest at the origin, its odometry every 35 ms (175, then 210 ms) until
    ``odometry_until_ms``: the node, and the wall cell's cost after each update."""
    nav2 = load_nav2_params(Path(__file__).parents[3] / "config" / "nav2" / "nav_go2.yaml")
    node = CostmapNode(nav2.local_costmap, "local_costmap")
    envs = [_tf(0, "base_link", "laser", 0.2), *(_scan(t) for t in scans_ms)]
    envs += [_tf(t, "odom", "base_link") for t in range(0, odometry_until_ms + 1, 35)]
    envs.append(Envelope("/clock", m.CLOCK, end_ms * MS, m.clock(end_ms * MS)))
    ex = Executor(start_ns=0)
    ex.add_source(sorted(envs, key=lambda e: e.time_ns))
    walls = []
    node_update = node._update

    def update(t: int) -> None:
        node_update(t)
        mx, my = node.costmap.world_to_cell(1.0, 0.0)
        walls.append(int(node.costmap.costs[my, mx]))

    node._update = update  # type: ignore[method-assign]
    ex.add_node(node)
    ex.run()
    ex.finish()
    return node, walls


def test_a_scan_before_its_transform_waits_for_the_next_update():
    """The scan at 190 ms comes before odometry's sample at 210 ms: the update at 200 ms cannot place it. It is
    kept, and the update at 400 ms marks its wall; nothing is skipped. (It was dropped and counted: a robot whose
    odometry runs at 28.6 Hz, its scans and its costmap's updates both at 5 Hz, lost 223 of 261 scans.)"""
    node, walls = _run(odometry_until_ms=600, end_ms=600)
    assert walls[:3] == [0, 0, LETHAL], walls
    assert not node.skipped and not node.pending


def test_a_scan_whose_transform_does_not_come_within_the_tolerance_is_skipped_and_counted():
    """Odometry stops at 175 ms: the scan at 190 ms waits while the updates are within transform_tolerance
    (0.3 s) of its stamp (200, 400 ms), then is counted as skipped at 600 ms and never marked."""
    node, walls = _run(odometry_until_ms=180, end_ms=800)
    assert node.params.transform_tolerance == 0.3
    assert LETHAL not in walls and len(walls) >= 4
    assert node.skipped == {"scan: no transform odom <- laser": 1} and not node.pending


def test_a_waiting_scan_replaced_or_left_at_the_end_is_counted_unless_its_transform_came():
    """A scan that waited at one update and was replaced by the next before its transform came could not be
    placed: it is counted, as is one still waiting when the log ends. One whose transform came before the next
    scan replaced it is superseded, as any scan a newer one replaces between updates: not counted."""
    node, walls = _run(odometry_until_ms=180, end_ms=800, scans_ms=(190, 290))
    assert node.skipped == {"scan: no transform odom <- laser": 2} and not node.pending and LETHAL not in walls
    node, _ = _run(odometry_until_ms=180, end_ms=250)  # the log ends at 250 ms, the scan waiting since 200 ms
    assert node.skipped == {"scan: no transform odom <- laser": 1}
    node, walls = _run(odometry_until_ms=800, end_ms=800, scans_ms=(190, 290))  # 190's came at 210 ms
    assert not node.skipped and walls[:3] == [0, 0, LETHAL]
