"""``nav2_mppi_controller::MPPIController`` as a navlog ``Controller`` (see ``controllers.base``)."""

from __future__ import annotations

import numpy as np

from navlog.replay.nav2.controllers.base import ControlContext, ControllerSetup, ControlResult, Pose2D, Twist2D
from navlog.replay.nav2.controllers.mppi.critics import build_critics
from navlog.replay.nav2.controllers.mppi.optimizer import Optimizer
from navlog.replay.nav2.controllers.mppi.params import MPPIParams
from navlog.replay.nav2.controllers.mppi.path_handler import PathHandler


class MPPIController:
    """One cycle: the path handler's goal and local plan, then the optimizer's command (``Optimizer.eval_control``)."""

    def __init__(self, params: MPPIParams, setup: ControllerSetup) -> None:
        self.params = params
        self.setup = setup
        self.critics = build_critics(params, setup)
        self.optimizer = Optimizer(params, setup, self.critics)
        self.path_handler = PathHandler(params)

    def set_plan(self, path: np.ndarray) -> None:
        self.path_handler.set_path(path)

    def set_speed_limit(self, limit: float, percentage: bool) -> None:
        """Nav2's speed limit: a percentage of the maximum speeds, or an absolute vx limit; 0 removes it."""
        self.optimizer.set_speed_limit(limit, percentage)

    def reset(self) -> None:
        self.optimizer.reset()
        self.optimizer.set_speed_limit(0.0, True)

    def compute_velocity_commands(self, pose: Pose2D, velocity: Twist2D, ctx: ControlContext) -> ControlResult:
        goal = self.path_handler.goal(ctx.global_to_local)
        local = self.path_handler.transform_path(pose, ctx.global_to_local, ctx.costmap)
        tol = getattr(ctx.goal_checker, "xy_goal_tolerance", None) if ctx.goal_checker is not None else None
        cmd = self.optimizer.eval_control(
            pose, velocity, local, (goal[0], goal[1]), ctx.costmap, None if tol is None else float(tol)
        )
        traj = self.optimizer.trajectories
        sample = np.stack([traj[0, ::5, ::3], traj[1, ::5, ::3]], axis=-1)  # the sample alone stacked
        return ControlResult(cmd=cmd, local_plan=local, trajectories=sample)
