"""The planner pipeline driven by hand-built messages on the executor."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from navlog.errors import ConfigError
from navlog.replay import messages as m
from navlog.replay.io.map_server import save_map
from navlog.replay.nav2.costmap import Costmap2D, CostmapParams, StaticLayerParams
from navlog.replay.nav2.planners import PlanningError
from navlog.replay.nodes.costmap import costmap_msg, footprint_msg
from navlog.replay.occupancy_map import OccupancyMap
from navlog.replay.pipelines.planner import (
    Params,
    build,
    load_goals,
    plan_on_map,
    write_plan_mcap,
    write_plan_png,
)
from navlog.replay.runtime.executor import Envelope, Executor
from navlog.replay.session import pipeline_params

DATA = Path(__file__).resolve().parents[1] / "nav2" / "data"
JAZZY_ARTICLE = Path(__file__).resolve().parents[3] / "config" / "nav2" / "simple_robot_jazzy.yaml"  # seed 001's file
NAV2 = str(JAZZY_ARTICLE)


def room_map() -> OccupancyMap:
    """A 6 x 6 m room at 0.05 m centred on the origin, walls all round and a block at (0.5, 0)."""
    data = np.zeros((120, 120), dtype=np.int8)
    data[:2, :] = data[-2:, :] = data[:, :2] = data[:, -2:] = 100
    data[50:70, 65:75] = 100  # x 0.25 .. 0.75, y -0.5 .. 0.5
    return OccupancyMap(data, 0.05, (-3.0, -3.0, 0.0))


def goal_msg(t, x, y, frame="map"):
    return m.msg_class(m.POSE_STAMPED)(header=m.header(t, frame), pose=m.pose((x, y, 0.0), m.quat_from_yaw(0.0)))


def tf_msg(t, x, y):
    prefix = "simple_robot/"
    return m.tf_message([m.transform_stamped(t, "map", prefix + "base_link", (x, y, 0.0), m.quat_from_yaw(0.0))])


def run(params: Params, envs: list[Envelope], until_ns: int = 3_000_000_000):
    pipe = build(params, {e.topic for e in envs})
    ex = Executor()
    out: list[Envelope] = []

    class Sink:
        def write(self, env):
            if env.topic in pipe.outputs:  # a path comes as its CDR bytes when no node reads it
                msg = m.deserialize(env.msg, env.typename) if isinstance(env.msg, bytes) else env.msg
                out.append(Envelope(env.topic, env.typename, env.time_ns, msg))

    ex.add_sink(Sink())
    for node in pipe.nodes:
        ex.add_node(node)
    ex.add_source(envs)
    ex.run(until_ns)
    ex.finish()
    return pipe, out


def _inputs(goal=(1.5, 0.0), frame="map"):
    grid = room_map().to_msg(0)
    envs = [Envelope("/map", m.OCCUPANCY_GRID, 0, grid)]
    for k in range(31):
        t = k * 100_000_000
        envs.append(Envelope("/tf", m.TF_MESSAGE, t, tf_msg(t, -1.5, 0.0)))
        if k == 5:
            envs.append(Envelope("/goal_pose", m.POSE_STAMPED, t, goal_msg(t, *goal, frame=frame)))
    envs.sort(key=lambda e: e.time_ns)
    return envs


def test_plans_around_the_block_from_goal_pose(tmp_path):
    params = Params(nav2_params=NAV2)
    pipe, out = run(params, _inputs())
    plans = [e for e in out if e.topic == "/plan"]
    costmaps = [e for e in out if e.topic == "/global_costmap/costmap"]
    assert costmaps and costmaps[0].msg.info.width == 120
    assert plans, pipe.skipped()
    xy = np.array([[p.pose.position.x, p.pose.position.y] for p in plans[0].msg.poses])
    assert xy[0] == pytest.approx((-1.5, 0.0), abs=0.06) and xy[-1] == pytest.approx((1.5, 0.0))
    # the block plus inflation (0.7 m, robot radius 0.22) is avoided: the path leaves y = 0
    assert np.abs(xy[:, 1]).max() > 0.6
    written = pipe.write_artifacts(tmp_path)
    doc = json.loads(written["plans"].read_text())
    assert doc["plans"][0]["length_m"] > 3.0 and doc["failures"] == []


def test_replay_is_deterministic():
    a = [(e.topic, e.time_ns, m.serialize(e.msg, e.typename)) for e in run(Params(nav2_params=NAV2), _inputs())[1]]
    b = [(e.topic, e.time_ns, m.serialize(e.msg, e.typename)) for e in run(Params(nav2_params=NAV2), _inputs())[1]]
    assert a == b and len(a) > 5


def _late_tf_inputs(tf_from_ns: int, child: str = "simple_robot/base_link"):
    """The map and a goal at time 0; the robot's TF (at (-1.5, 0)) only from ``tf_from_ns`` on."""
    envs = [
        Envelope("/map", m.OCCUPANCY_GRID, 0, room_map().to_msg(0)),
        Envelope("/goal_pose", m.POSE_STAMPED, 0, goal_msg(0, 1.5, 0.0)),
    ]
    for k in range(tf_from_ns // 100_000_000, 31):
        t = k * 100_000_000
        tf = m.tf_message([m.transform_stamped(t, "map", child, (-1.5, 0.0, 0.0), m.quat_from_yaw(0.0))])
        envs.append(Envelope("/tf", m.TF_MESSAGE, t, tf))
    return sorted(envs, key=lambda e: e.time_ns)


def plan_starts(out):
    return [
        (e.time_ns, e.msg.poses[0].pose.position.x, e.msg.poses[0].pose.position.y) for e in out if e.topic == "/plan"
    ]


def test_planning_waits_for_the_robot_tf_when_the_log_has_tf():
    # the goal comes first and the robot's TF 1.2 s later: every plan starts at the robot, none at (0, 0)
    pipe, out = run(Params(nav2_params=NAV2), _late_tf_inputs(1_200_000_000))
    starts = plan_starts(out)
    assert starts and starts[0][0] >= 1_200_000_000
    assert all(x == pytest.approx(-1.5, abs=0.06) and y == pytest.approx(0.0, abs=0.06) for _, x, y in starts)
    assert not any("without a robot pose" in k for k in pipe.skipped())


def test_legs_without_a_robot_pose_are_said_and_counted(tmp_path):
    # /tf is in the log but never names the robot frame: the leg is planned at the end, from `start`
    pipe, out = run(Params(nav2_params=NAV2, start=(-1.0, 1.0, 0.0)), _late_tf_inputs(0, child="other_frame"))
    starts = plan_starts(out)
    assert len(starts) == 1 and starts[0][1:] == pytest.approx((-1.0, 1.0), abs=0.06)
    key = "legs planned without a robot pose (map <- simple_robot/base_link)"
    assert pipe.skipped()[key] == 1
    doc = json.loads(pipe.write_artifacts(tmp_path)["plans"].read_text())
    assert "no robot pose (map <- simple_robot/base_link): leg planned from (-1.00, 1.00)" in doc["plans"][0]["notes"]
    # a log without any /tf plans at once, also noted
    pipe, out = run(Params(nav2_params=NAV2), [e for e in _late_tf_inputs(0) if e.topic != "/tf"])
    assert plan_starts(out)[0][0] == 0 and pipe.skipped()[key] == 1


def test_goal_frame_without_transform_is_counted():
    pipe, out = run(Params(nav2_params=NAV2), _inputs(frame="odom"))
    assert not [e for e in out if e.topic == "/plan"]
    assert any("no transform" in k for k in pipe.skipped())


def test_goal_in_obstacle_reports_failure():
    params = Params(nav2_params=NAV2, planner_server={"GridBased": {"tolerance": 0.0}})
    pipe, out = run(params, _inputs(goal=(0.5, 0.0)))
    events = [e.msg for e in out if e.topic == "/navlog/events"]
    assert events and events[0].kind == "plan_failed" and "goal occupied" in events[0].detail
    assert pipe.skipped()["planning failed"] >= 1


def test_goals_yaml_and_override_short_path():
    goals, frame = load_goals("indoor_room_waypoints")
    assert frame == "map" and goals[0] == (-1.0, -1.0, 0.0) and goals[2] == (1.2, 0.8, 3.051) and goals[-1] == (0, 0, 0)
    params = Params(
        nav2_params=NAV2,
        goals="indoor_room_waypoints",
        planner="smac2d",
        global_costmap={"inflation_layer": {"inflation_radius": 0.3}},
    )
    envs = [e for e in _inputs() if e.topic != "/goal_pose"]
    pipe, out = run(params, envs)
    assert [e for e in out if e.topic == "/plan"]
    with pytest.raises(ConfigError, match="inflation_radios"):
        build(Params(nav2_params=NAV2, global_costmap={"inflation_layer": {"inflation_radios": 0.3}}), set())
    with pytest.raises(ConfigError, match="ObstcaleLayer"):
        build(Params(nav2_params=str(DATA / "kibot_nav2_fragments.yaml")), set())


def test_overrides_without_a_file_apply_to_nav2_defaults():
    from navlog.replay.nav2.costmap import default_costmap_params
    from navlog.replay.nav2.planners import NavfnParams, Smac2DParams
    from navlog.replay.pipelines.planner import planning_nav2_params

    same = planning_nav2_params(None, ["tolerance=0.5"])  # Nav2's default value: nothing changes
    assert same.planner_server.planners["GridBased"] == NavfnParams()
    assert same.global_costmap == default_costmap_params()
    changed = planning_nav2_params(None, ["tolerance=0.0", "global_costmap.inflation_layer.inflation_radius=0.3"])
    assert changed.planner_server.planners["GridBased"].tolerance == 0.0
    assert changed.global_costmap.layers["inflation_layer"].inflation_radius == 0.3
    smac = planning_nav2_params(None, ["tolerance=0.2"], planner="smac2d").planner_server.planners["GridBased"]
    assert isinstance(smac, Smac2DParams) and smac.tolerance == 0.2


def test_plan_on_map_as_a_library_call(tmp_path):
    room = room_map()
    result = plan_on_map(room, (-1.5, 0.0, 0.0), (1.5, 0.0, 0.0), nav2_params=NAV2)
    cm, plan = result.costmap, result.plan
    assert (cm.size_x, cm.size_y) == (120, 120) and cm.params.global_frame == "map"
    assert plan.planner == "navfn" and plan.poses[-1, :2] == pytest.approx((1.5, 0.0))
    assert np.abs(plan.poses[:, 1]).max() > 0.6  # around the inflated block
    # the same from a map_server file, and the same plan the pipeline would make with smac2d
    yaml_path, _ = save_map(room, tmp_path / "room.yaml")
    again = plan_on_map(yaml_path, (-1.5, 0.0, 0.0), (1.5, 0.0, 0.0), nav2_params=NAV2)
    assert again.plan.poses.tobytes() == plan.poses.tobytes() and again.plan.cost == plan.cost
    smac = plan_on_map(room, (-1.5, 0.0, 0.0), (1.5, 0.0, 0.0), nav2_params=NAV2, planner="smac2d")
    assert smac.plan.planner == "smac2d"
    write_plan_mcap(tmp_path / "plan.mcap", result)
    write_plan_png(tmp_path / "plan.png", result)
    assert (tmp_path / "plan.mcap").stat().st_size > 0 and (tmp_path / "plan.png").stat().st_size > 0
    # errors name the map file when it was given one
    with pytest.raises(PlanningError, match=r"room.yaml: goal \(9.00, 0.00\) is outside the costmap"):
        plan_on_map(yaml_path, (-1.5, 0.0, 0.0), (9.0, 0.0, 0.0), nav2_params=NAV2)
    with pytest.raises(PlanningError, match="goal occupied"):
        plan_on_map(room, (-1.5, 0.0, 0.0), (0.5, 0.0, 0.0), nav2_params=NAV2, overrides=["GridBased.tolerance=0.0"])
    unknown = OccupancyMap(np.full((40, 40), -1, dtype=np.int8), 0.05)
    with pytest.raises(ConfigError, match="^the map is unknown everywhere"):
        plan_on_map(unknown, (0.5, 0.5, 0.0), (1.5, 0.5, 0.0))


def test_costmap_message():
    data = np.zeros((3, 3), dtype=np.int8)
    data[1, 1] = 100
    cm = Costmap2D(CostmapParams(plugins=("static_layer",), layers={"static_layer": StaticLayerParams()}))
    cm.set_static_map(OccupancyMap(data, 0.5, (-1.0, 2.0, 0.0)))
    cm.update(0.0, 0.0)
    msg = costmap_msg(cm, 7)
    assert msg.header.frame_id == "map" and msg.info.width == 3
    assert msg.data.tolist() == [0, 0, 0, 0, 100, 0, 0, 0, 0]
    assert msg.info.origin.position.x == -1.0


def test_published_footprint_message():
    cm = Costmap2D(CostmapParams(plugins=(), width=4, height=4, resolution=0.1, robot_radius=0.3))
    msg = footprint_msg(cm, 0, 2.0, 2.0, 0.0)
    assert len(msg.polygon.points) == 16 and msg.polygon.points[0].x == pytest.approx(2.31)


@pytest.mark.parametrize(
    "override, message",
    [
        ("goal_tolerance=-1", "goal_tolerance: -1.0 is out of range: must be >= 0.0"),
        ("goal_tolerance=.nan", "goal_tolerance: nan is out of range"),
        ("goal_tolerance=20", "goal_tolerance: 20.0 is out of range: must be <= 10.0"),
        ("start=[.nan,0,0]", r"start: \[nan, 0.0, 0.0\]: x, y and yaw must be finite numbers"),
        ("start=[1,.inf,0]", r"start: \[1.0, inf, 0.0\]: x, y and yaw must be finite numbers"),
    ],
)
def test_params_refuse_a_goal_tolerance_or_start_no_plan_can_use(override, message):
    """A negative or NaN tolerance was accepted and no goal was ever reached; a NaN start reached the costmap."""
    with pytest.raises(ConfigError, match=message):
        pipeline_params("planner", overrides=[override])
