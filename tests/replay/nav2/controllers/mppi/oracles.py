"""NumPy forms of the MPPI kernels: slow, plainly vectorised, the oracles the compiled kernels must equal bit for bit."""

from __future__ import annotations

import numpy as np


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


def numpy_rollouts(opt, pose, speed):
    """``Optimizer._noised_controls`` with NumPy: (cv, state, trajectories) of the optimizer's noise, the
    clamp by ``numpy_clamp_rollouts`` and the poses by float32 cumulative sums (NumPy's cos and sin)."""
    cv = opt.u[:, None, :] + opt.noises
    state = np.zeros_like(cv)
    state[:, :, 0] = opt._speed(speed)[:, None]
    numpy_clamp_rollouts(cv, state, *opt._clamp_limits())
    dt = np.float32(opt.p.model_dt)
    vx, vy, wz = state
    yaw = np.float32(pose[2]) + np.cumsum(wz * dt, axis=-1)
    c, s = np.empty_like(yaw), np.empty_like(yaw)
    c[..., 0], s[..., 0] = np.float32(np.cos(pose[2])), np.float32(np.sin(pose[2]))
    np.cos(yaw[..., :-1], out=c[..., 1:])
    np.sin(yaw[..., :-1], out=s[..., 1:])
    dx, dy = vx * c, vx * s
    if opt.holonomic:
        dx, dy = dx - vy * s, dy + vy * c
    x = np.float32(pose[0]) + np.cumsum(dx * dt, axis=-1)
    y = np.float32(pose[1]) + np.cumsum(dy * dt, axis=-1)
    return cv, state, np.stack([x, y, yaw])


def numpy_furthest_reached(path, x_end, y_end):
    """``furthest_reached_index`` with NumPy: a suffix minimum per trajectory, the rows composed pairwise."""
    d = (path[None, :, 0] - x_end[:, None]) ** 2 + (path[None, :, 1] - y_end[:, None]) ** 2
    n = d.shape[1]
    suffix_min = np.minimum.accumulate(d[:, ::-1], axis=1)[:, ::-1]
    holds = np.where(d == suffix_min, np.arange(n), n)
    nearest = np.minimum.accumulate(holds[:, ::-1], axis=1)[:, ::-1]  # first index of the minimum of d[i, r:]
    while len(nearest) > 1:  # r_i = nearest[i, r_(i-1)] from r = 0
        if len(nearest) % 2:
            nearest = np.vstack([nearest, np.arange(n)])
        nearest = np.take_along_axis(nearest[1::2], nearest[0::2], axis=1)
    return int(nearest[0, 0])


def numpy_cost_critic(critic, data):
    """``CostCritic``'s per-trajectory cost (before its weight) and fail flag with NumPy, centre check only."""
    cm, p = data.costmap, critic.p
    step = p.trajectory_point_step
    n = data.x.shape[1] // step
    tx, ty = data.x[:, : n * step : step], data.y[:, : n * step : step]
    fx, fy = (tx - cm.origin_x) / cm.resolution, (ty - cm.origin_y) / cm.resolution
    inside = (fx >= 0) & (fy >= 0) & (fx < cm.size_x) & (fy < cm.size_y)
    cost = np.where(inside, cm.costs[np.where(inside, fy, 0).astype(int), np.where(inside, fx, 0).astype(int)], 255)
    tracking = bool(cm.params.track_unknown_space)
    collide = ((cost == 254) | (cost == 253) | ((cost == 255) & (not tracking))) & (cost >= 1)
    add = np.where(
        cost >= p.near_collision_cost, p.critical_cost, 0.0 if data.robot_near_goal(p.near_goal_distance) else cost
    )
    any_collide = collide.any(axis=1)
    return np.where(any_collide, p.collision_cost, add.sum(axis=1)) / n, bool(any_collide.all())


def numpy_path_align(critic, data):
    """``PathAlignCritic``'s per-trajectory mean distance with NumPy (searchsorted, running maximum)."""
    p = critic.p
    count, valid = data.furthest_reached(), data.path_points_valid()
    path = data.path[:count]
    along = np.concatenate([[0.0], np.cumsum(np.hypot(np.diff(path[:, 0]), np.diff(path[:, 1])))])
    step = p.trajectory_point_step
    tx, ty, tyaw = data.x[:, ::step], data.y[:, ::step], data.yaw[:, ::step]
    traj_len = np.cumsum(np.hypot(np.diff(tx, axis=1), np.diff(ty, axis=1)), axis=1)
    i = np.searchsorted(along, traj_len, side="right")
    last = len(along) - 1
    ic = np.minimum(i, last)
    prev = along[np.maximum(ic - 1, 0)]
    nearest = np.where(i > last, last, np.where(traj_len - prev < along[ic] - traj_len, ic - 1, ic))
    nearest = np.maximum.accumulate(nearest, axis=1)
    ok = valid[nearest]
    dx, dy = path[nearest, 0] - tx[:, 1:], path[nearest, 1] - ty[:, 1:]
    d2 = dx * dx + dy * dy
    if p.use_path_orientations:
        t = np.fmod(tyaw[:, 1:] - path[nearest, 2] + np.pi, 2.0 * np.pi)
        d2 = d2 + np.where(t < 0.0, t + np.pi, t - np.pi) ** 2
    samples = ok.sum(axis=1)
    return np.where(samples > 0, np.where(ok, np.sqrt(d2), 0.0).sum(axis=1) / np.maximum(samples, 1), 0.0)


def numpy_per_trajectory(name, critic, data):
    """The other batch critics' per-trajectory cost (before weight and power) with NumPy, by name."""
    dt = data.model_dt
    if name == "GoalCritic":
        return np.hypot(data.x - data.goal[0], data.y - data.goal[1]).mean(axis=1)
    if name == "PreferForwardCritic":
        return (np.maximum(-data.vx, 0.0) * dt).sum(axis=1)
    if name == "TwirlingCritic":
        return np.abs(data.wz).mean(axis=1)
    if name == "VelocityDeadbandCritic":
        db = [abs(v) for v in (tuple(critic.p.deadband_velocities) + (0.0, 0.0, 0.0))[:3]]
        out = np.maximum(db[0] - np.abs(data.vx), 0.0) + np.maximum(db[2] - np.abs(data.wz), 0.0)
        if data.holonomic:
            out = out + np.maximum(db[1] - np.abs(data.vy), 0.0)
        return (out * dt).sum(axis=1)
    if name == "ConstraintCritic":
        omni = critic.model == "Omni"
        v = np.where(data.vx > 0.0, 1.0, -1.0) * np.hypot(data.vx, data.vy) if omni else data.vx
        out = np.maximum(v - critic.max_vel, 0.0) + np.maximum(critic.min_vel - v, 0.0)
        if critic.model == "Ackermann":
            with np.errstate(divide="ignore", invalid="ignore"):
                out = out + np.maximum(critic.min_turning_r - np.abs(data.vx) / np.abs(data.wz), 0.0)
        return (out * dt).sum(axis=1)
    raise KeyError(name)
