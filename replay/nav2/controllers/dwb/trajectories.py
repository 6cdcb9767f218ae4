"""DWB's trajectory generators: the velocity samples of one cycle and the trajectories they simulate.

``velocity_samples`` is ``XYThetaIterator``: per axis a ``OneDVelocityIterator`` over the dynamic
window ``current ± acc · dt`` clipped to the limits (``dt`` is ``sim_time`` for the
StandardTrajectoryGenerator, ``sim_period`` = 1 / controller_frequency for the
LimitedAccelGenerator), ``*_samples`` values with an exact 0 inserted where the window crosses it;
the product x (outer), y, theta (inner), without the twists ``max_speed_xy`` / ``min_speed_xy`` /
``min_speed_theta`` rule out and without the zero twist.

``generate`` simulates every sample at once (vectorised): the trajectory of twist ``cmd`` has
``n`` equal steps over ``sim_time`` (``ceil(sim_time / time_granularity)`` with
``discretize_by_time``, otherwise enough steps that none is longer than ``linear_granularity``
metres or ``angular_granularity`` radians); each step moves the velocity towards ``cmd`` within the
acceleration limits (the LimitedAccelGenerator jumps to ``cmd``), then the pose by that velocity.
Poses: the start, the ``n`` steps, and the last again with ``include_last_point``. Trajectories of
fewer steps are padded with their last pose (``count`` says how many are real).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from navlog.replay.compiled import compile_together
from navlog.replay.nav2.controllers.dwb.params import LIMITED_ACCEL_GENERATOR, DWBParams

EPSILON = 1e-5


def project_velocity(v0, accel, decel, dt, target):
    """``projectVelocity``: v0 moved towards ``target`` by at most ``accel · dt`` (up) or ``decel · dt`` (down)."""
    return np.where(v0 < target, np.minimum(target, v0 + accel * dt), np.maximum(target, v0 + decel * dt))


def axis_samples(current: float, vmin: float, vmax: float, acc: float, decel: float, dt: float, n: int) -> list[float]:
    """The velocities ``OneDVelocityIterator`` returns, in order (with its inserted exact zero)."""
    current = min(max(current, vmin), vmax)
    hi = float(project_velocity(current, acc, decel, dt, vmax))
    lo = float(project_velocity(current, acc, decel, dt, vmin))
    if abs(lo - hi) < EPSILON:
        return [lo]
    increment = (hi - lo) / max(1, max(2, n) - 1)
    out, v, zero_pending = [], lo, True
    while v <= hi + EPSILON:
        out.append(v)
        if zero_pending and v < 0.0 < v + increment and v + increment <= hi + EPSILON:
            out.append(0.0)
            zero_pending = False
        v += increment
    return out


def velocity_samples(p: DWBParams, current: tuple[float, float, float], dt: float) -> np.ndarray:
    """(K, 3) twists (vx, vy, wz) of one cycle in ``XYThetaIterator``'s order (see the module docstring)."""
    xs = axis_samples(current[0], p.min_vel_x, p.max_vel_x, p.acc_lim_x, p.decel_lim_x, dt, p.vx_samples)
    ys = axis_samples(current[1], p.min_vel_y, p.max_vel_y, p.acc_lim_y, p.decel_lim_y, dt, p.vy_samples)
    ths = axis_samples(
        current[2], -p.max_vel_theta, p.max_vel_theta, p.acc_lim_theta, p.decel_lim_theta, dt, p.vtheta_samples
    )
    grid = np.array(np.meshgrid(xs, ys, ths, indexing="ij"), dtype=np.float64).reshape(3, -1).T
    vx, vy, th = grid[:, 0], grid[:, 1], grid[:, 2]
    vmag_sq = vx * vx + vy * vy
    ok = ~((vmag_sq == 0.0) & (th == 0.0))
    if p.max_speed_xy >= 0.0:
        ok &= ~(vmag_sq > p.max_speed_xy**2 + EPSILON)
    if p.min_speed_xy >= 0.0 and p.min_speed_theta >= 0.0:
        ok &= ~((vmag_sq + EPSILON < p.min_speed_xy**2) & (np.abs(th) + EPSILON < p.min_speed_theta))
    return grid[ok]


def step_counts(p: DWBParams, twists: np.ndarray) -> np.ndarray:
    """(K,) the number of simulation steps of each twist's trajectory (at least 1)."""
    if p.discretize_by_time:
        n = np.full(len(twists), math.ceil(p.sim_time / p.time_granularity), dtype=np.int64)
    else:
        linear = np.hypot(twists[:, 0], twists[:, 1]) * p.sim_time / p.linear_granularity
        angular = np.abs(twists[:, 2]) * p.sim_time / p.angular_granularity
        n = np.ceil(np.maximum(linear, angular)).astype(np.int64)
    return np.maximum(n, 1)


@dataclass
class Trajectories:
    """One cycle's simulated trajectories, K of them, padded to P poses."""

    twists: np.ndarray  # (K, 3) the command each trajectory stands for (vx, vy, wz)
    poses: np.ndarray  # (K, P, 3) x, y, yaw in the costmap frame; padded with the last pose
    times: np.ndarray  # (K, P) seconds from the start of each pose
    count: np.ndarray  # (K,) how many of the P poses are real

    @property
    def valid(self) -> np.ndarray:
        """(K, P) True where a pose is real, False where it pads."""
        return np.arange(self.poses.shape[1])[None, :] < self.count[:, None]

    def last(self) -> np.ndarray:
        """(K, 3) the last pose of each trajectory."""
        return self.poses[:, -1]


def window_time(p: DWBParams, controller_frequency: float) -> float:
    """The time over which the velocity window reaches: sim_time, or the LimitedAccelGenerator's period."""
    if p.trajectory_generator_name != LIMITED_ACCEL_GENERATOR:
        return p.sim_time
    if p.sim_period > 0.0:
        return p.sim_period
    return 1.0 / controller_frequency if controller_frequency > 0 else 0.05


def simulate(pose, velocity, twists, n, dt, acc, decel, limited, poses, times):
    """Fill ``poses`` (K, P, 3) and ``times`` (K, P) with the trajectories; returns (K, 3) the first step's velocities.

    Trajectory k runs ``n[k]`` steps of ``dt[k]`` seconds from ``pose`` at ``velocity``: each step
    the velocity moves towards ``twists[k]`` by ``acc · dt`` / ``decel · dt`` at most (jumps to it when
    ``limited``), then the pose moves by it; the rest of the row repeats the last pose.
    """
    k_count, p_count = poses.shape[0], poses.shape[1]
    first = np.empty((k_count, 3))
    vel = np.empty(3)
    for k in range(k_count):
        x, y, th = pose[0], pose[1], pose[2]
        for a in range(3):
            vel[a] = velocity[a]
        poses[k, 0, 0], poses[k, 0, 1], poses[k, 0, 2] = x, y, th
        times[k, 0] = 0.0
        h = dt[k]
        for i in range(1, p_count):
            if i <= n[k]:
                for a in range(3):
                    target = twists[k, a]
                    if limited:
                        vel[a] = target
                    elif vel[a] < target:
                        vel[a] = min(target, vel[a] + acc[a] * h)
                    else:
                        vel[a] = max(target, vel[a] + decel[a] * h)
                if i == 1:
                    for a in range(3):
                        first[k, a] = vel[a]
                c, s = np.cos(th), np.sin(th)
                x = x + (vel[0] * c - vel[1] * s) * h
                y = y + (vel[0] * s + vel[1] * c) * h
                th = th + vel[2] * h
                times[k, i] = i * h
            else:
                times[k, i] = times[k, i - 1]
            poses[k, i, 0], poses[k, i, 1], poses[k, i, 2] = x, y, th
    return first


@functools.cache
def compiled_simulate() -> Callable[..., np.ndarray]:
    """``simulate`` compiled by numba (on first use; cached on disk)."""
    return compile_together(globals(), (simulate,))["simulate"]


def generate(
    p: DWBParams, pose: tuple[float, float, float], velocity: tuple[float, float, float], twists: np.ndarray
) -> Trajectories:
    """The trajectory of every twist from ``pose`` at ``velocity`` (see the module docstring)."""
    twists = np.ascontiguousarray(twists, dtype=np.float64).reshape(-1, 3)
    n = step_counts(p, twists)
    steps = int(n.max()) if len(n) else 1
    extra = 1 if p.include_last_point else 0
    poses = np.empty((len(twists), steps + 1 + extra, 3))
    times = np.empty((len(twists), steps + 1 + extra))
    first = compiled_simulate()(
        np.asarray(pose, dtype=np.float64),
        np.asarray(velocity, dtype=np.float64),
        twists,
        n,
        p.sim_time / n,
        np.array([p.acc_lim_x, p.acc_lim_y, p.acc_lim_theta]),
        np.array([p.decel_lim_x, p.decel_lim_y, p.decel_lim_theta]),
        p.trajectory_generator_name == LIMITED_ACCEL_GENERATOR,
        poses,
        times,
    )
    reported = first if p.limit_vel_cmd_in_traj else twists.copy()
    return Trajectories(twists=reported, poses=poses, times=times, count=n + 1 + extra)
