"""DWB (dwb_core::DWBLocalPlanner): parameters, velocity samples, trajectories, critics, plan pruning, closed loop."""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from scipy.ndimage import distance_transform_edt

import navlog.replay.nav2.controllers.dwb.trajectories as trajectories_module
from navlog.errors import ConfigError
from navlog.replay.nav2.controllers.base import ControlContext, ControllerSetup, InvalidPath, NoValidControl
from navlog.replay.nav2.controllers.controller_server import RUNNING, SUCCEEDED, ControllerServer
from navlog.replay.nav2.controllers.dwb import DWBController, DWBParams
from navlog.replay.nav2.controllers.dwb.critics import (
    Cycle,
    adjust_plan_resolution,
    make_critic,
)
from navlog.replay.nav2.controllers.dwb.params import (
    BaseObstacleParams,
    GoalAlignParams,
    GoalDistParams,
    ObstacleFootprintParams,
    OscillationParams,
    PathAlignParams,
    PathDistParams,
    PreferForwardParams,
    RotateToGoalParams,
    resolve_critic_class,
)
from navlog.replay.nav2.controllers.dwb.trajectories import (
    Trajectories,
    axis_samples,
    generate,
    simulate,
    step_counts,
    velocity_samples,
)
from navlog.replay.nav2.controllers.registry import CONTROLLERS
from navlog.replay.nav2.costmap.cost_values import INSCRIBED, LETHAL, NO_INFORMATION
from navlog.replay.nav2.costmap.footprint import footprint_cost, footprint_costs, transform_footprint
from navlog.replay.nav2.costmap.grid import CostmapGrid, CostmapParams
from navlog.replay.nav2.costmap.inflation_layer import inflation_costs
from navlog.replay.nav2.params import load_nav2_params
from navlog.replay.nav2.schema import ERROR, WARNING, SectionReader


@pytest.fixture
def tb3(params_dir: Path) -> Path:
    """The TurtleBot3 (waffle) Humble Nav2 file."""
    return params_dir / "turtlebot3_humble_waffle_nav2.yaml"


@pytest.fixture
def tb4(params_dir: Path) -> Path:
    """The TurtleBot4 Humble Nav2 file."""
    return params_dir / "turtlebot4_humble_nav2.yaml"


# Nav2's Humble bringup kinematics (nav2_bringup/params/nav2_params.yaml)
HUMBLE = {
    "max_vel_x": 0.26,
    "max_speed_xy": 0.26,
    "max_vel_theta": 1.0,
    "acc_lim_x": 2.5,
    "acc_lim_theta": 3.2,
    "decel_lim_x": -2.5,
    "decel_lim_theta": -3.2,
    "vy_samples": 1,
    "linear_granularity": 0.05,
}


def dwb_params(**kw) -> DWBParams:
    base = {**HUMBLE, "critics": ("BaseObstacle",), "critic_params": {"BaseObstacle": BaseObstacleParams()}}
    return dataclasses.replace(DWBParams(), **{**base, **kw})


def read(section: dict) -> tuple[DWBParams, SectionReader]:
    r = SectionReader({})
    return DWBParams.read_loaded(r, section, ("FollowPath",), "dwb_core::DWBLocalPlanner"), r


def grid(size_cells: int = 10, resolution: float = 0.1, origin=(0.0, 0.0)) -> CostmapGrid:
    w = size_cells * resolution
    return CostmapGrid(
        CostmapParams(
            width=w, height=w, resolution=resolution, origin_x=origin[0], origin_y=origin[1], robot_radius=0.1
        )
    )


def trajectories(*rows, twists=None) -> Trajectories:
    """Trajectories from explicit pose lists (padded with their last pose)."""
    n = max(len(r) for r in rows)
    poses = np.array([list(r) + [r[-1]] * (n - len(r)) for r in rows], dtype=np.float64)
    tw = np.zeros((len(rows), 3)) if twists is None else np.asarray(twists, dtype=np.float64)
    times = np.tile(np.arange(n, dtype=np.float64), (len(rows), 1))
    return Trajectories(tw, poses, times, np.array([len(r) for r in rows]))


def cycle(cm: CostmapGrid, plan, pose=(0.55, 0.55, 0.0), goal=None, velocity=(0.0, 0.0, 0.0), tol=0.25) -> Cycle:
    plan = np.asarray(plan, dtype=np.float64)
    goal = tuple(plan[-1]) if goal is None else goal
    return Cycle(pose, velocity, goal, plan, cm, np.array(cm.footprint), tol, 0.25)


# ------------------------------------------------------------------ parameters


def test_humble_files_load_without_errors_and_register_dwb(tb3, tb4):
    plugin = CONTROLLERS["dwb_core::DWBLocalPlanner"]
    assert plugin is not None and plugin.implementation is DWBController
    for path in (tb3, tb4):
        nav2 = load_nav2_params(path)
        assert nav2.errors == []
        p = nav2.controller_server.controllers["FollowPath"]
        assert isinstance(p, DWBParams)
        assert p.critics == (
            "RotateToGoal",
            "Oscillation",
            "BaseObstacle",
            "GoalAlign",
            "PathAlign",
            "PathDist",
            "GoalDist",
        )
        assert p.critic_params["BaseObstacle"] == BaseObstacleParams(scale=0.02)
        assert p.critic_params["PathAlign"] == PathAlignParams(scale=32.0, forward_point_distance=0.1)
        assert p.critic_params["RotateToGoal"] == RotateToGoalParams(
            scale=32.0, slowing_factor=5.0, lookahead_time=-1.0
        )
        assert p.critic_params["Oscillation"] == OscillationParams()
    tb3 = load_nav2_params(tb3).controller_server.controllers["FollowPath"]
    assert (tb3.max_vel_x, tb3.vtheta_samples, tb3.sim_time, tb3.xy_goal_tolerance) == (0.22, 40, 2.0, 0.05)


def test_kinematic_limits_left_at_zero_are_errors_naming_the_key():
    p, r = read({"critics": ["BaseObstacle"], "max_vel_x": 0.26, "acc_lim_x": 2.5, "decel_lim_x": -2.5})
    bad = sorted(x.path for x in r.problems if x.severity == ERROR)
    assert bad == [
        "FollowPath.acc_lim_theta",
        "FollowPath.decel_lim_theta",
        "FollowPath.max_speed_xy",
        "FollowPath.max_vel_theta",
    ]
    assert any("max_vel_theta: 1.0" in x.message for x in r.problems)
    with pytest.raises(ConfigError, match="max_vel_theta is 0.0"):
        DWBController(p, ControllerSetup())
    # a decel limit given as a positive number is out of range, as is a negative acceleration
    _, r = read({**HUMBLE, "critics": ["BaseObstacle"], "decel_lim_x": 2.5, "acc_lim_theta": -1.0})
    assert {x.path for x in r.problems if x.severity == ERROR} >= {"FollowPath.decel_lim_x", "FollowPath.acc_lim_theta"}


def test_critics_read_flat_or_nested_and_resolved_as_dwb_does():
    assert resolve_critic_class("PathAlign", ()) == "dwb_critics::PathAlignCritic"
    assert resolve_critic_class("BaseObstacleCritic", ()) == "dwb_critics::BaseObstacleCritic"
    section = {
        **HUMBLE,
        "critics": ["Obstacles", "GoalAlign", "PathDst", "Twirl"],
        "Obstacles.class": "ObstacleFootprint",
        "Obstacles.sum_scores": True,
        "GoalAlign": {"scale": 24.0, "aggregation_type": "Sum"},
        "PathDist.scale": 3.0,
    }
    p, r = read(section)
    assert p.critic_params["Obstacles"] == ObstacleFootprintParams(sum_scores=True)
    assert p.critic_params["GoalAlign"] == GoalAlignParams(scale=24.0, aggregation_type="sum")
    problems = [(x.severity, x.path, x.message) for x in r.problems]
    assert [m for sev, path, m in problems if sev == ERROR and path == "FollowPath.critics"] == [
        "unknown DWB critic 'PathDst' (class PathDstCritic) (did you mean 'PathDist'?); Nav2 fails to load it",
        "unknown DWB critic 'Twirl' (class TwirlCritic) (did you mean 'Twirling'?); Nav2 fails to load it",
    ]
    assert any(sev == WARNING and path == "FollowPath.PathDist" and "not in critics" in m for sev, path, m in problems)
    _, r = read({**HUMBLE})
    assert [x.message[:19] for x in r.problems if x.severity == ERROR] == ["DWB needs 'critics'"]
    # no section at all (the server's default plugin): one warning, not the errors of a configured DWB
    _, r = read({})
    assert [(x.severity, x.path) for x in r.problems] == [(WARNING, "FollowPath")]


# ------------------------------------------------------------------ velocity samples and trajectories


def test_one_axis_samples_window_and_inserted_zero():
    # from rest, window 0 +- 3.2 * 0.1: 4 samples -0.32 .. 0.32, with an exact 0 inserted
    assert axis_samples(0.0, -1.0, 1.0, 3.2, -3.2, 0.1, 4) == pytest.approx([-0.32, -0.32 / 3, 0.0, 0.32 / 3, 0.32])
    # the window is clipped by the limits, and a window inside them keeps its width
    assert axis_samples(-0.3, -1.0, 1.0, 2.5, -2.5, 0.1, 5) == pytest.approx([-0.55, -0.425, -0.3, -0.175, -0.05])
    assert axis_samples(0.1, 0.0, 0.22, 2.5, -2.5, 1.7, 3) == pytest.approx([0.0, 0.11, 0.22])
    # no room: one sample (vy of a differential robot)
    assert axis_samples(0.0, 0.0, 0.0, 0.0, 0.0, 1.7, 5) == [0.0]


def test_sample_counts_of_the_humble_robots(tb3, tb4):
    tb3 = load_nav2_params(tb3).controller_server.controllers["FollowPath"]
    twists = velocity_samples(tb3, (0.0, 0.0, 0.0), tb3.sim_time)
    # vx 20 in [0, 0.22]; vy one (0); vtheta 40 in [-1, 1] plus the inserted 0; minus the zero twist
    assert len(twists) == 20 * 41 - 1
    assert twists[0] == pytest.approx([0.0, 0.0, -1.0])
    assert twists[-1] == pytest.approx([0.22, 0.0, 1.0])
    assert not ((twists[:, 0] == 0) & (twists[:, 2] == 0)).any()
    tb4 = load_nav2_params(tb4).controller_server.controllers["FollowPath"]
    assert len(velocity_samples(tb4, (0.0, 0.0, 0.0), tb4.sim_time)) == 20 * 21 - 1
    # LimitedAccelGenerator: the window is 1 / controller_frequency wide: vx 0.1 +- 2.5 * 0.05
    limited = dataclasses.replace(tb3, trajectory_generator_name="dwb_plugins::LimitedAccelGenerator")
    ctrl = DWBController(limited, ControllerSetup(controller_frequency=20.0))
    xs = np.unique(velocity_samples(limited, (0.1, 0.0, 0.0), ctrl.window_time)[:, 0])
    assert (xs.min(), xs.max(), len(xs)) == (pytest.approx(0.0), pytest.approx(0.22), 20)
    # max_speed_xy below max_vel_x removes the fast samples
    slow = dataclasses.replace(tb3, max_speed_xy=0.1)
    assert velocity_samples(slow, (0.0, 0.0, 0.0), 2.0)[:, 0].max() <= 0.1 + 1e-5


def test_trajectory_steps_and_end_poses():
    p = dwb_params(sim_time=1.7)
    tw = np.array([[0.2, 0.0, 0.0], [0.0, 0.0, 1.0]])
    # 0.2 m/s for 1.7 s in steps of at most 0.05 m: ceil(6.8) = 7; 1 rad/s: ceil(1.7 / 0.025) = 68
    assert step_counts(p, tw).tolist() == [7, 68]
    assert step_counts(dataclasses.replace(p, discretize_by_time=True), tw).tolist() == [4, 4]  # ceil(1.7 / 0.5)
    t = generate(p, (1.0, 2.0, 0.0), (0.0, 0.0, 0.0), tw)
    assert t.count.tolist() == [7 + 2, 68 + 2]  # start, steps, the last point again
    # straight: 2.5 m/s² reaches 0.2 m/s within the first step of 1.7/7 s
    assert t.poses[0, t.count[0] - 1] == pytest.approx([1.0 + 0.34, 2.0, 0.0])
    # rotation: 3.2 rad/s² in steps of 0.025 s: 0.08, 0.16, .. 0.96 then 1.0 for 56 steps
    assert t.poses[1, -1, 2] == pytest.approx(0.025 * (0.08 * 78 + 56 * 1.0))
    assert t.poses[1, -1, :2] == pytest.approx([1.0, 2.0])
    assert t.times[1, -1] == pytest.approx(1.7)
    without_last = generate(dataclasses.replace(p, include_last_point=False), (0, 0, 0), (0, 0, 0), tw)
    assert without_last.count.tolist() == [8, 69]
    # decelerating from 0.26 to 0.1 at -2.5 m/s² over 1.7/9 s steps: 0.26 - 0.472 < 0.1, so 0.1 at once
    t = generate(p, (0.0, 0.0, 0.0), (0.26, 0.0, 0.0), np.array([[0.1, 0.0, 0.0]]))
    assert t.poses[0, -1, 0] == pytest.approx(0.17)


@pytest.mark.parametrize(
    "generator", ["dwb_plugins::StandardTrajectoryGenerator", "dwb_plugins::LimitedAccelGenerator"]
)
def test_compiled_simulate_gives_the_plain_python_bits(generator, monkeypatch, tb3):
    # a cycle of the TurtleBot 3 file's: its 819 samples from a moving, turning robot
    tb3 = dataclasses.replace(
        load_nav2_params(tb3).controller_server.controllers["FollowPath"], trajectory_generator_name=generator
    )
    velocity = (0.15, 0.0, -0.4)
    twists = velocity_samples(tb3, velocity, tb3.sim_time)
    compiled = generate(tb3, (1.3, -0.7, 2.9), velocity, twists)
    monkeypatch.setattr(trajectories_module, "compiled_simulate", lambda: simulate)
    plain = generate(tb3, (1.3, -0.7, 2.9), velocity, twists)
    assert compiled.poses.tobytes() == plain.poses.tobytes() and compiled.times.tobytes() == plain.times.tobytes()
    assert compiled.twists.tobytes() == plain.twists.tobytes()
    assert len(twists) > 500 and np.ptp(compiled.poses[:, -1, 2]) > 1.0  # trajectories that turn apart


# ------------------------------------------------------------------ critics on a small grid


def test_base_obstacle_scores_the_last_cell_and_rejects_obstacles():
    cm = grid()
    cm.costs[5, 5] = 100
    cm.costs[5, 7] = INSCRIBED
    cm.costs[2, 2] = LETHAL
    cm.costs[8, 8] = NO_INFORMATION
    critic = make_critic("BaseObstacle", BaseObstacleParams(scale=0.02))
    t = trajectories(
        [(0.15, 0.55, 0), (0.55, 0.55, 0)],  # ends on the cost-100 cell
        [(0.55, 0.55, 0), (0.75, 0.55, 0)],  # ends on INSCRIBED
        [(0.25, 0.25, 0), (0.35, 0.25, 0)],  # starts on LETHAL
        [(0.85, 0.85, 0)],  # unknown
        [(0.95, 0.55, 0), (1.05, 0.55, 0)],  # off the grid
        [(0.55, 0.55, 0), (0.15, 0.15, 0)],  # passes cost 100, ends free
    )
    score, illegal, _ = critic.score(t, cycle(cm, [(0.05, 0.05, 0)]))
    assert illegal.tolist() == [False, True, True, True, True, False]
    assert score[[0, 5]].tolist() == [100.0, 0.0]
    summed = make_critic("B", BaseObstacleParams(sum_scores=True)).score(t, cycle(cm, [(0.05, 0.05, 0)]))[0]
    assert summed[[0, 5]].tolist() == [100.0, 100.0]


def test_obstacle_footprint_takes_the_outline_and_allows_inscribed():
    cm = grid(20, 0.05)
    cm.costs[10, 14] = INSCRIBED
    cm.costs[10, 6] = 50
    critic = make_critic("ObstacleFootprint", ObstacleFootprintParams(scale=1.0))
    c = cycle(cm, [(0.5, 0.5, 0)])
    c.footprint = np.array([[0.2, 0.0], [0.0, 0.2], [-0.2, 0.0], [0.0, -0.2]])  # a diamond
    # at (0.51, 0.51) its side vertices sit on cells (6, 10) and (14, 10); 0.05 m on, on (7, 10) and (15, 10)
    t = trajectories([(0.51, 0.51, 0.0)], [(0.51, 0.51, 0.0), (0.56, 0.51, 0.0)], [(0.86, 0.51, 0.0)])
    score, illegal, _ = critic.score(t, c)
    assert illegal.tolist() == [False, False, True]  # the last one's vertex leaves the grid
    assert score[:2].tolist() == [INSCRIBED, 0.0]  # INSCRIBED on the outline is legal; the last pose counts
    summed = make_critic("F", ObstacleFootprintParams(sum_scores=True)).score(t, c)[0]
    assert summed[:2].tolist() == [INSCRIBED, INSCRIBED + 0.0]  # over the real poses only
    assert critic.scale(c) == pytest.approx(0.05)  # scale x resolution
    cm.costs[10, 15] = LETHAL
    assert critic.score(t, c)[1].tolist() == [False, True, True]


def test_footprint_costs_equal_footprint_cost_per_placement():
    rng = np.random.default_rng(7)
    costs = rng.choice(np.array([0, 10, 100, INSCRIBED, LETHAL, NO_INFORMATION], dtype=np.uint8), (40, 50))
    square = [(0.3, 0.2), (0.3, -0.2), (-0.3, -0.25), (-0.3, 0.25)]
    placed = np.array([transform_footprint(square, *p) for p in rng.uniform((-0.5, -0.5, -3), (2.7, 2.2, 3), (500, 3))])
    expected = [footprint_cost(costs, v, 0.0, 0.0, 0.05) for v in placed]
    assert footprint_costs(costs, placed, 0.0, 0.0, 0.05).tolist() == expected
    assert set(expected) >= {LETHAL, NO_INFORMATION}


def test_path_and_goal_distances_on_a_small_grid():
    cm = grid()  # 10 x 10 cells of 0.1 m
    plan = [(x, 0.55, 0.0) for x in np.arange(0.05, 1.0, 0.1)]  # along row 5
    c = cycle(cm, plan)
    path_dist = make_critic("PathDist", PathDistParams(scale=32.0))
    goal_dist = make_critic("GoalDist", GoalDistParams(scale=24.0))
    assert path_dist.prepare(c) and goal_dist.prepare(c)
    t = trajectories([(0.55, 0.55, 0), (0.55, 0.85, 0)], [(0.35, 0.15, 0)], [(0.95, 0.55, 0)])
    assert path_dist.score(t, c)[0].tolist() == [3.0, 4.0, 0.0]  # cells from row 5
    assert goal_dist.score(t, c)[0].tolist() == [7.0, 10.0, 0.0]  # Manhattan cells to (9, 5)
    assert path_dist.scale(c) == pytest.approx(0.1 * 0.5 * 32.0)
    # a plan off the costmap leaves every cell unreachable: PathDist rules every trajectory out
    off = cycle(cm, [(5.0, 5.0, 0.0), (6.0, 5.0, 0.0)])
    assert not path_dist.prepare(off)
    assert path_dist.score(t, off)[1].all()
    # only the plan's first stretch on known cells counts
    cm.costs[5, 5] = NO_INFORMATION
    assert path_dist.prepare(c)
    assert path_dist.score(t, c)[0].tolist() == [4.0, 4.0, 5.0]  # sources are cells 0..4 of row 5


def test_alignment_critics_score_the_point_ahead():
    cm = grid()
    plan = [(x, 0.55, 0.0) for x in np.arange(0.05, 0.7, 0.1)]  # row 5, cells 0..6
    c = cycle(cm, plan, pose=(0.15, 0.55, 0.0))
    path_align = make_critic("PathAlign", PathAlignParams(scale=32.0, forward_point_distance=0.3))
    goal_align = make_critic("GoalAlign", GoalAlignParams(scale=24.0, forward_point_distance=0.3))
    assert path_align.prepare(c) and goal_align.prepare(c)
    # heading +y from (0.35, 0.55): the point ahead (0.35, 0.85) is 3 cells off the path
    t = trajectories([(0.15, 0.55, 0.0), (0.35, 0.55, math.pi / 2)], [(0.15, 0.55, 0.0), (0.35, 0.55, 0.0)])
    assert path_align.score(t, c)[0].tolist() == [3.0, 0.0]
    # the goal target is the plan's end (0.65) moved 0.3 on along robot -> goal: (0.95, 0.55), cell (9, 5)
    assert goal_align.score(t, c)[0].tolist() == [3.0 + 6.0, 3.0]
    # within forward_point_distance of the goal PathAlign drops out (scale 0)
    near = cycle(cm, plan, pose=(0.5, 0.55, 0.0))
    path_align.prepare(near)
    assert path_align.scale(near) == 0.0


def test_rotate_to_goal_slows_then_only_rotates():
    cm = grid()
    plan = [(0.5, 0.5, 0.0), (0.55, 0.55, 1.0)]
    critic = make_critic("RotateToGoal", RotateToGoalParams(scale=32.0))
    tw = [[0.0, 0.0, 0.5], [0.1, 0.0, 0.0], [0.3, 0.0, 0.0]]
    t = trajectories([(0.5, 0.5, 0.2)], [(0.5, 0.5, 0.5)], [(0.5, 0.5, 1.0)], twists=tw)
    far = cycle(cm, plan, pose=(0.1, 0.1, 0.0))
    critic.prepare(far)
    assert critic.score(t, far)[0].tolist() == [0.0, 0.0, 0.0]
    # inside xy_goal_tolerance at 0.3 m/s (> trans_stopped_velocity 0.25): must slow down
    moving = cycle(cm, plan, pose=(0.5, 0.5, 0.0), velocity=(0.3, 0.0, 0.0))
    critic.prepare(moving)
    score, illegal, _ = critic.score(t, moving)
    assert illegal.tolist() == [False, False, True]
    assert score[:2] == pytest.approx([0.8, 0.1**2 * 5.0 + 0.5])
    # slow enough: only rotation is legal, scored by the yaw error at the end; latched from now on
    stopped = cycle(cm, plan, pose=(0.5, 0.5, 0.0), velocity=(0.1, 0.0, 0.0))
    critic.prepare(stopped)
    score, illegal, _ = critic.score(t, stopped)
    assert illegal.tolist() == [False, True, True]
    assert score[0] == pytest.approx(0.8)
    critic.prepare(far)
    assert critic.score(t, far)[1].tolist() == [False, True, True]
    critic.reset()
    critic.prepare(far)
    assert not critic.score(t, far)[1].any()


def test_oscillation_and_prefer_forward():
    cm = grid()
    c = cycle(cm, [(0.5, 0.5, 0.0)], pose=(0.5, 0.5, 0.0))
    osc = make_critic("Oscillation", OscillationParams())
    tw = [[0.2, 0.0, 0.0], [-0.2, 0.0, 0.0], [0.0, 0.0, 0.5]]
    t = trajectories([(0.5, 0.5, 0)], [(0.5, 0.5, 0)], [(0.5, 0.5, 0)], twists=tw)
    osc.prepare(c)
    osc.debrief((0.2, 0.0, 0.0), c)
    assert not osc.score(t, c)[1].any()
    osc.debrief((-0.2, 0.0, 0.0), c)  # forward then backward: going forward again would oscillate
    assert osc.score(t, c)[1].tolist() == [True, False, False]
    moved = cycle(cm, [(0.5, 0.5, 0.0)], pose=(0.6, 0.5, 0.0))  # 0.1 m > oscillation_reset_dist
    osc.prepare(moved)
    osc.debrief((-0.2, 0.0, 0.0), moved)
    assert not osc.score(t, moved)[1].any()
    pf = make_critic("PreferForward", PreferForwardParams())
    tw = [[-0.1, 0.0, 0.0], [0.05, 0.0, 0.1], [0.2, 0.0, 0.5], [0.05, 0.0, 0.3]]
    t = trajectories(*[[(0.5, 0.5, 0)]] * 4, twists=tw)
    assert pf.score(t, c)[0] == pytest.approx([1.0, 1.0, 5.0, 3.0])


def test_adjust_plan_resolution_fills_long_gaps():
    xy = np.array([[0.0, 0.0], [1.0, 0.0], [1.05, 0.0]])
    out = adjust_plan_resolution(xy, 0.1)
    # 1 m apart: int((1 - 0.2) / 0.1) - 1 = 7 parts, 6 points inserted every 1/7 m
    assert len(out) == 3 + 6
    assert out[:8, 0] == pytest.approx(np.arange(8) / 7.0)
    assert adjust_plan_resolution(xy[1:], 0.1) is not None and len(adjust_plan_resolution(xy[1:], 0.1)) == 2


# ------------------------------------------------------------------ the planner


class Tolerances:
    xy_goal_tolerance = 0.25
    yaw_goal_tolerance = 0.25


def context(cm: CostmapGrid, now_ns: int = 0) -> ControlContext:
    return ControlContext(now_ns=now_ns, costmap=cm, global_to_local=np.eye(3), goal_checker=Tolerances())


@pytest.fixture
def humble_controller(tb3: Path) -> Callable[..., DWBController]:
    """Makes the TurtleBot3 file's DWB at 10 Hz, robot radius 0.22 m, with the given parameters replaced."""

    def make(**kw) -> DWBController:
        p = load_nav2_params(tb3).controller_server.controllers["FollowPath"]
        return DWBController(
            dataclasses.replace(p, **kw), ControllerSetup(controller_frequency=10.0, robot_radius=0.22)
        )

    return make


def test_plan_transform_prunes_as_dwb(humble_controller):
    ctrl = humble_controller()
    plan = np.column_stack([np.arange(21) * 0.25, np.zeros(21), np.zeros(21)])  # 0 .. 5 m along x
    ctrl.set_plan(plan)
    cm = grid(60, 0.05, origin=(0.5, -1.5))  # 3 x 3 m: half size 1.5 m
    local = ctrl.transform_plan((2.0, 0.0, 0.0), context(cm))
    # starts at the first pose closer than 1.5 m (0.75), ends before the first farther than 1.5 m (3.75)
    assert local[:, 0] == pytest.approx(np.arange(3, 15) * 0.25)
    assert ctrl.plan is not None and ctrl.plan[0, 0] == pytest.approx(0.75)  # pruned for good
    keep = humble_controller(prune_plan=False, shorten_transformed_plan=False)
    keep.set_plan(plan)
    local = keep.transform_plan((2.0, 0.0, 0.0), context(cm))
    assert (local[0, 0], local[-1, 0], len(keep.plan)) == (pytest.approx(0.75), pytest.approx(3.5), 21)
    # a plan frame moved by map -> odom: the plan comes out in the costmap frame
    shifted = ControlContext(0, cm, np.array([[1.0, 0, 0.5], [0, 1.0, 0], [0, 0, 1.0]]), Tolerances())
    keep.set_plan(plan)
    assert keep.transform_plan((2.5, 0.0, 0.0), shifted)[0, 0] == pytest.approx(1.25)
    far = humble_controller()
    far.set_plan(plan)
    with pytest.raises(InvalidPath):
        far.transform_plan((20.0, 20.0, 0.0), context(grid(60, 0.05, origin=(18.5, 18.5))))
    with pytest.raises(InvalidPath):
        humble_controller().compute_velocity_commands((0, 0, 0), (0, 0, 0), context(cm))


def test_no_legal_trajectory_is_no_valid_control_naming_the_critic(humble_controller):
    ctrl = humble_controller()
    cm = grid(60, 0.05, origin=(-1.5, -1.5))
    cm.costs[:] = LETHAL
    ctrl.set_plan(np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0]]))
    with pytest.raises(NoValidControl, match=r"no legal trajectory among 819 samples \(819 by BaseObstacle"):
        ctrl.compute_velocity_commands((0.0, 0.0, 0.0), (0.0, 0.0, 0.0), context(cm))


def test_short_circuit_does_not_change_the_command(humble_controller):
    cm = grid(60, 0.05, origin=(-1.5, -1.5))
    plan = np.column_stack([np.linspace(0, 1.4, 29), np.linspace(0, 0.7, 29), np.full(29, 0.46)])
    cmds = []
    for short in (True, False):
        ctrl = humble_controller(short_circuit_trajectory_evaluation=short)
        ctrl.set_plan(plan)
        cmds.append(ctrl.compute_velocity_commands((0.0, 0.0, 0.0), (0.1, 0.0, 0.0), context(cm)).cmd)
    assert cmds[0] == cmds[1]
    assert cmds[0][0] > 0.0 and cmds[0][2] > 0.0  # forward, turning left towards the plan


def l_path() -> np.ndarray:
    a = np.column_stack([np.arange(0, 3.0, 0.05), np.zeros(60), np.zeros(60)])
    b = np.column_stack([np.full(61, 3.0), np.arange(0, 3.0001, 0.05), np.full(61, math.pi / 2)])
    return np.vstack([a, b])


def drive(ctrl: DWBController, cm: CostmapGrid, path: np.ndarray, frequency: float, limit_s: float = 40.0):
    """A unicycle following the controller's commands; returns the poses it went through."""
    dt = 1.0 / frequency
    x = y = th = 0.0
    v = w = 0.0
    ctrl.set_plan(path)
    poses = [(x, y, th)]
    for i in range(int(limit_s * frequency)):
        if math.hypot(x - path[-1, 0], y - path[-1, 1]) < 0.25:
            break
        v, _, w = ctrl.compute_velocity_commands((x, y, th), (v, 0.0, w), context(cm, int(i * dt * 1e9))).cmd
        x, y, th = x + v * math.cos(th) * dt, y + v * math.sin(th) * dt, th + w * dt
        poses.append((x, y, th))
    return np.array(poses)


@pytest.mark.slow
def test_closed_loop_turtlebot3_follows_an_l_path(humble_controller):
    ctrl = humble_controller()
    cm = grid(120, 0.05, origin=(-1.0, -1.0))  # 6 x 6 m, empty
    poses = drive(ctrl, cm, l_path(), 10.0)
    end = poses[-1]
    assert math.hypot(end[0] - 3.0, end[1] - 3.0) < 0.25
    assert np.abs(poses[:, 1][poses[:, 0] < 2.5]).max() < 0.05  # on the first leg
    assert len(poses) < 30 * 10  # 5.75 m at <= 0.22 m/s: well under 30 s


@pytest.mark.slow
def test_closed_loop_turtlebot3_passes_clutter_without_touching_it(humble_controller):
    cm = grid(120, 0.05, origin=(-1.0, -1.0))
    lethal = np.zeros(cm.costs.shape, dtype=bool)
    lethal[26:32, 46:54] = True  # a box x 1.3 .. 1.7, y 0.3 .. 0.6 beside the first leg
    lethal[70:78, 86:90] = True  # a box x 3.3 .. 3.5, y 2.5 .. 2.9 beside the second leg
    d = distance_transform_edt(~lethal)
    cm.costs[:] = inflation_costs(d, cm.resolution, 0.22, 3.0)
    poses = drive(ctrl := humble_controller(), cm, l_path(), 10.0)
    assert ctrl is not None
    end = poses[-1]
    assert math.hypot(end[0] - 3.0, end[1] - 3.0) < 0.25
    mx, my = cm.world_to_cell(poses[:, 0], poses[:, 1])
    assert (cm.costs[my, mx] < INSCRIBED).all()  # the robot's circle never reached a lethal cell


@pytest.mark.slow
def test_controller_server_runs_dwb_from_the_turtlebot3_file_to_success(tb3):
    cs = load_nav2_params(tb3).controller_server
    server = ControllerServer(cs, ControllerSetup(controller_frequency=cs.controller_frequency, robot_radius=0.22))
    assert isinstance(server.controller, DWBController)
    cm = grid(120, 0.05, origin=(-1.0, -1.0))
    path = l_path()
    dt = 1.0 / cs.controller_frequency
    x = y = th = v = w = 0.0
    server.follow_path(path, 0)
    for i in range(400):
        out = server.cycle(int(i * dt * 1e9), (x, y, th), (v, 0.0, w), context(cm, int(i * dt * 1e9)))
        if out.status != RUNNING:
            break
        v, _, w = out.cmd
        x, y, th = x + v * math.cos(th) * dt, y + v * math.sin(th) * dt, th + w * dt
    assert out.status == SUCCEEDED
    assert math.hypot(x - 3.0, y - 3.0) <= 0.25 and abs(th - math.pi / 2) <= 0.25  # the goal checker's tolerances
