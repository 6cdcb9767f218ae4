"""The navigation stack on the executor: costmaps, planner, controller server, behaviours and navigator.

``NavigationStack(nav2, goals=..., mode=...)`` builds, from one Nav2 parameter file, the nodes to add
to the executor in this order (``nodes``):

1. the global costmap (``global_costmap``: ``CostmapNode``, fed by /map or ``static_map``, the
   obstacle sources and TF), publishing ``/global_costmap/costmap`` at its ``publish_frequency``;
2. the local costmap (``local_costmap``: usually a rolling window in ``odom``), publishing
   ``/local_costmap/costmap`` and ``/local_costmap/published_footprint``;
3. ``NavigationNode``: the navigator (``navlog.replay.nav2.navigator``: the default tree's replanning
   and recoveries, the waypoint follower), the planner (the planner server's ``GridBased``, the
   default tree's planner id), the controller server (``FollowPath``) and the behaviours, all on
   sim time: the navigator ticks every ``bt_loop_duration`` (10 ms), the controller cycles every
   1/``controller_frequency``, a behaviour every 1/``cycle_frequency``.

The navigator's first tick is at ``start_ns`` (default: the executor's start, the log's first
message in a replay, 0 live), then every ``bt_loop_duration``. The robot pose comes from TF (global frame <- robot base for the navigator and planner, the local
costmap's frame <- robot base for the controller and behaviours); the navigator waits for it and
for the first global costmap update, counting the ticks it waited. The odometry twist is the latest
message on ``odom_topic``. Goals come from the list (each published on ``/goal_pose`` as it is
accepted) or, with no list, from a ``/goal_pose`` subscription (a new goal pre-empts the running one).

Published: ``/plan`` (nav_msgs/Path, every plan), ``cmd_topic`` (Twist, or TwistStamped with
``controller_server.enable_stamped_cmd_vel``: controller and behaviour commands, zero when a goal
or behaviour ends), ``/local_plan`` (the controller's local plan), the costmaps, ``/goal_pose`` and
navigation events on ``/navlog/events`` (``goal_accepted``, ``goal_succeeded``, ``goal_failed``,
``replan_failed``, ``follow_path_failed``, ``costmap_cleared``, ``recovery_started``,
``recovery_failed``, ``waypoint_passed``). Same inputs, same output bytes.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Sequence
from typing import Any

import numpy as np

from navlog.errors import ConfigError
from navlog.replay import messages as m
from navlog.replay.geometry import yaw_from_matrix
from navlog.replay.nav2.behaviors import BackUp, Behavior, BehaviorServerParams, Spin, Wait
from navlog.replay.nav2.controllers.base import ControlContext, ControllerSetup, se2
from navlog.replay.nav2.controllers.controller_server import RUNNING, SUCCEEDED, ControllerServer
from navlog.replay.nav2.controllers.server import ControllerServerParams
from navlog.replay.nav2.costmap import CostmapParams, default_costmap_params
from navlog.replay.nav2.costmap.cost_values import LETHAL
from navlog.replay.nav2.navigator import (
    ActionResult,
    BtNavigatorParams,
    GoalResult,
    NavGoal,
    Navigator,
    Pose2D,
    WaypointFollowerParams,
)
from navlog.replay.nav2.params import Nav2Params
from navlog.replay.nav2.planners import PLANNER_NAMES, Planner, PlanningError, PlanResult, make_planner
from navlog.replay.nodes.collision_monitor import EVENTS_TOPIC
from navlog.replay.nodes.costmap import CostmapNode
from navlog.replay.nodes.planner import path_cdr
from navlog.replay.occupancy_map import OccupancyMap
from navlog.replay.runtime.executor import Node
from navlog.replay.runtime.tf import TransformError
from navlog.replay.workers.background import SerialThread

__all__ = ["GoalResult", "NavGoal", "NavigationNode", "NavigationStack"]

PLANNER_ID = "GridBased"  # the default tree's PlannerSelector default
CONTROLLER_ID = "FollowPath"  # the default tree's ControllerSelector default
# nav2_msgs/action/ComputePathToPose codes (ComputePathThroughPoses: + 100)
START_OUTSIDE_MAP, GOAL_OUTSIDE_MAP, GOAL_OCCUPIED, NO_VALID_PATH, PLAN_TF_ERROR = 203, 204, 206, 208, 202


def _count(d: dict[str, int], key: str) -> None:
    d[key] = d.get(key, 0) + 1


def default_local_costmap() -> CostmapParams:
    """A local costmap when the file has none: Nav2 bringup's, a 3 x 3 m rolling window in odom, no static layer."""
    base = default_costmap_params()
    plugins = tuple(p for p in base.plugins if p != "static_layer")
    return dataclasses.replace(
        base,
        global_frame="odom",
        rolling_window=True,
        width=3,
        height=3,
        resolution=0.05,
        plugins=plugins,
        layers={k: v for k, v in base.layers.items() if k in plugins},
    )


def server_planner(nav2: Nav2Params) -> Planner:
    """The planner the default tree asks for (``GridBased``), built as the planner server configures it."""
    server = nav2.planner_server
    params = server.planners.get(PLANNER_ID) if server is not None else None
    if server is not None and PLANNER_ID not in server.planner_plugins:
        listed = ", ".join(server.planner_plugins)
        raise ConfigError(
            f"planner_server: the default navigation tree plans with '{PLANNER_ID}', planner_plugins lists [{listed}]"
        )
    if server is not None and params is None:
        raise ConfigError(
            f"planner_server: planner '{PLANNER_ID}' has no parameters navlog read (its plugin is unknown to navlog or "
            "read but not implemented; run `navlog check-config`)"
        )
    plugin = params.plugin if params is not None else PLANNER_NAMES["navfn"]
    short = next(name for name, p in PLANNER_NAMES.items() if p == plugin)
    return make_planner(server, short, PLANNER_ID if params is not None else "")


class NavigationNode(Node):
    """The navigator, planner, controller server and behaviours on sim time (see the module docstring)."""

    name = "bt_navigator"

    def __init__(
        self,
        nav2: Nav2Params,
        global_node: CostmapNode,
        local_node: CostmapNode,
        *,
        goals: Sequence[NavGoal] = (),
        mode: str = "waypoints",
        seed: int = 0,
        cmd_topic: str = "/cmd_vel_nav",
        odom_topic: str = "/odom",
        start_ns: int | None = None,
    ) -> None:
        super().__init__()
        self.gnode, self.lnode = global_node, local_node
        self.bt = nav2.bt_navigator or BtNavigatorParams()
        self.bparams = nav2.behavior_server or BehaviorServerParams()
        self.cparams = nav2.controller_server or ControllerServerParams()
        self.planner = server_planner(nav2)
        gp = nav2.planner_server.planners.get(PLANNER_ID) if nav2.planner_server is not None else None
        self.goal_occupied_check = gp is not None and gp.plugin == PLANNER_NAMES["navfn"] and gp.tolerance == 0.0
        lcm = local_node.costmap
        setup = ControllerSetup(
            controller_frequency=self.cparams.controller_frequency,
            seed=seed,
            footprint=np.asarray(lcm.footprint, dtype=float).reshape(-1, 2),
            robot_radius=local_node.params.robot_radius,
            background=SerialThread(),  # MPPI draws the next cycle's noise beside the node
        )
        self.server = ControllerServer(self.cparams, setup, controller_id=CONTROLLER_ID)
        # a list to collect each controller cycle's wall time in s (``navlog.campaign``); None: not timed.
        # Wall time depends on the machine: it never reaches an output.
        self.cycle_wall_s: list[float] | None = None
        self.has_goal_list = bool(goals)
        self.navigator = Navigator(
            self,
            goals=goals,
            mode=mode,
            tree=self.bt.tree,
            waypoint_follower=nav2.waypoint_follower or WaypointFollowerParams(),
        )
        self.cmd_topic, self.odom_topic, self.start_ns = cmd_topic, odom_topic, start_ns
        self.stamped = self.cparams.enable_stamped_cmd_vel
        self.tick_ns = int(self.bt.bt_loop_duration) * 1_000_000
        self.control_ns = int(round(1e9 / self.cparams.controller_frequency))
        self.behavior_ns = int(round(1e9 / self.bparams.cycle_frequency))
        self.odom_twist: tuple[float, float, float] = (0.0, 0.0, 0.0)
        self.next_control: int | None = None
        self.follow_result: ActionResult | None = None
        self.behavior: Behavior | None = None
        self.next_behavior: int | None = None
        self.behavior_done: ActionResult | None = None
        self.plans: list[tuple[int, PlanResult]] = []
        self.goal_count = 0
        self.started = False

    # ------------------------------------------------------------ wiring
    def setup(self) -> None:
        self.subscribe(self.odom_topic, self._on_odom, (m.ODOMETRY,))
        if not self.has_goal_list:
            self.subscribe("/goal_pose", self._on_goal, (m.POSE_STAMPED,))
        self.create_timer(self.tick_ns, self._tick, self.start_ns)

    def _on_odom(self, msg: Any, t: int) -> None:
        tw = msg.twist.twist
        self.odom_twist = (float(tw.linear.x), float(tw.linear.y), float(tw.angular.z))

    def _on_goal(self, msg: Any, t: int) -> None:
        q = msg.pose.orientation
        pose = (float(msg.pose.position.x), float(msg.pose.position.y), m.yaw_from_quat((q.x, q.y, q.z, q.w)))
        frame = (msg.header.frame_id or self.bt.global_frame).lstrip("/")
        if frame != self.bt.global_frame:
            T = self._lookup(self.bt.global_frame, frame, t)
            if T is None:
                _count(self.skipped, f"/goal_pose in '{frame}': no transform to '{self.bt.global_frame}'")
                return
            c, s = T[0, 0], T[1, 0]
            pose = (
                c * pose[0] - s * pose[1] + T[0, 3],
                s * pose[0] + c * pose[1] + T[1, 3],
                pose[2] + yaw_from_matrix(T),
            )
        self.goal_count += 1
        self.navigator.set_goal(NavGoal(f"goal_{self.goal_count}", pose), t)
        self._publish_events()

    # ------------------------------------------------------------ poses
    def _lookup(self, target: str, source: str, t: int) -> np.ndarray | None:
        try:
            return self.gnode.tf.lookup(target, source, t)
        except TransformError:
            try:
                return self.gnode.tf.lookup(target, source, None)
            except TransformError:
                return None

    def _pose(self, frame: str, t: int) -> Pose2D | None:
        T = self._lookup(frame, self.gnode.params.robot_base_frame, t)
        return None if T is None else (float(T[0, 3]), float(T[1, 3]), yaw_from_matrix(T))

    def robot_pose(self) -> Pose2D | None:
        return self._pose(self.bt.global_frame, self.now())

    # ------------------------------------------------------------ the navigator's backend
    def compute_path(self, goals: Sequence[Pose2D], now_ns: int) -> ActionResult:
        through = 100 if len(goals) > 1 or self.navigator.mode == "through_poses" else 0
        start = self.robot_pose()
        if start is None:
            return ActionResult(False, PLAN_TF_ERROR + through, "no robot pose for planning")
        cm = self.gnode.costmap
        for code, p, what in ((START_OUTSIDE_MAP, start, "start"), *((GOAL_OUTSIDE_MAP, g, "goal") for g in goals)):
            if cm.cost_at(p[0], p[1]) is None:
                return ActionResult(False, code + through, f"{what} ({p[0]:.2f}, {p[1]:.2f}) is outside the costmap")
        if self.goal_occupied_check:  # NavFn's GoalOccupied: tolerance 0 and the goal cell lethal
            for g in goals:
                if cm.cost_at(g[0], g[1]) == LETHAL:
                    return ActionResult(False, GOAL_OCCUPIED + through, f"goal ({g[0]:.2f}, {g[1]:.2f}) is occupied")
        legs: list[np.ndarray] = []
        prev = start
        try:
            for g in goals:
                plan = self.planner.plan(cm, prev, g)
                self.plans.append((now_ns, plan))
                legs.append(plan.poses if not legs else plan.poses[1:])
                prev = g
        except PlanningError as exc:
            return ActionResult(False, NO_VALID_PATH + through, str(exc))
        path = np.concatenate(legs)
        self.publish_cdr("/plan", m.PATH, path_cdr(None, now_ns, self.gnode.params.global_frame, path))
        return ActionResult(True, path=path)

    def clear_costmap(self, which: str, now_ns: int) -> None:
        (self.lnode if which == "local" else self.gnode).clear_entirely()

    def follow_path(self, path: np.ndarray, now_ns: int) -> None:
        if not self.server.active:
            self.next_control = now_ns  # the controller server's loop starts at the goal
            self.follow_result = None
        self.server.follow_path(path, now_ns)

    def follow_path_result(self) -> ActionResult | None:
        res, self.follow_result = self.follow_result, None
        return res

    def cancel_follow_path(self, now_ns: int) -> None:
        if self.server.active:
            self.server.cancel()
            self._publish_cmd((0.0, 0.0, 0.0), now_ns)
        self.next_control = None

    def start_behavior(self, kind: str, args: dict[str, float], now_ns: int) -> None:
        bp = self.bparams
        behavior: Behavior = (
            Spin(bp, args["target_yaw"])
            if kind == "spin"
            else BackUp(bp, args["dist"], args["speed"])
            if kind == "backup"
            else Wait(bp, args["duration"])
        )
        failed = behavior.start(now_ns, self._pose(bp.local_frame, now_ns))
        if failed is not None:
            self.behavior_done = ActionResult(False, failed.code, failed.message)
            return
        self.behavior, self.next_behavior, self.behavior_done = behavior, now_ns, None
        self._step_behavior(now_ns)

    def behavior_result(self) -> ActionResult | None:
        res, self.behavior_done = self.behavior_done, None
        return res

    def cancel_behavior(self, now_ns: int) -> None:
        if self.behavior is not None and not isinstance(self.behavior, Wait):
            self._publish_cmd((0.0, 0.0, 0.0), now_ns)
        self.behavior = self.next_behavior = None

    # ------------------------------------------------------------ the loop
    def _tick(self, t: int) -> None:
        if not self.started:
            if self.gnode.updates == 0 or self.lnode.updates == 0:
                _count(self.skipped, "navigator ticks waiting for the first costmap updates")
                return
            if self.robot_pose() is None:
                p = self.gnode.params
                _count(
                    self.skipped,
                    f"navigator ticks waiting for the robot pose ({p.global_frame} <- {p.robot_base_frame})",
                )
                return
            self.started = True
        self.navigator.tick(t)
        if self.next_control is not None and self.server.active and t >= self.next_control:
            self.next_control += self.control_ns
            self._control(t)
        if self.behavior is not None and self.next_behavior is not None and t >= self.next_behavior:
            self._step_behavior(t)
        self._publish_events()

    def _control(self, t: int) -> None:
        lframe = self.lnode.params.global_frame
        pose = self._pose(lframe, t)
        T = self._lookup(lframe, self.bt.global_frame, t)
        g2l = np.eye(3) if T is None else se2(float(T[0, 3]), float(T[1, 3]), yaw_from_matrix(T))
        if T is None:
            pose = None  # the plan cannot be brought into the controller's frame: TF_ERROR
        ctx = ControlContext(
            now_ns=t, costmap=self.lnode.costmap, global_to_local=g2l, goal_checker=self.server.goal_checker
        )  # type: ignore[arg-type]
        if self.cycle_wall_s is None:
            out = self.server.cycle(t, pose, self.odom_twist, ctx)
        else:
            start = time.perf_counter()
            out = self.server.cycle(t, pose, self.odom_twist, ctx)
            self.cycle_wall_s.append(time.perf_counter() - start)
        self._publish_cmd(out.cmd, t)
        if out.result is not None and len(out.result.local_plan):
            poses = out.result.local_plan
            self.publish_cdr("/local_plan", m.PATH, path_cdr(None, t, lframe, poses))
        if out.status != RUNNING:
            self.follow_result = ActionResult(out.status == SUCCEEDED, out.code, out.message)
            self.next_control = None

    def _step_behavior(self, t: int) -> None:
        assert self.behavior is not None and self.next_behavior is not None
        self.next_behavior += self.behavior_ns
        step = self.behavior.step(t, self._pose(self.bparams.local_frame, t), self.lnode.costmap)  # type: ignore[arg-type]
        if step.cmd is not None:
            self._publish_cmd(step.cmd, t)
        if step.status != RUNNING:
            self.behavior_done = ActionResult(step.status == SUCCEEDED, step.code, step.message)
            self.behavior = self.next_behavior = None

    # ------------------------------------------------------------ outputs
    def _publish_cmd(self, cmd: tuple[float, float, float], t: int) -> None:
        twist = m.twist(*cmd)
        if self.stamped:
            msg = m.msg_class(m.TWIST_STAMPED)(header=m.header(t, self.gnode.params.robot_base_frame), twist=twist)
            self.publish(self.cmd_topic, m.TWIST_STAMPED, msg)
        else:
            self.publish(self.cmd_topic, m.TWIST, twist)

    def _publish_events(self) -> None:
        nav = self.navigator
        if self.has_goal_list:
            frame = self.bt.global_frame
            for g in nav.accepted:
                msg = m.msg_class(m.POSE_STAMPED)(
                    header=m.header(self.now(), frame),
                    pose=m.pose((g.pose[0], g.pose[1], 0.0), m.quat_from_yaw(g.pose[2])),
                )
                self.publish("/goal_pose", m.POSE_STAMPED, msg)
        nav.accepted.clear()
        for ns, kind, detail, value in nav.events:
            self.publish(EVENTS_TOPIC, m.EVENT_TYPE, m.event(ns, kind, self.name, detail, value))
        nav.events.clear()


class NavigationStack:
    """The costmap nodes and the navigation node built from one Nav2 file (see the module docstring)."""

    def __init__(
        self,
        nav2: Nav2Params,
        *,
        goals: Sequence[NavGoal] = (),
        mode: str = "waypoints",
        static_map: OccupancyMap | None = None,
        seed: int = 0,
        cmd_topic: str = "/cmd_vel_nav",
        odom_topic: str = "/odom",
        start_ns: int | None = None,
    ) -> None:
        if mode not in ("waypoints", "through_poses"):
            raise ConfigError(f"navigation mode must be 'waypoints' or 'through_poses', got {mode!r}")
        self.goals = list(goals)
        gparams = nav2.global_costmap or default_costmap_params()
        lparams = nav2.local_costmap or default_local_costmap()
        self.global_costmap = CostmapNode(
            gparams, "global_costmap", static_map=static_map, publish_period_s=_period(gparams.publish_frequency)
        )
        self.local_costmap = CostmapNode(
            lparams, "local_costmap", static_map=static_map, publish_period_s=_period(lparams.publish_frequency)
        )
        self.navigation = NavigationNode(
            nav2,
            self.global_costmap,
            self.local_costmap,
            goals=self.goals,
            mode=mode,
            seed=seed,
            cmd_topic=cmd_topic,
            odom_topic=odom_topic,
            start_ns=start_ns,
        )
        self.nodes: list[Node] = [self.global_costmap, self.local_costmap, self.navigation]

    @property
    def results(self) -> list[GoalResult]:
        return self.navigation.navigator.results

    @property
    def outputs(self) -> list[str]:
        """The topics the stack publishes (a replay regenerates them: never read from the log)."""
        out = {"/plan", "/local_plan", self.navigation.cmd_topic, EVENTS_TOPIC}
        if self.navigation.has_goal_list:  # without one it reads /goal_pose instead
            out.add("/goal_pose")
        for node in (self.global_costmap, self.local_costmap):
            out |= {f"/{node.name}/costmap", f"/{node.name}/published_footprint"}
        return sorted(out)

    @property
    def sensor_topics(self) -> list[str]:
        """The topics the costmaps observe (their obstacle sources), the global costmap's first."""
        return self.global_costmap.topics + self.local_costmap.topics

    @property
    def done(self) -> bool:
        """Every goal of the list ended (never, without a list: goals come from /goal_pose)."""
        return bool(self.goals) and len(self.results) >= len(self.goals)

    def skipped(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for node in (self.global_costmap, self.local_costmap):
            out.update({f"{node.name}: {k}": v for k, v in node.skipped.items()})
            out.update({f"{node.name}: {k}": v for k, v in node.costmap.skipped.items()})
        out.update(self.navigation.skipped)
        return out


def _period(frequency: float) -> float | None:
    return 1.0 / frequency if frequency > 0 else None
