"""Nav2's BT navigator and waypoint follower as an explicit state machine over sim time (no executor).

navlog does not run behaviour-tree XML; it reproduces the observable behaviour of Nav2's default
trees (``navigate_to_pose_w_replanning_and_recovery.xml`` and its through-poses twin):

- ``RateController`` replans at 1 Hz (through poses: 0.333 Hz) on SIM time, timed from the last
  successful plan (Nav2's ``RateController`` uses the wall clock; a run faster than real time
  would replan less often per sim second there). A replan pre-empts ``FollowPath`` with the new path.
- Planner ``RecoveryNode(1)``: a failed plan whose code lets a planner recovery help clears the
  global costmap and plans once more. Controller ``RecoveryNode(1)``: a failed FollowPath whose code
  lets a controller recovery help clears the local costmap and follows the same path once more.
- Outer ``RecoveryNode(6)``: when navigation fails and a recovery can help (controller codes 100,
  104, 105, 106; planner codes 200, 207, 208 and 300, 307, 308), the ``RoundRobin`` runs its next
  recovery -- clear both costmaps, Spin 1.57, Wait 5 s, BackUp 0.30 m at 0.15 m/s (Humble: 0.05) --
  and navigation restarts (replanning at once). The RoundRobin index persists within a goal and
  restarts at "clear" for every goal; a recovery that fails passes to the next one, all four
  failing fails the goal. After 6 recoveries the next failure fails the goal; a code no recovery
  helps with (103 INVALID_PATH, 102, 107, 204 GOAL_OUTSIDE_MAP, ...) fails it at once. The Humble
  tree (``tree="humble"``) has no error-code gating: every failure may recover.
- A failed goal reports Nav2's code: the lowest non-zero of the planner's and the controller's last
  codes (``populateErrorCode``).
- NavigateThroughPoses: before each plan ``RemovePassedGoals`` (radius 0.7) drops leading goals the
  robot is within the radius of, always keeping the last.
- Waypoint follower: one NavigateToPose goal at a time; after a reached waypoint it pauses
  ``waypoint_pause_duration`` ms (``WaitAtWaypoint``; Nav2 sleeps on the wall clock, navlog on sim
  time); a failed one stops the rest when ``stop_on_failure``, else it is recorded and the next sent.

The navigator drives a ``NavigationBackend`` (the executor node implements it): planning and
costmap clearing complete at once; FollowPath and the behaviours run over time and are polled each
``tick(now_ns)`` (every ``bt_loop_duration``). It records events (``goal_accepted``,
``goal_succeeded``, ``goal_failed``, ``replan_failed``, ``follow_path_failed``, ``costmap_cleared``,
``recovery_started``, ``recovery_failed``, ``waypoint_passed``) and a ``GoalResult`` per goal.

``BtNavigatorParams`` / ``read_bt_navigator`` and ``WaypointFollowerParams`` /
``read_waypoint_follower`` read the ``bt_navigator`` and ``waypoint_follower`` blocks.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, ClassVar, Protocol

import numpy as np

from navlog.replay.config import suggest
from navlog.replay.limits import MAX_RATE_HZ
from navlog.replay.nav2.plugins import normalize_plugin
from navlog.replay.nav2.schema import NOTE, WARNING, SectionReader, param

Pose2D = tuple[float, float, float]  # x, y (metres), yaw (radians)

RUNNING = "running"
SUCCEEDED = "succeeded"
FAILED = "failed"

# WouldAControllerRecoveryHelp / WouldAPlannerRecoveryHelp (Jazzy)
CONTROLLER_RECOVERY_CODES = frozenset({100, 104, 105, 106})
PLANNER_RECOVERY_CODES = frozenset({200, 207, 208, 300, 307, 308})
TREES = ("jazzy", "humble")


# ---------------------------------------------------------------- parameters


@dataclass(frozen=True)
class BtNavigatorParams:
    """``bt_navigator`` node parameters navlog uses (the rest is read and noted)."""

    global_frame: str = "map"
    robot_base_frame: str = "base_link"
    odom_topic: str = "odom"
    bt_loop_duration: int = param(10, gt=0)  # ms
    default_server_timeout: int = param(20, ge=0)  # ms
    wait_for_service_timeout: int = param(1000, ge=0)  # ms
    action_server_result_timeout: float = param(900.0, ge=0.0)
    transform_tolerance: float = param(0.1, ge=0.0)
    navigators: tuple[str, ...] = ("navigate_to_pose", "navigate_through_poses")
    error_code_names: tuple[str, ...] = ("compute_path_error_code", "follow_path_error_code")
    use_sim_time: bool = False
    tree: str = "jazzy"  # not a Nav2 parameter: the default tree of the file's Nav2 (see read_bt_navigator)
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "default_server_timeout",
        "wait_for_service_timeout",
        "action_server_result_timeout",
        "default_nav_to_pose_bt_xml",
        "default_nav_through_poses_bt_xml",
        "default_bt_xml_filename",
        "plugin_lib_names",
        "enable_groot_monitoring",
        "groot_zmq_publisher_port",
        "groot_zmq_server_port",
        "groot_server_port",
        "goal_blackboard_id",
        "goals_blackboard_id",
        "path_blackboard_id",
        "use_sim_time",
        "always_reload_bt_xml",
        "introspection_mode",
        "filter_duration",
        "default_cancel_timeout",  # Nav2 after Jazzy
        "error_code_name_prefixes",  # Nav2 after Jazzy: error codes by prefix (navlog reports its own codes)
        "bt_search_directories",  # Nav2 after Jazzy: where behaviour tree files are looked for
    )


def read_bt_navigator(r: SectionReader, params: dict, path: tuple) -> BtNavigatorParams:
    """The node's parameters; a custom tree XML is warned about (navlog runs the default tree's behaviour)."""
    sections = tuple(k for k, v in params.items() if isinstance(v, dict))
    for key in ("default_nav_to_pose_bt_xml", "default_nav_through_poses_bt_xml", "default_bt_xml_filename"):
        value = params.get(key)
        if isinstance(value, str) and value and "replanning_and_recovery" not in value:
            r.add(WARNING, path + (key,), f"custom behaviour tree '{value}': navlog runs the default tree's behaviour")
    for name in sections:
        r.add(NOTE, path + (name,), "navigator plugin section read, not checked")
    humble = "navigators" not in params and ("plugin_lib_names" in params or "default_bt_xml_filename" in params)
    if humble:
        r.add(NOTE, path, "Humble bt_navigator (plugin_lib_names, no navigators): Humble's default tree is used")
    extra: dict[str, Any] = {"tree": "humble" if humble else "jazzy"}
    return r.read(
        BtNavigatorParams, {k: v for k, v in params.items() if k != "tree"}, path, sections=sections, extra=extra
    )


@dataclass(frozen=True)
class WaypointFollowerParams:
    """``waypoint_follower`` parameters with its ``WaitAtWaypoint`` task executor's."""

    loop_rate: int = param(20, gt=0, le=MAX_RATE_HZ)
    stop_on_failure: bool = True
    waypoint_task_executor_plugin: str = "wait_at_waypoint"
    action_server_result_timeout: float = param(900.0, ge=0.0)
    global_frame_id: str = "map"
    use_sim_time: bool = False
    pause_enabled: bool = True  # the task executor's ``enabled``
    waypoint_pause_duration: int = 0  # ms, the task executor's
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "loop_rate",
        "action_server_result_timeout",
        "use_sim_time",
        "introspection_mode",  # Nav2 after Jazzy
    )


WAYPOINT_EXECUTORS = (
    "nav2_waypoint_follower::WaitAtWaypoint",
    "nav2_waypoint_follower::PhotoAtWaypoint",
    "nav2_waypoint_follower::InputAtWaypoint",
)


def read_waypoint_follower(r: SectionReader, params: dict, path: tuple) -> WaypointFollowerParams:
    """The node's parameters and its ``WaitAtWaypoint`` section (other task executors are noted, not run)."""
    sections = tuple(k for k, v in params.items() if isinstance(v, dict))
    name = params.get("waypoint_task_executor_plugin", "wait_at_waypoint")
    extra: dict[str, Any] = {}
    sec = params.get(name) if isinstance(name, str) else None
    if isinstance(sec, dict):
        ptype = normalize_plugin(str(sec.get("plugin", "nav2_waypoint_follower::WaitAtWaypoint")))
        spath = path + (name,)
        if ptype not in WAYPOINT_EXECUTORS:
            r.add(WARNING, spath + ("plugin",), f"unknown task executor '{ptype}'{suggest(ptype, WAYPOINT_EXECUTORS)}")
        elif ptype != WAYPOINT_EXECUTORS[0]:
            r.add(NOTE, spath + ("plugin",), f"task executor '{ptype}' is read, not run by navlog")
        else:
            enabled, pause = sec.get("enabled", True), sec.get("waypoint_pause_duration", 0)
            if isinstance(enabled, bool):
                extra["pause_enabled"] = enabled
            if isinstance(pause, int) and not isinstance(pause, bool) and pause >= 0:
                extra["waypoint_pause_duration"] = pause
            else:
                r.add(WARNING, spath + ("waypoint_pause_duration",), f"expected milliseconds >= 0, got {pause!r}")
    return r.read(WaypointFollowerParams, params, path, sections=sections, extra=extra)


# ---------------------------------------------------------------- goals, results, the backend


@dataclass(frozen=True)
class NavGoal:
    """A named goal pose, in the global costmap's frame (``map``)."""

    name: str
    pose: Pose2D


@dataclass
class GoalResult:
    """How one goal ended: ``status`` "succeeded" | "failed" with Nav2's error code and message."""

    name: str
    goal: Pose2D
    status: str
    code: int
    message: str
    start_ns: int
    end_ns: int
    recoveries: int
    replans: int


@dataclass
class ActionResult:
    """A finished action (FollowPath, a behaviour) or a plan: ``ok``, else Nav2's error ``code``."""

    ok: bool
    code: int = 0
    message: str = ""
    path: np.ndarray | None = None  # the plan, for ``compute_path``


class NavigationBackend(Protocol):
    """What the navigator drives; the executor node implements it on the planner, controller and behaviours."""

    def robot_pose(self) -> Pose2D | None:
        """The robot in the global frame, None without a transform."""

    def compute_path(self, goals: Sequence[Pose2D], now_ns: int) -> ActionResult:
        """Plan from the robot through ``goals`` (one for NavigateToPose), at once."""

    def clear_costmap(self, which: str, now_ns: int) -> None:
        """Clear the ``local`` or ``global`` costmap entirely."""

    def follow_path(self, path: np.ndarray, now_ns: int) -> None:
        """Send FollowPath (a new goal, or a pre-emption with a new path while one runs)."""

    def follow_path_result(self) -> ActionResult | None:
        """None while FollowPath runs, then its result (once)."""

    def cancel_follow_path(self, now_ns: int) -> None: ...

    def start_behavior(self, kind: str, args: dict[str, float], now_ns: int) -> None:
        """Start ``spin`` (target_yaw), ``wait`` (duration) or ``backup`` (dist, speed)."""

    def behavior_result(self) -> ActionResult | None:
        """None while the behaviour runs, then its result (once)."""

    def cancel_behavior(self, now_ns: int) -> None: ...


Event = tuple[int, str, str, float]  # (ns, kind, detail, value)


def recoveries_of(tree: str) -> list[tuple[str, dict[str, float]]]:
    """The RoundRobin's children of the default tree: clear both costmaps, spin, wait, back up."""
    return [
        ("clear_costmaps", {}),
        ("spin", {"target_yaw": 1.57}),
        ("wait", {"duration": 5.0}),
        ("backup", {"dist": 0.30, "speed": 0.05 if tree == "humble" else 0.15}),
    ]


# ---------------------------------------------------------------- one navigation action


class NavigateAction:
    """One NavigateToPose (one goal) or NavigateThroughPoses (several) goal of the default tree.

    ``tick(now_ns)`` returns RUNNING, SUCCEEDED or FAILED (then ``code`` and ``message``);
    ``passed`` lists the indices of the through-poses goals RemovePassedGoals dropped, as they go.
    """

    NUMBER_OF_RETRIES = 6

    def __init__(
        self,
        backend: NavigationBackend,
        goals: Sequence[Pose2D],
        now_ns: int,
        events: list[Event],
        *,
        tree: str = "jazzy",
        through_poses: bool = False,
        remove_passed_radius: float = 0.7,
    ) -> None:
        if tree not in TREES:
            raise ValueError(f"tree must be one of {TREES}, got {tree!r}")
        self.backend = backend
        self.goals = list(goals)
        self.first = 0  # index of the first goal not yet passed (through poses)
        self.passed: list[int] = []
        self.events = events
        self.tree = tree
        self.through = through_poses
        self.radius = remove_passed_radius
        self.period_ns = int(round(1e9 / (0.333 if through_poses else 1.0)))
        self.recoveries_list = recoveries_of(tree)
        self.retries = 0  # outer RecoveryNode
        self.rr_index = 0  # RoundRobin, persists within the goal
        self.rr_failed = 0
        self.recoveries = 0
        self.plans = 0
        self.plan_code = 0
        self.follow_code = 0
        self.code = 0
        self.message = ""
        self.path: np.ndarray | None = None
        self.last_plan_ns: int | None = None  # RateController: None = first tick (idle)
        self.following = False
        self.sent_path: np.ndarray | None = None
        self.follow_retry = 0
        self.recovering: str | None = None  # the running recovery behaviour
        self.start_ns = now_ns

    @property
    def replans(self) -> int:
        return max(self.plans - 1, 0)

    def _event(self, now_ns: int, kind: str, detail: str = "", value: float = 0.0) -> None:
        self.events.append((now_ns, kind, detail, value))

    def _helps(self, code: int, codes: frozenset[int]) -> bool:
        return self.tree == "humble" or code in codes

    # -- the planner branch: RateController -> RecoveryNode(1) ComputePath | clear global
    def _plan(self, now_ns: int) -> bool:
        if self.through:
            self._remove_passed(now_ns)
        for attempt in range(2):
            self.plans += 1
            res = self.backend.compute_path(self.goals[self.first :], now_ns)
            if res.ok and res.path is not None:
                self.path, self.plan_code, self.last_plan_ns = res.path, 0, now_ns
                return True
            self.plan_code = res.code
            self._event(now_ns, "replan_failed", res.message, res.code)
            if attempt == 0 and self._helps(res.code, PLANNER_RECOVERY_CODES):
                self.backend.clear_costmap("global", now_ns)
                self._event(now_ns, "costmap_cleared", "global")
            else:
                break
        self.message = res.message
        return False

    def _remove_passed(self, now_ns: int) -> None:
        pose = self.backend.robot_pose()
        if pose is None:
            return
        while len(self.goals) - self.first > 1:
            g = self.goals[self.first]
            if math.hypot(g[0] - pose[0], g[1] - pose[1]) > self.radius:
                break
            self.passed.append(self.first)
            self._event(now_ns, "waypoint_passed", "", self.first)
            self.first += 1

    # -- the whole tree
    def tick(self, now_ns: int) -> str:
        if self.recovering is not None:
            res = self.backend.behavior_result()
            if res is None:
                return RUNNING
            self.recovering = None
            if not self._recovery_done(now_ns, res):
                return self._recover(now_ns)
        return self._navigate(now_ns)

    def _navigate(self, now_ns: int) -> str:
        if self.last_plan_ns is None or now_ns - self.last_plan_ns >= self.period_ns:
            if not self._plan(now_ns):
                return self._navigation_failed(now_ns)
        assert self.path is not None
        if not self.following:
            self.backend.follow_path(self.path, now_ns)
            self.following, self.sent_path = True, self.path
            return RUNNING
        if self.sent_path is not self.path:  # a new plan: FollowPath sends it as a new goal (pre-emption)
            self.backend.follow_path(self.path, now_ns)
            self.sent_path = self.path
        res = self.backend.follow_path_result()
        if res is None:
            return RUNNING
        self.following = False
        if res.ok:
            self.follow_code = 0
            return SUCCEEDED
        self.follow_code = res.code
        self.message = res.message
        self._event(now_ns, "follow_path_failed", res.message, res.code)
        if self.follow_retry < 1 and self._helps(res.code, CONTROLLER_RECOVERY_CODES):
            self.follow_retry = 1
            self.backend.clear_costmap("local", now_ns)
            self._event(now_ns, "costmap_cleared", "local")
            self.backend.follow_path(self.path, now_ns)
            self.following, self.sent_path = True, self.path
            return RUNNING
        return self._navigation_failed(now_ns)

    def _halt_navigation(self, now_ns: int) -> None:
        """PipelineSequence halted: FollowPath cancelled, the RateController and RecoveryNodes reset."""
        if self.following:
            self.backend.cancel_follow_path(now_ns)
        self.following, self.sent_path, self.follow_retry, self.last_plan_ns = False, None, 0, None

    def _navigation_failed(self, now_ns: int) -> str:
        self._halt_navigation(now_ns)
        if self.retries >= self.NUMBER_OF_RETRIES:
            return self._fail(now_ns)
        if not (
            self._helps(self.follow_code, CONTROLLER_RECOVERY_CODES)
            or self._helps(self.plan_code, PLANNER_RECOVERY_CODES)
        ):
            return self._fail(now_ns)
        self.rr_failed = 0
        return self._recover(now_ns)

    def _recover(self, now_ns: int) -> str:
        """Tick the RoundRobin: start its current child (clearing completes at once and navigation resumes)."""
        if self.rr_failed >= len(self.recoveries_list):
            self.rr_index = self.rr_failed = 0  # RoundRobin halted: every recovery failed
            return self._fail(now_ns)
        kind, args = self.recoveries_list[self.rr_index]
        self.recoveries += 1
        self._event(now_ns, "recovery_started", kind, self.retries + 1)
        if kind == "clear_costmaps":
            self.backend.clear_costmap("local", now_ns)
            self.backend.clear_costmap("global", now_ns)
            self._recovery_done(now_ns, ActionResult(True))
            return self._navigate(now_ns)
        self.backend.start_behavior(kind, args, now_ns)
        self.recovering = kind
        return RUNNING

    def _recovery_done(self, now_ns: int, res: ActionResult) -> bool:
        self.rr_index = (self.rr_index + 1) % len(self.recoveries_list)
        if res.ok:
            self.rr_failed = 0
            self.retries += 1
            return True
        self.rr_failed += 1
        self._event(now_ns, "recovery_failed", res.message, res.code)
        return False

    def _fail(self, now_ns: int) -> str:
        codes = [c for c in (self.plan_code, self.follow_code) if c]
        self.code = min(codes) if codes else 0
        return FAILED

    def halt(self, now_ns: int) -> None:
        """Stop everything running (a pre-empting goal)."""
        self._halt_navigation(now_ns)
        if self.recovering is not None:
            self.backend.cancel_behavior(now_ns)
            self.recovering = None


# ---------------------------------------------------------------- the navigator: goals in turn


class Navigator:
    """Goals in turn: ``waypoints`` (the waypoint follower, one NavigateToPose each) or
    ``through_poses`` (one NavigateThroughPoses for all); ``set_goal`` (a /goal_pose) pre-empts.

    ``tick(now_ns)`` every ``bt_loop_duration``; ``results`` fills as goals end, ``events`` grows,
    ``accepted`` lists the goals sent since the caller last emptied it (it publishes them).
    """

    def __init__(
        self,
        backend: NavigationBackend,
        *,
        goals: Sequence[NavGoal] = (),
        mode: str = "waypoints",
        tree: str = "jazzy",
        waypoint_follower: WaypointFollowerParams | None = None,
    ) -> None:
        if mode not in ("waypoints", "through_poses"):
            raise ValueError(f"mode must be 'waypoints' or 'through_poses', got {mode!r}")
        self.backend = backend
        self.queue = list(goals)
        self.mode = mode
        self.tree = tree
        self.wf = waypoint_follower or WaypointFollowerParams()
        self.results: list[GoalResult] = []
        self.events: list[Event] = []
        self.accepted: list[NavGoal] = []
        self.action: NavigateAction | None = None
        self.active: list[NavGoal] = []  # the goals of the running action
        self.ended = 0  # how many of them have a result (through poses: the passed ones)
        self.pause_until: int | None = None

    @property
    def idle(self) -> bool:
        """No goal running, waiting or paused for."""
        return self.action is None and not self.queue and self.pause_until is None

    def set_goal(self, goal: NavGoal, now_ns: int) -> None:
        """A new goal (a /goal_pose): it pre-empts the running one, which is reported failed."""
        if self.action is not None:
            self.action.halt(now_ns)
            self._end_active(self.action, now_ns, FAILED, 0, f"pre-empted by the goal '{goal.name}'")
            self.action = None
        self.queue = [goal]
        self.pause_until = None
        self._start(now_ns)

    def _start(self, now_ns: int) -> None:
        if not self.queue:
            return
        if self.mode == "through_poses":
            self.active, self.queue = self.queue, []
        else:
            self.active, self.queue = self.queue[:1], self.queue[1:]
        self.ended = 0
        for g in self.active:
            self.accepted.append(g)
            self.events.append((now_ns, "goal_accepted", g.name, 0.0))
        self.action = NavigateAction(
            self.backend,
            [g.pose for g in self.active],
            now_ns,
            self.events,
            tree=self.tree,
            through_poses=self.mode == "through_poses",
        )

    def tick(self, now_ns: int) -> None:
        """One BT loop: the running goal's tree, then the next goal when it ended."""
        if self.pause_until is not None:
            if now_ns < self.pause_until:
                return
            self.pause_until = None
        if self.action is None:
            self._start(now_ns)
        action = self.action
        if action is None:
            return
        status = action.tick(now_ns)
        while self.ended < len(action.passed):
            self._result(action, self.active[self.ended], now_ns, SUCCEEDED, 0, "passed (RemovePassedGoals)")
        if status == RUNNING:
            return
        self.action = None
        if status == SUCCEEDED:
            self._end_active(action, now_ns, SUCCEEDED, 0, "")
            pause = self.wf.waypoint_pause_duration if self.wf.pause_enabled else 0
            if pause > 0 and self.queue:
                self.pause_until = now_ns + pause * 1_000_000
                return
        else:
            self._end_active(action, now_ns, FAILED, action.code, action.message)
            if self.wf.stop_on_failure and self.queue:
                failed = self.results[-1].name
                for g in self.queue:
                    self._result(None, g, now_ns, FAILED, 0, f"not sent: stop_on_failure after '{failed}' failed")
                self.queue = []
                return
        self._start(now_ns)

    def _end_active(self, action: NavigateAction, now_ns: int, status: str, code: int, message: str) -> None:
        for g in self.active[self.ended :]:
            self._result(action, g, now_ns, status, code, message)
        self.active = []

    def _result(
        self, action: NavigateAction | None, g: NavGoal, now_ns: int, status: str, code: int, message: str
    ) -> None:
        self.ended += 1
        start = action.start_ns if action is not None else now_ns
        recoveries, replans = (action.recoveries, action.replans) if action is not None else (0, 0)
        self.results.append(GoalResult(g.name, g.pose, status, code, message, start, now_ns, recoveries, replans))
        kind = "goal_succeeded" if status == SUCCEEDED else "goal_failed"
        self.events.append((now_ns, kind, f"{g.name}: {message}" if message else g.name, float(code)))
