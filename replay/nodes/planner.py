"""The planner node: Nav2's planner server on the executor (its costmap: ``navlog.replay.nodes.costmap``).

``PlannerNode`` holds the goals (from /goal_pose or a goal list), plans from the robot pose (TF
global_frame <- robot_base_frame) every ``replan_period_s`` and publishes /plan (nav_msgs/Path).
When the log has robot TF (``wait_for_robot_tf``), planning waits for the transform, as scans do;
legs that never get a robot pose (the log ends first) are planned at the end as a chain from
``start``. Without any robot TF (a log with only a map), it plans the goal list as such a chain at
once. Either way each leg planned without a robot pose carries a note and is counted.
``path_cdr`` writes the path it publishes (``navlog.replay.io.pose_cdr``).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from navlog.replay import messages as m
from navlog.replay.io import pose_cdr
from navlog.replay.nav2.planners import Planner, PlanningError, PlanResult, Pose2D
from navlog.replay.nodes.costmap import CostmapNode
from navlog.replay.runtime.executor import Node
from navlog.replay.runtime.tf import TransformError


def path_cdr(plan: PlanResult | None, t: int, frame: str, xyyaw: np.ndarray | None = None) -> bytes:
    """The CDR bytes of the nav_msgs/Path of a plan's poses (or of ``xyyaw``, (N, 3) x, y, yaw) stamped
    ``t`` in ``frame``."""
    rows = xyyaw if xyyaw is not None else plan.poses if plan is not None else np.zeros((0, 3))
    return pose_cdr.path(t, frame, rows)


class PlannerNode(Node):
    name = "planner_server"

    def __init__(
        self,
        costmap_node: CostmapNode,
        planner: Planner,
        goals: list[Pose2D] | None = None,
        goal_frame: str = "map",
        replan_period_s: float = 1.0,
        goal_tolerance: float = 0.25,
        start: Pose2D = (0.0, 0.0, 0.0),
        goal_topic: str = "/goal_pose",
        wait_for_robot_tf: bool = False,
    ) -> None:
        super().__init__()
        self.cm_node = costmap_node
        self.planner = planner
        self.goals = list(goals or [])
        self.goal_frame = goal_frame
        self.period = int(round(replan_period_s * 1e9))
        self.goal_tolerance = goal_tolerance
        self.start = start
        self.goal_topic = goal_topic
        self.index = 0
        self.plans: list[tuple[int, PlanResult]] = []
        self.failures: list[tuple[int, str]] = []
        self.chained = False
        self.wait_for_robot_tf = wait_for_robot_tf
        self.had_robot_pose = False

    def setup(self) -> None:
        self.subscribe(self.goal_topic, self._on_goal, (m.POSE_STAMPED,))
        self.create_timer(self.period, self._tick)

    def _on_goal(self, msg: Any, t: int) -> None:
        q = msg.pose.orientation
        yaw = m.yaw_from_quat((q.x, q.y, q.z, q.w))
        self.goals = [(float(msg.pose.position.x), float(msg.pose.position.y), yaw)]
        self.goal_frame = msg.header.frame_id or self.cm_node.params.global_frame
        self.index = 0
        self._tick(t)

    def _goal_in_global(self, goal: Pose2D, t: int) -> Pose2D | None:
        frame = self.goal_frame.lstrip("/")
        gframe = self.cm_node.params.global_frame
        if frame == gframe:
            return goal
        try:
            T = self.cm_node.tf.lookup(gframe, frame, t)
        except TransformError:
            self.skipped[f"goal in frame '{frame}': no transform to '{gframe}'"] += 1
            self.failures.append((t, f"goal in frame '{frame}' has no transform to '{gframe}'"))
            return None
        x, y = T[0, 0] * goal[0] + T[0, 1] * goal[1] + T[0, 3], T[1, 0] * goal[0] + T[1, 1] * goal[1] + T[1, 3]
        return x, y, goal[2] + math.atan2(T[1, 0], T[0, 0])

    def _plan(self, start: Pose2D, goal: Pose2D, t: int, note: str = "") -> None:
        try:
            plan = self.planner.plan(self.cm_node.costmap, start, goal)
        except PlanningError as exc:
            self.skipped["planning failed"] += 1
            self.failures.append((t, f"{note}: {exc}" if note else str(exc)))
            self.publish("/navlog/events", m.EVENT_TYPE, m.event(t, "plan_failed", self.name, str(exc)))
            return
        if note:
            plan.notes.append(note)
        self.plans.append((t, plan))
        self.publish_cdr("/plan", m.PATH, path_cdr(plan, t, self.cm_node.params.global_frame))

    def _plan_chain(self, t: int) -> None:
        """Plan the goals not yet planned as a chain of legs from ``start``, each leg noted and counted."""
        self.chained = True
        p = self.cm_node.params
        prev = self.start
        for leg_goal in self.goals[self.index :]:
            g = self._goal_in_global(leg_goal, t)
            if g is None:
                return
            self.skipped[f"legs planned without a robot pose ({p.global_frame} <- {p.robot_base_frame})"] += 1
            note = (
                f"no robot pose ({p.global_frame} <- {p.robot_base_frame}): leg planned from "
                f"({prev[0]:.2f}, {prev[1]:.2f})"
            )
            self._plan(prev, g, t, note)
            prev = g
        self.index = len(self.goals)

    def finish(self) -> None:
        # the log ended before the robot TF came: plan what is left from `start`, and say so
        if self.wait_for_robot_tf and not self.had_robot_pose and not self.chained and self.index < len(self.goals):
            if self.cm_node.updates:
                self._plan_chain(self.now())

    def _tick(self, t: int) -> None:
        if self.index >= len(self.goals) or self.cm_node.updates == 0:
            return
        robot = self.cm_node.robot_pose(t)
        if robot is None:
            if self.chained or self.had_robot_pose:
                return
            if self.wait_for_robot_tf:
                return  # the transform may still come (as scans wait for theirs)
            self._plan_chain(t)  # no robot TF in the log at all
            return
        self.had_robot_pose = True
        goal = self._goal_in_global(self.goals[self.index], t)
        if goal is None:
            return
        if math.hypot(robot[0] - goal[0], robot[1] - goal[1]) <= self.goal_tolerance:
            self.publish("/navlog/events", m.EVENT_TYPE, m.event(t, "goal_reached", self.name, "", self.index))
            self.index += 1
            if self.index >= len(self.goals):
                return
            goal = self._goal_in_global(self.goals[self.index], t)
            if goal is None:
                return
        self._plan(robot, goal, t)


def plan_lengths(plans: list[tuple[int, PlanResult]]) -> np.ndarray:
    return np.array([p.length for _, p in plans])
