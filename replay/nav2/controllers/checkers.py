"""Goal and progress checkers of the controller server, as ``nav2_controller``'s plugins compute them.

A goal checker decides when the robot has reached its goal: ``SimpleGoalChecker`` (xy within
``xy_goal_tolerance``, the boundary counting as reached, then yaw within ``yaw_goal_tolerance``;
``stateful``: once inside the xy tolerance only yaw is checked until ``reset``; with
``symmetric_yaw_tolerance`` the goal yaw + pi is accepted too), ``StoppedGoalChecker`` (also the
odometry twist below ``trans_stopped_velocity`` / ``rot_stopped_velocity``) and
``PositionGoalChecker`` (xy only, latched when stateful).

A progress checker decides when the robot has stopped making progress: ``SimpleProgressChecker``
keeps a baseline pose and its time; moving strictly more than ``required_movement_radius`` from it
moves the baseline, and the check fails once ``movement_time_allowance`` seconds of sim time pass
without such a move. ``PoseProgressChecker`` also counts rotating more than
``required_movement_angle`` as progress.

Poses are (x, y, yaw) tuples, twists (vx, vy, wz); time is integer nanoseconds of sim time, passed in.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from navlog.replay.geometry import normalize_angle, shortest_angular_distance
from navlog.replay.nav2.plugins import PluginParams
from navlog.replay.nav2.schema import param

Pose2D = tuple[float, float, float]  # x, y (metres), yaw (radians)
Twist2D = tuple[float, float, float]  # vx, vy (m/s), wz (rad/s)


@dataclass(frozen=True)
class GoalCheckerParams(PluginParams):
    """``nav2_controller::SimpleGoalChecker`` / ``StoppedGoalChecker`` / ``PositionGoalChecker`` parameters."""

    plugin: str = "nav2_controller::SimpleGoalChecker"
    xy_goal_tolerance: float = param(0.25, ge=0.0)
    yaw_goal_tolerance: float = param(0.25, ge=0.0)
    stateful: bool = True
    symmetric_yaw_tolerance: bool = False
    trans_stopped_velocity: float = param(0.25, ge=0.0)
    rot_stopped_velocity: float = param(0.25, ge=0.0)
    # Nav2 after Jazzy: the goal counts only within this length of the path's end (navlog does not check it)
    READ_ONLY: ClassVar[tuple[str, ...]] = ("path_length_tolerance",)


@dataclass(frozen=True)
class ProgressCheckerParams(PluginParams):
    """``nav2_controller::SimpleProgressChecker`` / ``PoseProgressChecker`` parameters.

    Nav2 does not bound ``required_movement_radius``: a negative radius makes every check pass.
    """

    plugin: str = "nav2_controller::SimpleProgressChecker"
    required_movement_radius: float = 0.5
    movement_time_allowance: float = param(10.0, ge=0.0)
    required_movement_angle: float = param(0.5, ge=0.0)


class SimpleGoalChecker:
    """``nav2_controller::SimpleGoalChecker``; see the module docstring."""

    def __init__(self, params: GoalCheckerParams) -> None:
        self.params = params
        self.xy_goal_tolerance = params.xy_goal_tolerance
        self.yaw_goal_tolerance = params.yaw_goal_tolerance
        self._tol_sq = params.xy_goal_tolerance * params.xy_goal_tolerance
        self.check_xy = True

    def reset(self) -> None:
        """Forget the xy latch (the controller server calls it on every new path)."""
        self.check_xy = True

    def _xy_reached(self, pose: Pose2D, goal: Pose2D) -> bool:
        dx, dy = pose[0] - goal[0], pose[1] - goal[1]
        return dx * dx + dy * dy <= self._tol_sq

    def is_goal_reached(self, pose: Pose2D, goal: Pose2D, velocity: Twist2D) -> bool:
        """True when ``pose`` is within tolerance of ``goal`` (``velocity`` is ignored)."""
        if self.check_xy:
            if not self._xy_reached(pose, goal):
                return False
            if self.params.stateful:
                self.check_xy = False
        tol = self.yaw_goal_tolerance
        if abs(shortest_angular_distance(pose[2], goal[2])) <= tol:
            return True
        if self.params.symmetric_yaw_tolerance:
            return abs(shortest_angular_distance(pose[2], normalize_angle(goal[2] + math.pi))) <= tol
        return False


class StoppedGoalChecker(SimpleGoalChecker):
    """``nav2_controller::StoppedGoalChecker``: the simple check, and the robot (nearly) stopped."""

    def is_goal_reached(self, pose: Pose2D, goal: Pose2D, velocity: Twist2D) -> bool:
        if not super().is_goal_reached(pose, goal, velocity):
            return False
        p = self.params
        return abs(velocity[2]) <= p.rot_stopped_velocity and math.hypot(velocity[0], velocity[1]) <= (
            p.trans_stopped_velocity
        )


class PositionGoalChecker(SimpleGoalChecker):
    """``nav2_controller::PositionGoalChecker``: xy only; when stateful, reached stays reached until reset."""

    def __init__(self, params: GoalCheckerParams) -> None:
        super().__init__(params)
        self.yaw_goal_tolerance = 0.0  # Nav2 reports a zero orientation tolerance
        self.position_reached = False

    def reset(self) -> None:
        self.position_reached = False

    def is_goal_reached(self, pose: Pose2D, goal: Pose2D, velocity: Twist2D) -> bool:
        if self.params.stateful and self.position_reached:
            return True
        reached = self._xy_reached(pose, goal)
        if self.params.stateful and reached:
            self.position_reached = True
        return reached


class SimpleProgressChecker:
    """``nav2_controller::SimpleProgressChecker``; see the module docstring."""

    def __init__(self, params: ProgressCheckerParams) -> None:
        self.params = params
        self._allowance_ns = int(round(params.movement_time_allowance * 1e9))
        self.baseline: Pose2D | None = None
        self.baseline_ns = 0

    def reset(self) -> None:
        """Forget the baseline (at the start of a goal)."""
        self.baseline = None

    def _moved_enough(self, pose: Pose2D, baseline: Pose2D) -> bool:
        return math.hypot(pose[0] - baseline[0], pose[1] - baseline[1]) > self.params.required_movement_radius

    def check(self, pose: Pose2D, now_ns: int) -> bool:
        """False when the robot has not moved enough for longer than the allowance."""
        if self.baseline is None or self._moved_enough(pose, self.baseline):
            self.baseline = pose
            self.baseline_ns = now_ns
            return True
        return now_ns - self.baseline_ns <= self._allowance_ns


class PoseProgressChecker(SimpleProgressChecker):
    """``nav2_controller::PoseProgressChecker``: rotating more than ``required_movement_angle`` is progress too."""

    def _moved_enough(self, pose: Pose2D, baseline: Pose2D) -> bool:
        return (
            super()._moved_enough(pose, baseline)
            or abs(shortest_angular_distance(pose[2], baseline[2])) > self.params.required_movement_angle
        )


GoalChecker = SimpleGoalChecker  # the interface every goal checker has
ProgressChecker = SimpleProgressChecker  # the interface every progress checker has
