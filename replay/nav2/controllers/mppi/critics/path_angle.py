"""``mppi::critics::PathAngleCritic``: the trajectories' heading at their end towards a path point ahead."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from navlog.replay.geometry import remainder_angle, shortest_angular_distances
from navlog.replay.nav2.controllers.base import Pose2D
from navlog.replay.nav2.controllers.mppi.critics.base import Critic, CriticParams
from navlog.replay.nav2.schema import param

if TYPE_CHECKING:
    from navlog.replay.nav2.controllers.base import ControllerSetup
    from navlog.replay.nav2.controllers.mppi.critic_data import CriticData
    from navlog.replay.nav2.controllers.mppi.params import MPPIParams


@dataclass(frozen=True)
class PathAngleCriticParams(CriticParams):
    cost_weight: float = param(2.2, ge=0.0)
    offset_from_furthest: int = param(4, ge=0)
    threshold_to_consider: float = param(0.5, ge=0.0)
    max_angle_to_furthest: float = param(0.785398, ge=0.0)
    mode: int = param(0, choices=(0, 1, 2))


def pose_point_angle(pose: Pose2D, px: float, py: float, mode: int, point_yaw: float) -> float:
    """Nav2's ``posePointAngle``: the robot's heading error to a point (mode 1: either way; 2: along point_yaw)."""
    yaw = math.atan2(py - pose[1], px - pose[0])
    if mode == 2:
        if abs(float(shortest_angular_distances(yaw, point_yaw))) > math.pi / 2:
            yaw = remainder_angle(yaw + math.pi)
        return abs(float(shortest_angular_distances(yaw, pose[2])))
    fwd = abs(float(shortest_angular_distances(yaw, pose[2])))
    if mode == 1:
        return min(fwd, abs(float(shortest_angular_distances(yaw, remainder_angle(pose[2] + math.pi)))))
    return fwd


class PathAngleCritic(Critic[PathAngleCriticParams]):
    """Heading error of the trajectory's end to a path point ahead, when the robot faces away from it."""

    def __init__(self, p: PathAngleCriticParams, mppi: MPPIParams, setup: ControllerSetup) -> None:
        super().__init__(p, mppi, setup)
        reversing = abs(mppi.vx_min) >= 1e-6 and mppi.vx_min < 0.0
        self.mode = 0 if (p.mode == 1 and not reversing) else p.mode

    def score(self, data: CriticData) -> None:
        p = self.p
        if data.robot_near_goal(p.threshold_to_consider):
            return
        idx = min(data.furthest_reached() + p.offset_from_furthest, len(data.path) - 1)
        gx, gy, gyaw = (float(v) for v in data.path[idx])
        if pose_point_angle(data.pose, gx, gy, self.mode, gyaw) < p.max_angle_to_furthest:
            return
        between = np.arctan2(gy - data.y[:, -1], gx - data.x[:, -1])
        end_yaw = data.yaw[:, -1]
        if self.mode == 1:
            fwd = np.abs(shortest_angular_distances(end_yaw, between))
            between = np.where(fwd < math.pi / 2, between, shortest_angular_distances(-math.pi, between))
        elif self.mode == 2:
            away = np.abs(shortest_angular_distances(between, gyaw)) >= math.pi / 2
            between = np.where(away, shortest_angular_distances(-math.pi, between), between)
        self.add(data, np.abs(shortest_angular_distances(end_yaw, between)))
