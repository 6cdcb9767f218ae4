"""NumPy forms of the MPPI kernels, each with its kernel's arguments: slow, plainly vectorised, the oracles
the compiled kernels are compared with (bit for bit where the arithmetic is the same; see test_kernels).

``oracle_factories()`` lists (module, factory name, replacement): set each to run a cycle on the oracles.
"""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType
from typing import Any

import numpy as np

import navlog.replay.nav2.controllers.mppi.critic_data as critic_data
import navlog.replay.nav2.controllers.mppi.critics.constraint as constraint
import navlog.replay.nav2.controllers.mppi.critics.cost as cost
import navlog.replay.nav2.controllers.mppi.critics.goal as goal
import navlog.replay.nav2.controllers.mppi.critics.goal_angle as goal_angle
import navlog.replay.nav2.controllers.mppi.critics.path_align as path_align
import navlog.replay.nav2.controllers.mppi.critics.prefer_forward as prefer_forward
import navlog.replay.nav2.controllers.mppi.critics.twirling as twirling
import navlog.replay.nav2.controllers.mppi.critics.velocity_deadband as velocity_deadband
import navlog.replay.nav2.controllers.mppi.optimizer as optimizer
from navlog.replay.geometry import shortest_angular_distances


def numpy_clamp_rollouts(cv, state, axes, ups, downs):
    """``optimizer.clamp_rollouts`` with NumPy, one time step at a time over the whole batch: the oracle.

    The bounds are taken in float64 from the float32 control before, the clamped control stored as
    float32, as the kernel does.
    """
    t = cv.shape[2]
    for a in axes:
        col = np.ascontiguousarray(cv[a].T)  # (T, B): one row per time step
        last = state[a, :, 0].copy()
        up, down = ups[a], downs[a]
        for j in range(1, t):
            last64 = last.astype(np.float64)
            if a == 2:  # wz: symmetric, whatever the sign
                lo, hi = last64 + down, last64 + up
            else:  # forward: accelerate by up, slow by down; reverse: mirrored
                fwd = last > 0
                lo = last64 + np.where(fwd, down, -up)
                hi = last64 + np.where(fwd, up, -down)
            np.clip(col[j - 1], lo, hi, out=col[j - 1])
            last = col[j - 1]
        cv[a] = col.T
        state[a, :, 1:] = cv[a, :, :-1]


def numpy_noised_rollouts(u, noises, speed, axes, ups, downs, yaw0, dt, cv, state, traj):
    """``optimizer.noised_rollouts`` with NumPy: the clamp by ``numpy_clamp_rollouts``, the yaw by ``numpy_headings``."""
    cv[:] = u[:, None, :] + noises
    state[:] = 0.0
    state[:, :, 0] = speed[:, None]
    numpy_clamp_rollouts(cv, state, axes, ups, downs)
    numpy_headings(state, traj, yaw0, dt)


def numpy_headings(state, traj, yaw0, dt):
    """``optimizer.headings`` with NumPy: a float32 cumulative sum."""
    traj[2] = yaw0 + np.cumsum(state[2] * dt, axis=-1)


def numpy_positions(state, cos, sin, traj, x0, y0, dt, holonomic):
    """``optimizer.positions`` with NumPy: float32 cumulative sums."""
    vx, vy = state[0], state[1]
    dx, dy = vx * cos, vx * sin
    if holonomic:
        dx, dy = dx - vy * sin, dy + vy * cos
    traj[0] = x0 + np.cumsum(dx * dt, axis=-1)
    traj[1] = y0 + np.cumsum(dy * dt, axis=-1)


def numpy_furthest_reached_index(px, py, end_x, end_y):
    """``critic_data.furthest_reached_index`` with NumPy: a suffix minimum per trajectory, the rows composed pairwise."""
    d = (px[None, :] - end_x[:, None]) ** 2 + (py[None, :] - end_y[:, None]) ** 2
    n = d.shape[1]
    suffix_min = np.minimum.accumulate(d[:, ::-1], axis=1)[:, ::-1]
    holds = np.where(d == suffix_min, np.arange(n), n)
    nearest = np.minimum.accumulate(holds[:, ::-1], axis=1)[:, ::-1]  # first index of the minimum of d[i, r:]
    while len(nearest) > 1:  # r_i = nearest[i, r_(i-1)] from r = 0
        if len(nearest) % 2:
            nearest = np.vstack([nearest, np.arange(n)])
        nearest = np.take_along_axis(nearest[1::2], nearest[0::2], axis=1)
    return int(nearest[0, 0])


def numpy_cells_along(x, y, step, n, grid, origin_x, origin_y, resolution, out):
    """``cost.cells_along`` with NumPy (float32 ``worldToMap``)."""
    tx, ty = x[:, : n * step : step], y[:, : n * step : step]
    fx, fy = (tx - origin_x) / resolution, (ty - origin_y) / resolution
    inside = (fx >= 0) & (fy >= 0) & (fx < grid.shape[1]) & (fy < grid.shape[0])
    mx, my = np.where(inside, fx, 0).astype(np.int64), np.where(inside, fy, 0).astype(np.int64)
    out[:] = np.where(inside, grid[my, mx], 255)


def numpy_trajectory_costs(
    cost, checked, inscribed_collides, tracking, near_goal, near_collision, critical, collision, out
):
    """``cost.trajectory_costs`` with NumPy."""
    collide = (checked == 254) | ((checked == 255) & (not tracking))
    if inscribed_collides:
        collide |= checked == 253
    collide &= cost >= 1
    add = np.where(cost >= near_collision, critical, 0.0 if near_goal else cost)
    any_collide = collide.any(axis=1)
    out[:] = np.where(any_collide, collision, add.sum(axis=1))
    return bool(any_collide.all())


def numpy_aligned_distances(x, y, yaw, step, path, along, valid, use_orientations, out):
    """``path_align.aligned_distances`` with NumPy (searchsorted, a running maximum, float32 lengths)."""
    tx, ty, tyaw = x[:, ::step], y[:, ::step], yaw[:, ::step]
    dx, dy = np.diff(tx, axis=1), np.diff(ty, axis=1)
    traj_len = np.cumsum(np.sqrt(dx * dx + dy * dy), axis=1)
    i = np.searchsorted(along, traj_len, side="right")
    last = len(along) - 1
    ic = np.minimum(i, last)
    prev = along[np.maximum(ic - 1, 0)]
    nearest = np.where(i > last, last, np.where(traj_len - prev < along[ic] - traj_len, ic - 1, ic))
    nearest = np.maximum.accumulate(nearest, axis=1)
    ok = valid[nearest]
    ex, ey = path[nearest, 0] - tx[:, 1:], path[nearest, 1] - ty[:, 1:]
    d2 = ex * ex + ey * ey
    if use_orientations:
        t = np.fmod(tyaw[:, 1:] - path[nearest, 2] + np.pi, 2.0 * np.pi)
        d2 = d2 + np.where(t < 0.0, t + np.pi, t - np.pi) ** 2
    samples = ok.sum(axis=1)
    out[:] = np.where(samples > 0, np.where(ok, np.sqrt(d2), 0.0).sum(axis=1) / np.maximum(samples, 1), 0.0)


def numpy_goal_distances(x, y, gx, gy, out):
    """``goal.goal_distances`` with NumPy."""
    dx, dy = x - np.float64(gx), y - np.float64(gy)
    out[:] = np.sqrt(dx * dx + dy * dy).mean(axis=1)


def numpy_heading_errors(yaw, goal_yaw, flipped, symmetric, out):
    """``goal_angle.heading_errors`` with NumPy (``geometry.shortest_angular_distances``)."""
    d = np.abs(shortest_angular_distances(yaw, goal_yaw))
    if symmetric:
        d = np.minimum(d, np.abs(shortest_angular_distances(yaw, flipped)))
    out[:] = d.mean(axis=1)


def numpy_reverse_speeds(vx, dt, out):
    """``prefer_forward.reverse_speeds`` with NumPy."""
    out[:] = (np.maximum(-vx.astype(np.float64), 0.0) * dt).sum(axis=1)


def numpy_mean_turn_rates(wz, out):
    """``twirling.mean_turn_rates`` with NumPy."""
    out[:] = np.abs(wz.astype(np.float64)).mean(axis=1)


def numpy_deadband_speeds(vx, vy, wz, deadband, holonomic, dt, out):
    """``velocity_deadband.deadband_speeds`` with NumPy."""
    inside = np.maximum(deadband[0] - np.abs(vx.astype(np.float64)), 0.0) + np.maximum(deadband[2] - np.abs(wz), 0.0)
    if holonomic:
        inside = inside + np.maximum(deadband[1] - np.abs(vy.astype(np.float64)), 0.0)
    out[:] = (inside * dt).sum(axis=1)


def numpy_limit_excess(vx, vy, wz, max_vel, min_vel, model, min_turning_r, dt, out):
    """``constraint.limit_excess`` with NumPy."""
    v = vx.astype(np.float64)
    if model == 1:
        v = np.where(v > 0.0, 1.0, -1.0) * np.hypot(v, vy)
    excess = np.maximum(v - max_vel, 0.0) + np.maximum(min_vel - v, 0.0)
    if model == 2:
        with np.errstate(divide="ignore", invalid="ignore"):
            excess = excess + np.maximum(min_turning_r - np.abs(vx.astype(np.float64)) / np.abs(wz), 0.0)
    out[:] = (excess * dt).sum(axis=1)


def oracle_factories() -> list[tuple[ModuleType, str, Callable[[], Any]]]:
    """Every compiled kernel's factory with one that gives the NumPy oracle instead."""
    rollouts = {
        "clamp_rollouts": numpy_clamp_rollouts,
        "headings": numpy_headings,
        "positions": numpy_positions,
        "noised_rollouts": numpy_noised_rollouts,
    }
    cost_kernels = {"cells_along": numpy_cells_along, "trajectory_costs": numpy_trajectory_costs}
    return [
        (optimizer, "compiled_rollouts", lambda: rollouts),
        (critic_data, "compiled_furthest_reached_index", lambda: numpy_furthest_reached_index),
        (cost, "compiled_cost_kernels", lambda: cost_kernels),
        (path_align, "compiled_aligned_distances", lambda: numpy_aligned_distances),
        (goal, "compiled_goal_distances", lambda: numpy_goal_distances),
        (goal_angle, "compiled_heading_errors", lambda: numpy_heading_errors),
        (prefer_forward, "compiled_reverse_speeds", lambda: numpy_reverse_speeds),
        (twirling, "compiled_mean_turn_rates", lambda: numpy_mean_turn_rates),
        (velocity_deadband, "compiled_deadband_speeds", lambda: numpy_deadband_speeds),
        (constraint, "compiled_limit_excess", lambda: numpy_limit_excess),
    ]
