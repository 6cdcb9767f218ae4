"""What every controller of the controller server shares: its inputs, its result and its errors.

A controller (Regulated Pure Pursuit, MPPI, DWB) is built once from its parameter dataclass and a
``ControllerSetup`` (the controller server's frequency, the run's seed, the local costmap's
footprint); then, as Nav2's ``nav2_core::Controller``:

- ``set_plan(path)`` takes a new global plan (a new goal, or every replan of the navigator);
- ``compute_velocity_commands(pose, velocity, ctx)`` returns one ``ControlResult`` per controller
  cycle, or raises ``NoValidControl`` (Nav2's ``NoValidControl`` exception: the server counts
  ``failure_tolerance`` from it) or ``ControllerError`` (any other failure, which aborts the goal);
- ``reset()`` forgets all state (the server calls it when a goal ends or fails).

Frames, as in Nav2: the plan is in the global planner's frame (``map``); ``pose`` is the robot in the
local costmap's global frame (``odom``); ``ctx.global_to_local`` is the 3x3 homogeneous SE(2)
transform that takes plan coordinates into that frame (the controller transforms the plan itself,
every cycle, since ``map -> odom`` moves). ``velocity`` is the odometry twist in the robot frame
after the server's ``min_*_velocity_threshold``. All of it is pure computation on sim time:
``ctx.now_ns`` is the cycle's time, never the wall clock.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from navlog.errors import NavlogError
from navlog.replay.nav2.costmap.grid import CostmapGrid

Pose2D = tuple[float, float, float]  # x, y (metres), yaw (radians)
Twist2D = tuple[float, float, float]  # vx, vy (m/s), wz (rad/s), robot frame


class ControllerError(NavlogError):
    """A controller failed in a way Nav2 reports as an error code (``code``: FollowPath's, e.g. 103)."""

    code = 100  # FollowPath UNKNOWN


class InvalidPath(ControllerError):
    """The plan cannot be followed: empty, or nothing of it left near the robot (FollowPath code 103)."""

    code = 103


class NoValidControl(ControllerError):
    """No command this cycle (Nav2's ``nav2_core::NoValidControl``, FollowPath code 106)."""

    code = 106


class GoalTolerances(Protocol):
    """What a controller may ask of the goal checker (Nav2's ``getTolerances``)."""

    xy_goal_tolerance: float
    yaw_goal_tolerance: float


@dataclass(frozen=True)
class ControllerSetup:
    """What the controller server gives a controller when it configures it."""

    controller_frequency: float = 20.0  # Hz; MPPI and RPP read it
    seed: int = 0  # the run's seed: a controller that samples noise draws it from here
    footprint: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))  # (K, 2) robot frame; empty: circular
    robot_radius: float = 0.1  # used when ``footprint`` is empty
    # where a controller may run work beside its cycle (a ``navlog.replay.mapping.background.Background``:
    # takes a call, returns its wait); None: at once, in the caller
    background: Callable[[Callable[[], None]], Callable[[], None]] | None = None


@dataclass
class ControlContext:
    """One controller cycle's surroundings: time, the local costmap, the plan's frame, the goal checker."""

    now_ns: int
    costmap: CostmapGrid  # the local costmap (``costs[my, mx]``, Nav2 cost values, frame = pose's frame)
    global_to_local: np.ndarray  # (3, 3) SE(2): plan frame -> costmap frame
    goal_checker: GoalTolerances


@dataclass
class ControlResult:
    """One cycle's command, with what the controller considered (drawn by ``navlog view``)."""

    cmd: Twist2D
    local_plan: np.ndarray  # (N, 3) x, y, yaw in the costmap frame: the plan the controller followed
    trajectories: np.ndarray | None = None  # (K, T, 2) candidate trajectories (a sample), or None


class Controller(Protocol):
    """A controller plugin's implementation: ``cls(params, setup)``; see the module docstring."""

    def set_plan(self, path: np.ndarray) -> None: ...

    def compute_velocity_commands(self, pose: Pose2D, velocity: Twist2D, ctx: ControlContext) -> ControlResult: ...

    def reset(self) -> None: ...


def first_after_integrated_distance(xy: np.ndarray, distance: float, start: int = 0) -> int:
    """Nav2's ``first_after_integrated_distance``: the first index after ``start`` at which the path
    (N, >=2) has run more than ``distance`` metres from ``start`` (``len(xy)`` when it never does)."""
    if start >= len(xy):
        return len(xy)
    seg = np.hypot(np.diff(xy[start:, 0]), np.diff(xy[start:, 1]))
    over = np.flatnonzero(np.cumsum(seg) > distance)
    return start + 1 + int(over[0]) if len(over) else len(xy)


def se2(x: float, y: float, yaw: float) -> np.ndarray:
    """The 3x3 homogeneous matrix of the pose (x, y, yaw)."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.array([[c, -s, x], [s, c, y], [0.0, 0.0, 1.0]])


def transform_poses(poses: np.ndarray, T: np.ndarray) -> np.ndarray:
    """Poses (N, 3) x, y, yaw moved by the SE(2) matrix ``T`` (3, 3)."""
    out = np.empty_like(poses, dtype=float)
    out[:, :2] = poses[:, :2] @ T[:2, :2].T + T[:2, 2]
    out[:, 2] = poses[:, 2] + np.arctan2(T[1, 0], T[0, 0])
    return out
