"""The navigation stack on the executor: a robot integrated in the test reaches two goals around a wall
with Regulated Pure Pursuit, and two runs give bit-identical outputs."""

from __future__ import annotations

import hashlib
import math

import numpy as np
import pytest

from navlog.errors import ConfigError
from navlog.replay import messages as m
from navlog.replay.nav2 import parse_nav2_text
from navlog.replay.nodes.collision_monitor import EVENTS_TOPIC
from navlog.replay.nodes.navigation import GoalResult, NavGoal, NavigationStack
from navlog.replay.occupancy_map import OccupancyMap
from navlog.replay.runtime.executor import Executor, Node

S = 1_000_000_000
MS = 1_000_000

NAV2 = """
global_costmap:
  global_costmap:
    ros__parameters:
      global_frame: map
      robot_base_frame: base_link
      update_frequency: 1.0
      publish_frequency: 0.5
      robot_radius: 0.2
      resolution: 0.05
      plugins: ["static_layer", "inflation_layer"]
      static_layer: {plugin: "nav2_costmap_2d::StaticLayer"}
      inflation_layer: {plugin: "nav2_costmap_2d::InflationLayer", inflation_radius: 0.55, cost_scaling_factor: 3.0}
local_costmap:
  local_costmap:
    ros__parameters:
      global_frame: odom
      robot_base_frame: base_link
      update_frequency: 5.0
      publish_frequency: 2.0
      rolling_window: true
      width: 3
      height: 3
      resolution: 0.05
      robot_radius: 0.2
      plugins: ["static_layer", "inflation_layer"]
      static_layer: {plugin: "nav2_costmap_2d::StaticLayer"}
      inflation_layer: {plugin: "nav2_costmap_2d::InflationLayer", inflation_radius: 0.55, cost_scaling_factor: 3.0}
planner_server:
  ros__parameters:
    planner_plugins: ["GridBased"]
    GridBased: {plugin: "nav2_navfn_planner::NavfnPlanner", tolerance: 0.5, allow_unknown: true}
controller_server:
  ros__parameters:
    controller_frequency: 20.0
    controller_plugins: ["FollowPath"]
    goal_checker: {plugin: "nav2_controller::SimpleGoalChecker"}
    progress_checker: {plugin: "nav2_controller::SimpleProgressChecker"}
    FollowPath:
      plugin: "nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController"
      desired_linear_vel: 0.5
waypoint_follower:
  ros__parameters:
    stop_on_failure: false
    wait_at_waypoint: {plugin: "nav2_waypoint_follower::WaitAtWaypoint", waypoint_pause_duration: 200}
"""


def room() -> OccupancyMap:
    """6 x 4 m, walls around, and a wall at x 1.5 from the south wall up to y 0.5."""
    res = 0.05
    data = np.zeros((80, 120), dtype=np.int8)  # origin (-1, -2)
    data[:, :2] = data[:, -2:] = data[:2, :] = data[-2:, :] = 100
    data[: int((0.5 + 2) / res), int(2.5 / res) : int(2.6 / res)] = 100
    return OccupancyMap(data=data, resolution=res, origin=(-1.0, -2.0, 0.0))


class UnicycleRobot(Node):
    """Integrates the latest /cmd_vel_nav at 50 Hz into odom -> base_link (/tf) and /odom; map -> odom is identity."""

    name = "robot"

    def __init__(self) -> None:
        super().__init__()
        self.pose = [0.0, 0.0, 0.0]
        self.cmd = (0.0, 0.0, 0.0)
        self.trace: list[tuple[float, float]] = []

    def setup(self) -> None:
        self.subscribe("/cmd_vel_nav", lambda msg, t: setattr(self, "cmd", m.twist_values(msg)))
        self.create_timer(20 * MS, self._step, 0)

    def _step(self, t: int) -> None:
        if t == 0:
            ident = m.transform_stamped(0, "map", "odom", (0, 0, 0), (0, 0, 0, 1))
            self.publish("/tf_static", m.TF_MESSAGE, m.tf_message([ident]))
        else:
            vx, _, wz = self.cmd
            self.pose[0] += vx * 0.02 * math.cos(self.pose[2])
            self.pose[1] += vx * 0.02 * math.sin(self.pose[2])
            self.pose[2] += wz * 0.02
        x, y, yaw = self.pose
        q = m.quat_from_yaw(yaw)
        self.trace.append((x, y))
        self.publish("/tf", m.TF_MESSAGE, m.tf_message([m.transform_stamped(t, "odom", "base_link", (x, y, 0), q)]))
        self.publish(
            "/odom",
            m.ODOMETRY,
            m.odometry(t, "odom", "base_link", (x, y, 0), q, self.cmd[:1] + (0, 0), (0, 0, self.cmd[2])),
        )


class Digest:
    """sha256 of every message the stack publishes, per topic, in delivery order."""

    TOPICS = (
        "/plan",
        "/cmd_vel_nav",
        "/local_plan",
        "/global_costmap/costmap",
        "/local_costmap/costmap",
        "/local_costmap/published_footprint",
        "/goal_pose",
        EVENTS_TOPIC,
    )

    def __init__(self) -> None:
        self.h = {t: hashlib.sha256() for t in self.TOPICS}
        self.counts = dict.fromkeys(self.TOPICS, 0)
        self.events: list[tuple[int, str, str, float]] = []

    def write(self, env) -> None:
        if env.topic in self.h:
            self.h[env.topic].update(
                env.time_ns.to_bytes(8, "little")
                + (env.msg if isinstance(env.msg, bytes) else m.serialize(env.msg, env.typename))
            )
            self.counts[env.topic] += 1
            if env.topic == EVENTS_TOPIC:
                self.events.append((env.time_ns, env.msg.kind, env.msg.detail, env.msg.value))


GOALS = [NavGoal("east", (3.5, -1.0, -1.57)), NavGoal("home", (0.0, 0.0, 0.0))]


def run_stack(goals=GOALS, until_s=90, text=NAV2):
    nav2 = parse_nav2_text(text).require_valid()
    stack = NavigationStack(nav2, goals=goals, static_map=room())
    ex = Executor(start_ns=0)
    robot = UnicycleRobot()
    ex.add_node(robot, source=True)
    for node in stack.nodes:
        ex.add_node(node)
    digest = Digest()
    ex.add_sink(digest)
    ex.run(until_ns=until_s * S, on_step=lambda t: ex.stop() if stack.done else None)
    return stack, robot, digest


@pytest.fixture(scope="module")
def runs():
    return run_stack(), run_stack()


def test_two_goals_reached_around_the_wall(runs):
    (stack, robot, digest), _ = runs
    assert stack.done
    res = stack.results
    assert [(r.name, r.status, r.code, r.recoveries) for r in res] == [
        ("east", "succeeded", 0, 0),
        ("home", "succeeded", 0, 0),
    ]
    assert all(isinstance(r, GoalResult) for r in res)
    # the second goal starts after the 200 ms waypoint pause
    assert res[1].start_ns - res[0].end_ns == 200 * MS
    trace = np.array(robot.trace)
    assert trace[:, 1].max() > 0.5  # went round the wall's end at y 0.5
    # never through the wall (x 1.5 .. 1.6 below y 0.5)
    assert not ((trace[:, 0] > 1.45) & (trace[:, 0] < 1.65) & (trace[:, 1] < 0.55)).any()
    end_east = trace[int(res[0].end_ns // (20 * MS))]
    assert math.hypot(end_east[0] - 3.5, end_east[1] + 1.0) <= 0.25
    assert math.hypot(*robot.pose[:2]) <= 0.25
    assert res[0].replans >= 5  # replanned at 1 Hz on sim time


def test_outputs_and_events(runs):
    (stack, _, digest), _ = runs
    c = digest.counts
    assert c["/goal_pose"] == 2 and c["/plan"] >= 10 and c["/cmd_vel_nav"] > 200 and c["/local_plan"] > 200
    kinds = [e[1] for e in digest.events]
    assert kinds == ["goal_accepted", "goal_succeeded", "goal_accepted", "goal_succeeded"]
    # costmaps at their publish_frequency: global 0.5 Hz, local 2 Hz (updated at 1 and 5 Hz)
    end = stack.results[-1].end_ns / S
    assert abs(c["/global_costmap/costmap"] - end / 3) <= 2  # > 2 s apart at 1 Hz updates: every 3 s
    assert abs(c["/local_costmap/costmap"] - end / 0.6) <= 3  # > 0.5 s apart at 5 Hz updates: every 0.6 s
    assert c["/local_costmap/published_footprint"] >= 4 * end


def test_two_runs_are_bit_identical(runs):
    (_, _, a), (_, _, b) = runs
    assert {t: h.hexdigest() for t, h in a.h.items()} == {t: h.hexdigest() for t, h in b.h.items()}


def test_goal_in_the_wall_fails_and_the_next_goal_is_still_reached():
    goals = [NavGoal("inside", (1.55, -1.0, 0.0)), NavGoal("near", (0.8, 0.0, 0.0))]
    # the nearest free cell is 0.28 m away: with tolerance 0.25 NavFn finds no path (208, a planner recovery
    # may help): six recoveries, then the goal fails; the next goal is still sent (stop_on_failure false)
    stack, _, digest = run_stack(goals, until_s=60, text=NAV2.replace("tolerance: 0.5", "tolerance: 0.25"))
    first, second = stack.results
    assert (first.status, first.code, first.recoveries) == ("failed", 208, 6)
    assert second.status == "succeeded" and second.recoveries == 0
    started = [e[2] for e in digest.events if e[1] == "recovery_started"]
    assert started == ["clear_costmaps", "spin", "wait", "backup", "clear_costmaps", "spin"]
    # each failed plan clears the global costmap and plans once more (the planner's RecoveryNode(1))
    assert [e[1] for e in digest.events[:4]] == ["goal_accepted", "replan_failed", "costmap_cleared", "replan_failed"]
    # with tolerance 0 NavFn refuses a lethal goal as GOAL_OCCUPIED (206): no recovery helps
    stack, _, digest = run_stack(goals[:1], until_s=5, text=NAV2.replace("tolerance: 0.5", "tolerance: 0.0"))
    assert [(r.status, r.code, r.recoveries) for r in stack.results] == [("failed", 206, 0)]


def test_goal_outside_the_map_fails_at_once():
    stack, _, _ = run_stack([NavGoal("far", (20.0, 0.0, 0.0))], until_s=5)
    (r,) = stack.results
    assert (r.status, r.code, r.recoveries) == ("failed", 204, 0)
    assert "outside the costmap" in r.message


def test_unknown_controller_id_is_a_config_error():
    nav2 = parse_nav2_text(NAV2.replace('["FollowPath"]', '["Follow"]').replace("    FollowPath:", "    Follow:"))
    with pytest.raises(ConfigError, match="'FollowPath' is not in controller_plugins"):
        NavigationStack(nav2.require_valid(), goals=GOALS, static_map=room())


def test_a_log_that_starts_late_is_ticked_from_its_start() -> None:
    # a real bag's log time is the wall clock (1.7e9 s): the navigator's first tick is there, not at 0
    from navlog.replay.runtime.executor import Envelope

    start = 1_701_316_731_782_245_423
    nav2 = parse_nav2_text(NAV2).require_valid()
    stack = NavigationStack(nav2, goals=GOALS, static_map=room())
    ex = Executor(start_ns=start)
    ex.add_source(
        Envelope("/clock", m.CLOCK, start + k * 100_000_000, m.clock(start + k * 100_000_000)) for k in range(11)
    )
    for node in stack.nodes:
        ex.add_node(node)
    ex.run(on_step=lambda t: ex.stop() if ex.stats.timer_fires > 1000 else None)  # a bound, were ticks at 0
    assert start + S <= ex.now < start + S + 20_000_000
    assert ex.stats.timer_fires < 200  # 1 s of 10 ms ticks and the costmaps' timers, not 1.7e11 ticks
