"""Navigation metrics: goal episodes from events, clearance to a known grid, command jerk."""

from __future__ import annotations

import numpy as np
import pytest

from navlog.analysis.metrics.navigation import (
    clearance_field,
    clearances,
    command_jerk,
    goal_episodes,
    navigation_metrics,
)
from navlog.analysis.metrics.trajectory import Trajectory
from navlog.replay.occupancy_map import OccupancyMap

S = 1_000_000_000


def wall_map() -> OccupancyMap:
    """A 4 m x 2 m grid at 0.05 m with a wall filling x in [3.0, 3.05) (one column of cells)."""
    data = np.zeros((40, 80), dtype=np.int8)
    data[:, 60] = 100  # cell 60 spans x 3.00 .. 3.05
    return OccupancyMap(data=data, resolution=0.05, origin=(0.0, 0.0, 0.0))


def test_goal_episodes_pair_starts_and_ends_and_count_recoveries_and_collisions() -> None:
    events = [
        (1 * S, "goal_accepted", "navigator", "a", 0.0),
        (2 * S, "recovery_started", "navigator", "clear_costmaps", 0.0),
        (3 * S, "collision", "sim", "wall_1", 0.01),
        (4 * S, "goal_succeeded", "navigator", "", 0.0),
        (5 * S, "goal_accepted", "navigator", "b", 0.0),
        (9 * S, "goal_failed", "navigator", "Failed to make progress", 105.0),
        (10 * S, "collision", "sim", "wall_2", 0.0),  # outside any goal
        (11 * S, "goal_accepted", "navigator", "c", 0.0),
    ]
    goals, collisions = goal_episodes(events)
    assert [(g.name, g.status, g.code) for g in goals] == [
        ("a", "succeeded", 0),
        ("b", "failed", 105),
        ("c", "unfinished", 0),
    ]
    assert goals[0].recoveries == ["clear_costmaps"] and goals[0].collisions == 1
    assert goals[1].end_ns - goals[1].start_ns == 4 * S and goals[1].message == "Failed to make progress"
    assert collisions == 2


def test_clearance_to_a_wall_is_the_distance_to_its_edge_within_half_a_cell() -> None:
    grid = wall_map()
    field = clearance_field(np.asarray(grid.data) >= 65, grid.resolution)
    xy = np.array([[1.025, 1.0], [2.525, 1.0], [2.975, 1.0], [3.025, 1.0], [-1.0, 1.0]])
    c = clearances(grid, xy, field)
    # the wall's west edge is at x = 3.0: 1.975 m, 0.475 m, 0.025 m away; on the wall 0; outside the grid NaN
    assert c[:4] == pytest.approx([1.975, 0.475, 0.025, 0.0], abs=1e-9)
    assert np.isnan(c[4])


def test_command_jerk_of_a_linear_ramp_is_zero_and_of_a_step_is_large() -> None:
    t = np.arange(0, 21) * (S // 20)  # 20 Hz for one second
    acc, jerk = command_jerk(t, 0.5 * t / S)  # 0.5 m/s^2 ramp
    assert acc == pytest.approx(np.full(20, 0.5))
    assert np.abs(jerk).max() == pytest.approx(0.0, abs=1e-9)
    step = np.where(t >= 10 * (S // 20), 0.3, 0.0)
    acc, jerk = command_jerk(t, step)
    assert acc.max() == pytest.approx(0.3 * 20)  # 0.3 m/s in one 50 ms step
    assert np.abs(jerk).max() == pytest.approx(0.3 * 20 * 20)


def test_navigation_metrics_per_goal_path_clearance_and_speed() -> None:
    # the robot drives along y = 1 from x = 1 to x = 2.5 at 0.5 m/s: 3 s, 1.5 m, nearest the wall at 0.5 m
    t = np.arange(0, 301) * (S // 100)
    x = 1.0 + 0.5 * t / S
    pos = np.stack([x, np.full_like(x, 1.0), np.zeros_like(x)], axis=1)
    gt = Trajectory(t, pos, np.tile([0.0, 0.0, 0.0, 1.0], (len(t), 1)))
    events = [(0, "goal_accepted", "navigator", "east", 0.0), (3 * S, "goal_succeeded", "navigator", "", 0.0)]
    out = navigation_metrics(events, gt, (t, np.full(len(t), 0.5)), wall_map())
    assert out is not None
    g = out["goals"][0]
    assert (g["name"], g["status"], g["time_s"]) == ("east", "succeeded", 3.0)
    assert g["path_length_m"] == pytest.approx(1.5)
    assert g["min_clearance_m"] == pytest.approx(0.475)  # from the centre (2.525) of the cell x = 2.5 lies in
    assert out["speed_mps"]["mean"] == pytest.approx(0.5)
    assert out["goals_succeeded"] == 1 and out["collisions"] == 0
    assert out["command_jerk_mps3"]["max"] == 0.0


def test_a_log_without_goal_events_has_no_navigation_section() -> None:
    assert navigation_metrics([(0, "collision", "sim", "x", 0.0)], None, None) is None
