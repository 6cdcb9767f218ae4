"""``DWBController``: Nav2's DWB local planner (``dwb_core::DWBLocalPlanner``) as a navlog controller.

One cycle, as ``DWBLocalPlanner::computeVelocityCommands``:

1. the global plan is transformed into the costmap frame (``transform_plan``): it starts at the
   first pose closer than ``prune_distance`` (and half the costmap's size) to the robot, searched
   only within the first ``prune_distance`` metres of the plan, and ends before the first pose
   farther than ``forward_prune_distance`` (with ``shorten_transformed_plan``); with ``prune_plan``
   the poses before its start are dropped from the plan for good;
2. every critic is prepared with the robot pose and twist, the goal (the plan's end) and the
   transformed plan;
3. the trajectory generator samples the velocity window and simulates every sample;
4. each trajectory's total is ``Σ scale · score`` over the critics (a critic whose scale is 0 is
   skipped); illegal ones are dropped; the lowest total wins, the first of equals. The totals
   are computed for all samples at once: Nav2's ``short_circuit_trajectory_evaluation`` only stops
   adding critics for a trajectory already worse than the best, so it cannot change the winner;
5. the critics are debriefed with the command (zero when no trajectory is legal, which raises
   ``NoValidControl`` naming the critics that ruled the samples out).
"""

from __future__ import annotations

import numpy as np

from navlog.errors import ConfigError
from navlog.replay.nav2.controllers.base import (
    ControlContext,
    ControllerSetup,
    ControlResult,
    InvalidPath,
    NoValidControl,
    Pose2D,
    Twist2D,
    first_after_integrated_distance,
    transform_poses,
)
from navlog.replay.nav2.controllers.dwb.critics import Critic, Cycle, make_critic
from navlog.replay.nav2.controllers.dwb.params import DWBParams, kinematics_problems
from navlog.replay.nav2.controllers.dwb.trajectories import generate, velocity_samples, window_time
from navlog.replay.nav2.costmap.footprint import radius_footprint
from navlog.replay.nav2.costmap.grid import CostmapGrid

SHOWN_TRAJECTORIES = 64  # legal trajectories returned for drawing, evenly spread over the samples


class DWBController:
    """Nav2's DWB local planner (see the module docstring); built once per controller plugin."""

    def __init__(self, params: DWBParams, setup: ControllerSetup) -> None:
        problems = kinematics_problems(params)
        if problems:
            raise ConfigError("DWB: " + "; ".join(message for _, message in problems))
        if not params.critics:
            raise ConfigError("DWB needs 'critics' (e.g. [RotateToGoal, Oscillation, BaseObstacle, PathDist, ...])")
        missing = [name for name in params.critics if name not in params.critic_params]
        if missing:
            raise ConfigError(f"DWB critics {missing} have no known critic class (see `navlog check-config`)")
        self.params = params
        self.setup = setup
        self.critics: list[Critic] = [make_critic(name, params.critic_params[name]) for name in params.critics]
        self.window_time = window_time(params, setup.controller_frequency)
        self.plan: np.ndarray | None = None

    # ---------------------------------------------------------- nav2_core::Controller
    def set_plan(self, path: np.ndarray) -> None:
        """A new global plan (N, 3) in the plan frame; the critics' state is reset, as DWB's ``setPlan``."""
        self.plan = np.array(path, dtype=np.float64).reshape(-1, 3)
        for critic in self.critics:
            critic.reset()

    def reset(self) -> None:
        self.plan = None
        for critic in self.critics:
            critic.reset()

    def compute_velocity_commands(self, pose: Pose2D, velocity: Twist2D, ctx: ControlContext) -> ControlResult:
        local_plan = self.transform_plan(pose, ctx)
        assert self.plan is not None
        goal = transform_poses(self.plan[-1:], ctx.global_to_local)[0]
        cycle = Cycle(
            pose=pose,
            velocity=velocity,
            goal=(float(goal[0]), float(goal[1]), float(goal[2])),
            plan=local_plan,
            costmap=ctx.costmap,
            footprint=self._footprint(ctx.costmap),
            xy_goal_tolerance=self.params.xy_goal_tolerance,
            trans_stopped_velocity=self.params.trans_stopped_velocity,
            now_ns=ctx.now_ns,
        )
        for critic in self.critics:
            critic.prepare(cycle)
        twists = velocity_samples(self.params, velocity, self.window_time)
        trajs = generate(self.params, pose, velocity, twists)
        total = np.zeros(len(twists))
        illegal = np.zeros(len(twists), dtype=bool)
        reasons: dict[str, int] = {}
        for critic in self.critics:
            scale = critic.scale(cycle)
            if scale == 0.0:
                continue
            score, bad, why = critic.score(trajs, cycle)
            newly = int((bad & ~illegal).sum())
            if newly:
                reasons[f"{critic.name}: {why}"] = newly
            total = total + score * scale
            illegal |= bad
        if illegal.all():
            for critic in self.critics:
                critic.debrief((0.0, 0.0, 0.0), cycle)
            detail = ", ".join(f"{n} by {why}" for why, n in reasons.items())
            raise NoValidControl(f"DWB: no legal trajectory among {len(twists)} samples ({detail or 'none sampled'})")
        best = int(np.argmin(np.where(illegal, np.inf, total)))
        cmd = (float(trajs.twists[best, 0]), float(trajs.twists[best, 1]), float(trajs.twists[best, 2]))
        for critic in self.critics:
            critic.debrief(cmd, cycle)
        legal = np.flatnonzero(~illegal)
        shown = legal[np.linspace(0, len(legal) - 1, min(len(legal), SHOWN_TRAJECTORIES)).astype(np.int64)]
        return ControlResult(cmd=cmd, local_plan=local_plan, trajectories=trajs.poses[shown, :, :2])

    # ---------------------------------------------------------- steps
    def transform_plan(self, pose: Pose2D, ctx: ControlContext) -> np.ndarray:
        """The plan's part near the robot in the costmap frame (see the module docstring, step 1)."""
        if self.plan is None or len(self.plan) == 0:
            raise InvalidPath("DWB received a plan with zero length")
        p = self.params
        cm = ctx.costmap
        robot = transform_poses(np.array([pose], dtype=np.float64), np.linalg.inv(ctx.global_to_local))[0]
        half = max(cm.size_x, cm.size_y) * cm.resolution / 2.0
        start_threshold = min(half, p.prune_distance) if p.prune_plan else half
        end_threshold = min(half, p.forward_prune_distance) if p.shorten_transformed_plan else half
        xy = self.plan[:, :2]
        dist = np.hypot(xy[:, 0] - robot[0], xy[:, 1] - robot[1])
        stop = first_after_integrated_distance(xy, p.prune_distance)
        near = np.flatnonzero(dist[:stop] < start_threshold)
        begin = int(near[0]) if len(near) else stop
        far = np.flatnonzero(dist[begin:] > end_threshold)
        end = begin + int(far[0]) if len(far) else len(xy)
        local = transform_poses(self.plan[begin:end], ctx.global_to_local)
        if p.prune_plan:
            self.plan = self.plan[begin:]
        if len(local) == 0:
            raise InvalidPath(
                f"DWB: no pose of the plan lies within {start_threshold:g} m of the robot (the transformed plan is empty)"
            )
        return local

    def _footprint(self, costmap: CostmapGrid) -> np.ndarray:
        if len(self.setup.footprint):
            return np.asarray(self.setup.footprint, dtype=np.float64).reshape(-1, 2)
        if len(costmap.footprint):
            return np.asarray(costmap.footprint, dtype=np.float64)
        return np.asarray(radius_footprint(self.setup.robot_radius))
