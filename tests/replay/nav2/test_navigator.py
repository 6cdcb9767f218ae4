"""The navigator's default-tree behaviour driven by a scripted backend: exact action sequences."""

from __future__ import annotations

from collections import deque

import numpy as np
import pytest

from navlog.replay.nav2 import parse_nav2_text
from navlog.replay.nav2.navigator import (
    FAILED,
    RUNNING,
    SUCCEEDED,
    ActionResult,
    NavGoal,
    NavigateAction,
    Navigator,
    WaypointFollowerParams,
)

MS = 1_000_000
S = 1_000_000_000
TICK = 10 * MS


class FakeBackend:
    """Plans succeed unless scripted; FollowPath ends ``follow_ticks`` polls after it is sent, with the next
    scripted outcome (default: success); behaviours take ``behavior_ticks`` polls and succeed unless scripted."""

    def __init__(self, follow=(), plans=(), behaviors=(), follow_ticks=3, behavior_ticks=2, pose=(0.0, 0.0, 0.0)):
        self.follow = deque(follow)
        self.plans = deque(plans)
        self.behaviors = deque(behaviors)
        self.follow_ticks, self.behavior_ticks = follow_ticks, behavior_ticks
        self.log: list[str] = []
        self.pose = pose
        self._follow_left: int | None = None
        self._behavior_left: int | None = None

    def robot_pose(self):
        return self.pose

    def compute_path(self, goals, now_ns):
        self.log.append(f"plan@{now_ns // MS}")
        res = self.plans.popleft() if self.plans else ActionResult(True)
        if res.ok:
            return ActionResult(True, path=np.array([[0.0, 0.0, 0.0], [*goals[-1]]]))
        return res

    def clear_costmap(self, which, now_ns):
        self.log.append(f"clear {which}")

    def follow_path(self, path, now_ns):
        self.log.append("follow" if self._follow_left is None else "preempt")
        if self._follow_left is None:
            self._follow_left = self.follow_ticks

    def follow_path_result(self):
        self._follow_left -= 1
        if self._follow_left > 0:
            return None
        self._follow_left = None
        return self.follow.popleft() if self.follow else ActionResult(True)

    def cancel_follow_path(self, now_ns):
        self.log.append("cancel follow")
        self._follow_left = None

    def start_behavior(self, kind, args, now_ns):
        self.log.append(f"{kind} {' '.join(f'{k}={v}' for k, v in args.items())}")
        self._behavior_left = self.behavior_ticks

    def behavior_result(self):
        self._behavior_left -= 1
        if self._behavior_left > 0:
            return None
        return self.behaviors.popleft() if self.behaviors else ActionResult(True)

    def cancel_behavior(self, now_ns):
        self.log.append("cancel behavior")


def fail(code, msg="x"):
    return ActionResult(False, code, msg)


def run(action, t=0, limit=100_000):
    while True:
        status = action.tick(t)
        if status != RUNNING:
            return status, t
        t += TICK
        assert t < limit * TICK


def actions(log):
    return [e for e in log if not e.startswith(("plan", "preempt"))]


def test_success_without_recovery_replans_at_1hz_on_sim_time():
    be = FakeBackend(follow_ticks=350)  # FollowPath runs 3.5 s
    nav = NavigateAction(be, [(2.0, 0.0, 0.0)], 0, [])
    status, t = run(nav)
    assert status == SUCCEEDED and t == 350 * TICK  # sent at 0, polled from 10 ms
    assert [e for e in be.log if e.startswith("plan")] == ["plan@0", "plan@1000", "plan@2000", "plan@3000"]
    assert be.log.count("preempt") == 3 and nav.replans == 3 and nav.recoveries == 0


def test_controller_failing_with_105_runs_the_round_robin_in_order():
    be = FakeBackend(follow=[fail(105)] * 8)
    nav = NavigateAction(be, [(2.0, 0.0, 0.0)], 0, [])
    status, _ = run(nav)
    assert status == SUCCEEDED
    # each outer failure = FollowPath failed, local costmap cleared (context), FollowPath failed again
    context = ["follow", "clear local", "follow"]
    assert actions(be.log) == [
        *context,
        "clear local",
        "clear global",  # 1: ClearingActions
        *context,
        "spin target_yaw=1.57",
        *context,
        "wait duration=5.0",
        *context,
        "backup dist=0.3 speed=0.15",
        "follow",
    ]
    assert nav.recoveries == 4 and nav.retries == 4 and nav.rr_index == 0


def test_code_103_aborts_without_recovery():
    be = FakeBackend(follow=[fail(103, "plan off the costmap")])
    nav = NavigateAction(be, [(2.0, 0.0, 0.0)], 0, [])
    status, _ = run(nav)
    assert status == FAILED and nav.code == 103 and nav.recoveries == 0
    assert actions(be.log) == ["follow"]


def test_seventh_failure_fails_the_goal():
    be = FakeBackend(follow=[fail(106)] * 100)
    events = []
    nav = NavigateAction(be, [(2.0, 0.0, 0.0)], 0, events)
    status, _ = run(nav)
    assert status == FAILED and nav.code == 106
    started = [e[2] for e in events if e[1] == "recovery_started"]
    assert started == ["clear_costmaps", "spin", "wait", "backup", "clear_costmaps", "spin"]
    assert be.log.count("follow") == 14  # 7 outer attempts x (FollowPath + its one context retry)


def test_planner_failure_clears_global_then_recovers_and_reports_the_lowest_code():
    # 208 NO_VALID_PATH: the planner RecoveryNode clears the global costmap and replans once
    be = FakeBackend(plans=[fail(208), fail(208)] * 7)
    nav = NavigateAction(be, [(2.0, 0.0, 0.0)], 0, [])
    status, _ = run(nav)
    assert status == FAILED and nav.code == 208
    assert actions(be.log)[:4] == ["clear global", "clear local", "clear global", "clear global"]
    assert nav.recoveries == 6
    # 204 GOAL_OUTSIDE_MAP: no recovery helps
    be = FakeBackend(plans=[fail(204, "goal outside the map")])
    nav = NavigateAction(be, [(9.0, 0.0, 0.0)], 0, [])
    assert run(nav)[0] == FAILED and nav.code == 204 and nav.message == "goal outside the map"
    assert actions(be.log) == []


def test_failed_recovery_passes_to_the_next_and_all_failing_fails():
    be = FakeBackend(follow=[fail(105)] * 4, behaviors=[fail(703, "Collision Ahead")])
    nav = NavigateAction(be, [(2.0, 0.0, 0.0)], 0, [])
    assert run(nav)[0] == SUCCEEDED
    # clear; spin fails (703) -> wait starts in the same tick
    assert [e for e in actions(be.log) if not e.startswith(("follow", "clear local"))] == [
        "clear global",
        "spin target_yaw=1.57",
        "wait duration=5.0",
    ]
    be = FakeBackend(follow=[fail(105)] * 4, behaviors=[fail(703), fail(0), fail(714)])
    # clear succeeds, then spin / wait / backup fail, then clear is tried again and succeeds
    nav = NavigateAction(be, [(2.0, 0.0, 0.0)], 0, [])
    assert run(nav)[0] == SUCCEEDED and nav.recoveries == 5 and nav.retries == 2


def test_humble_tree_recovers_any_code_and_backs_up_slower():
    be = FakeBackend(follow=[fail(103)] * 8)
    nav = NavigateAction(be, [(2.0, 0.0, 0.0)], 0, [], tree="humble")
    assert run(nav)[0] == SUCCEEDED and nav.recoveries == 4
    assert "backup dist=0.3 speed=0.05" in be.log


def test_waypoint_follower_results_pause_and_stop_on_failure():
    goals = [NavGoal("a", (1.0, 0.0, 0.0)), NavGoal("b", (2.0, 0.0, 0.0)), NavGoal("c", (3.0, 0.0, 0.0))]
    be = FakeBackend()
    nav = Navigator(be, goals=goals, waypoint_follower=WaypointFollowerParams(waypoint_pause_duration=200))
    t = 0
    while not nav.idle:
        nav.tick(t)
        t += TICK
    assert [(r.name, r.status, r.start_ns // MS, r.end_ns // MS) for r in nav.results] == [
        ("a", SUCCEEDED, 0, 30),  # FollowPath sent at 0, its result polled at 30 ms
        ("b", SUCCEEDED, 230, 260),  # 200 ms pause after a reached waypoint
        ("c", SUCCEEDED, 460, 490),
    ]
    be = FakeBackend(follow=[ActionResult(True), fail(103, "bad path")])
    nav = Navigator(be, goals=goals, waypoint_follower=WaypointFollowerParams(stop_on_failure=True))
    t = 0
    while not nav.idle:
        nav.tick(t)
        t += TICK
    assert [(r.name, r.status, r.code) for r in nav.results] == [
        ("a", SUCCEEDED, 0),
        ("b", FAILED, 103),
        ("c", FAILED, 0),
    ]
    assert nav.results[2].message == "not sent: stop_on_failure after 'b' failed"
    assert [e[1] for e in nav.events].count("goal_accepted") == 2


def test_round_robin_restarts_for_every_goal():
    goals = [NavGoal("a", (1.0, 0.0, 0.0)), NavGoal("b", (2.0, 0.0, 0.0))]
    be = FakeBackend(follow=[fail(105)] * 4 + [ActionResult(True)] + [fail(105)] * 2)
    nav = Navigator(be, goals=goals, waypoint_follower=WaypointFollowerParams(stop_on_failure=False))
    t = 0
    while not nav.idle:
        nav.tick(t)
        t += TICK
    started = [(e[2]) for e in nav.events if e[1] == "recovery_started"]
    assert started == ["clear_costmaps", "spin", "clear_costmaps"]  # goal b starts at "clear" again
    assert [(r.name, r.recoveries) for r in nav.results] == [("a", 2), ("b", 1)]


def test_through_poses_removes_passed_goals():
    goals = [NavGoal("p1", (0.5, 0.0, 0.0)), NavGoal("p2", (3.0, 0.0, 0.0)), NavGoal("p3", (6.0, 0.0, 0.0))]
    be = FakeBackend(follow_ticks=700)  # 7 s of FollowPath
    nav = Navigator(be, goals=goals, mode="through_poses")
    t = 0
    while not nav.idle:
        be.pose = (t / S, 0.0, 0.0)  # 1 m/s along x
        nav.tick(t)
        t += TICK
    # p1 is within 0.7 m at once; replans 1 / 0.333 s after the last plan, on the first 10 ms tick after:
    # at 3.01 s the robot is at x 3.01, within 0.7 m of p2
    assert [e for e in be.log if e.startswith("plan")] == ["plan@0", "plan@3010", "plan@6020"]
    assert [(r.name, r.status, r.end_ns // MS) for r in nav.results] == [
        ("p1", SUCCEEDED, 0),
        ("p2", SUCCEEDED, 3010),
        ("p3", SUCCEEDED, 7000),
    ]


def test_set_goal_preempts():
    be = FakeBackend(follow_ticks=1000)
    nav = Navigator(be)
    nav.set_goal(NavGoal("g1", (1.0, 0.0, 0.0)), 0)
    nav.tick(0)
    nav.set_goal(NavGoal("g2", (2.0, 0.0, 0.0)), 50 * MS)
    assert "cancel follow" in be.log
    assert nav.results[0].name == "g1" and nav.results[0].status == FAILED
    assert nav.results[0].message == "pre-empted by the goal 'g2'"
    assert [g.name for g in nav.accepted] == ["g1", "g2"]


def test_params_are_read_from_the_bringup_blocks(params_dir):
    from navlog.replay.nav2 import load_nav2_params

    p = load_nav2_params(params_dir / "nav2_bringup_jazzy_nav2_params.yaml")
    assert p.errors == []
    assert p.bt_navigator.bt_loop_duration == 10 and p.bt_navigator.tree == "jazzy"
    assert p.waypoint_follower.stop_on_failure is False and p.waypoint_follower.waypoint_pause_duration == 200
    assert p.behavior_server.cycle_frequency == 10.0 and p.behavior_server.behaviors["spin"] == "nav2_behaviors::Spin"
    h = load_nav2_params(params_dir / "turtlebot4_humble_nav2.yaml")
    assert h.errors == [] and h.bt_navigator.tree == "humble"
    assert h.behavior_server.local_frame == "odom" and h.behavior_server.behaviors["backup"] == "nav2_behaviors::BackUp"


def test_bad_behavior_plugin_is_named():
    text = """
behavior_server:
  ros__parameters:
    behavior_plugins: ["spin"]
    spin:
      plugin: "nav2_behaviors::Spinn"
"""
    p = parse_nav2_text(text)
    msgs = {e.path: e.message for e in p.errors}
    assert "did you mean 'nav2_behaviors::Spin'" in msgs["behavior_server.ros__parameters.spin.plugin"]


def test_unknown_mode_is_an_error():
    with pytest.raises(ValueError, match="through_poses"):
        Navigator(FakeBackend(), mode="through")
