"""Nav2's behaviours (Spin, BackUp, Wait) stepped at 10 Hz of sim time on a small local costmap."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navlog.replay.nav2.behaviors import (
    FAILED,
    RUNNING,
    SUCCEEDED,
    BackUp,
    BehaviorServerParams,
    Spin,
    Wait,
    collision_free,
)
from navlog.replay.nav2.costmap.cost_values import LETHAL, NO_INFORMATION
from navlog.replay.nav2.costmap.grid import CostmapGrid, CostmapParams

S = 1_000_000_000
DT = S // 10  # cycle_frequency 10 Hz
P = BehaviorServerParams()
RECT = "[[0.5, 0.2], [0.5, -0.2], [-0.5, -0.2], [-0.5, 0.2]]"  # 1.0 x 0.4 m


def grid(fill=0):
    cm = CostmapGrid(
        CostmapParams(
            width=4, height=4, resolution=0.05, origin_x=-2.0, origin_y=-2.0, footprint=RECT, footprint_padding=0.0
        )
    )
    cm.costs[:] = fill
    return cm


def block(cm, x0, x1, y0, y1, value=LETHAL):
    """Cells whose centres lie in [x0, x1] x [y0, y1] set to ``value``."""
    xs, ys = cm.cell_centres()
    cm.costs[(xs >= x0) & (xs <= x1) & (ys >= y0) & (ys <= y1)] = value


def run(behavior, pose, cm, t0=0, max_steps=400):
    """Start, then step at 10 Hz, integrating each command for 0.1 s; returns (steps, final pose)."""
    assert behavior.start(t0, pose) is None
    steps = []
    t = t0
    for _ in range(max_steps):
        out = behavior.step(t, pose, cm)
        steps.append(out)
        if out.status != RUNNING:
            return steps, pose
        vx, _, wz = out.cmd or (0.0, 0.0, 0.0)
        pose = (pose[0] + vx * 0.1 * math.cos(pose[2]), pose[1] + vx * 0.1 * math.sin(pose[2]), pose[2] + wz * 0.1)
        t += DT
    raise AssertionError("did not end")


def test_spin_velocity_law_and_end():
    steps, pose = run(Spin(P, 1.57), (0.0, 0.0, 0.0), grid())
    w = [s.cmd[2] for s in steps[:-1]]
    # remaining >= 0.17 rad: sqrt(2 * 3.2 * remaining) >= 1.04, clamped to max_rotational_vel 1.0
    assert w[:15] == [1.0] * 15
    assert w[15] == pytest.approx(math.sqrt(2 * 3.2 * 0.07))  # remaining 0.07 -> 0.6693
    assert w[16] == 0.4  # remaining 0.0031 -> 0.14, raised to min_rotational_vel
    assert len(w) == 17 and steps[-1].status == SUCCEEDED and steps[-1].cmd == (0.0, 0.0, 0.0)
    assert pose[2] == pytest.approx(1.5 + 0.1 * w[15] + 0.04)


def test_spin_negative_target_turns_clockwise():
    steps, pose = run(Spin(P, -1.0), (0.0, 0.0, 3.0), grid())
    assert steps[0].cmd == (0.0, 0.0, -1.0) and steps[-1].status == SUCCEEDED
    assert pose[2] == pytest.approx(2.0, abs=0.05)  # wrapped through nothing; 1 rad clockwise


def test_spin_look_ahead_quirk_checks_only_the_angle_already_travelled():
    cm = grid()
    block(cm, 0.0, 0.6, 0.40, 0.45)  # the front-left corner (0.5, 0.2) reaches y 0.40 at yaw ~0.45
    assert collision_free(cm, 0.0, 0.0, 0.3) and not collision_free(cm, 0.0, 0.0, 0.5)
    steps, pose = run(Spin(P, 1.57), (0.0, 0.0, 0.0), cm)
    # the first step checks nothing (travelled 0), although 2 s ahead at 1 rad/s collides;
    # at yaw 0.2 it looks 0.2 ahead (free), at yaw 0.3 it looks 0.3 ahead (0.5: lethal)
    assert [s.status for s in steps] == [RUNNING, RUNNING, RUNNING, FAILED]
    assert steps[-1].code == 703 and steps[-1].cmd == (0.0, 0.0, 0.0)
    assert pose[2] == pytest.approx(0.3)


def test_spin_timeout_and_missing_pose():
    spin = Spin(P, 1.57, time_allowance=10.0)
    assert spin.start(0, (0.0, 0.0, 0.0)) is None
    assert spin.step(10 * S, (0.0, 0.0, 0.0), grid()).status == RUNNING  # exactly the allowance: still running
    out = spin.step(10 * S + 1, (0.0, 0.0, 0.0), grid())
    assert (out.status, out.code, out.cmd) == (FAILED, 701, (0.0, 0.0, 0.0))
    assert Spin(P).start(0, None).code == 702
    spin = Spin(P)
    spin.start(0, (0.0, 0.0, 0.0))
    assert spin.step(DT, None, grid()).code == 702


def test_backup_drives_back_the_distance():
    steps, pose = run(BackUp(P, 0.30, 0.15), (1.0, 0.5, 0.0), grid())
    assert all(s.cmd == (-0.15, 0.0, 0.0) for s in steps[:-1])
    assert steps[-1].status == SUCCEEDED and len(steps) - 1 in (20, 21)
    assert pose[0] == pytest.approx(0.70, abs=0.016) and pose[1] == 0.5
    # Humble's BT backs up at 0.05 m/s: three times the steps
    steps, _ = run(BackUp(P, 0.30, 0.05), (1.0, 0.5, 0.0), grid())
    assert len(steps) - 1 in (60, 61)


def test_backup_signs_are_forced_negative():
    steps, pose = run(BackUp(P, -0.30, 0.15), (0.0, 0.0, math.pi / 2), grid())
    assert steps[0].cmd == (-0.15, 0.0, 0.0) and pose[1] == pytest.approx(-0.30, abs=0.016)


def test_backup_look_ahead_is_limited_to_the_distance_left():
    # the rear edge is at x -0.5; backing 0.30 sweeps it to -0.8 (the look-ahead stops at -0.785)
    far = grid()
    block(far, -0.95, -0.90, -1.0, 1.0)
    steps, _ = run(BackUp(P, 0.30, 0.15), (0.0, 0.0, 0.0), far)
    assert steps[-1].status == SUCCEEDED
    near = grid()
    block(near, -0.78, -0.74, -1.0, 1.0)
    steps, _ = run(BackUp(P, 0.30, 0.15), (0.0, 0.0, 0.0), near)
    assert [s.status for s in steps] == [FAILED] and steps[0].code == 714


def test_unknown_space_and_off_grid_collide():
    steps, _ = run(BackUp(P, 0.30, 0.15), (0.0, 0.0, 0.0), grid(NO_INFORMATION))
    assert steps[0].code == 714
    assert not collision_free(grid(), 5.0, 0.0, 0.0)
    assert collision_free(grid(), 0.0, 0.0, 0.0)


def test_backup_timeout():
    b = BackUp(P, 0.30, 0.15, time_allowance=2.0)
    b.start(0, (0.0, 0.0, 0.0))
    out = b.step(2 * S + DT, (0.0, 0.0, 0.0), grid())  # not moved
    assert (out.status, out.code) == (FAILED, 711)


def test_wait_publishes_nothing_for_its_duration():
    w = Wait(P, 5.0)
    assert w.start(3 * S, None) is None
    outs = [w.step(3 * S + k * DT, None, None) for k in range(51)]
    assert all(o.status == RUNNING and o.cmd is None for o in outs[:50])
    assert outs[50].status == SUCCEEDED  # at 8 s exactly


def test_collision_free_uses_the_footprint_outline():
    cm = grid()
    block(cm, 0.57, 0.58, -0.03, 0.03)  # two cells: x [0.55, 0.60), y [-0.05, 0.05)
    assert np.count_nonzero(cm.costs == LETHAL) == 2
    assert collision_free(cm, 0.0, 0.0, 0.0)  # the front edge x 0.5 is in the cell before
    assert not collision_free(cm, 0.06, 0.0, 0.0)  # the front edge at 0.56 crosses the lethal cells
    assert collision_free(cm, 0.06, 0.3, 0.0)  # beside them
