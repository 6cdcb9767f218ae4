"""``--set`` of Nav2 keys in every pipeline that runs Nav2 nodes (navigation, safety, localization), as the
planner pipeline takes them: a node block then a full or short key path, or ``nav2.KEY`` for any key;
and the localization pipeline's initial pose from the command line."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navlog.errors import ConfigError
from navlog.recorder.world import write_world_map
from navlog.replay.pipelines import localization, navigation
from navlog.replay.session import pipeline_params

NAV_TOPICS = {"/tf", "/tf_static", "/scan", "/odom", "/map"}


def test_navigation_takes_nav2_keys_of_its_stack_and_its_filters():
    overrides = [
        "controller_server.FollowPath.desired_linear_vel=0.2",  # nav_go2.yaml: 0.3
        "global_costmap.inflation_layer.inflation_radius=0.6",  # short path, as the planner's
        "nav2.velocity_smoother.max_velocity=[0.25,0.0,1.0]",  # the smoother's name is its switch here
        "nav2.FootprintApproach.time_before_collision=2.0",  # any key, short
    ]
    run = navigation.build(pipeline_params("navigation", overrides=overrides), NAV_TOPICS)
    nav_node = run.stack.navigation
    assert nav_node.cparams.controllers["FollowPath"].desired_linear_vel == 0.2
    assert run.stack.global_costmap.params.layers["inflation_layer"].inflation_radius == 0.6
    smoother, monitor = (n for n in run.nodes if type(n).__name__ in ("VelocitySmootherNode", "CollisionMonitorNode"))
    assert tuple(smoother.params.max_velocity) == (0.25, 0.0, 1.0)
    assert monitor.monitor.params.polygon_params["FootprintApproach"].time_before_collision == 2.0
    # and without overrides the file's values stand
    plain = navigation.build(pipeline_params("navigation"), NAV_TOPICS)
    assert plain.stack.navigation.cparams.controllers["FollowPath"].desired_linear_vel == 0.3


def test_navigation_nav2_key_errors_name_the_key():
    with pytest.raises(ConfigError, match=r"desired_linear_ve: no such parameter \(did you mean 'desired_linear_vel'"):
        navigation.build(
            pipeline_params("navigation", overrides=["controller_server.FollowPath.desired_linear_ve=0.2"]), NAV_TOPICS
        )
    with pytest.raises(ConfigError, match="inflation_radius: ambiguous, it matches 2 parameters"):
        navigation.build(pipeline_params("navigation", overrides=["nav2.inflation_radius=0.4"]), NAV_TOPICS)


@pytest.mark.parametrize(
    "override, message",
    [
        (
            "behavior_server.cycle_frequency=-1",
            r"behavior_server.ros__parameters.cycle_frequency: -1.0 is out of range",
        ),
        ("behavior_server.rotational_acc_lim=.nan", r"rotational_acc_lim: expected a number, got .NaN."),
        ("behavior_server.max_rotational_vel=-1", r"max_rotational_vel: -1.0 is out of range: must be >= 0.0"),
        ("nav2.bt_navigator.bt_loop_duration=-1", r"bt_navigator.ros__parameters.bt_loop_duration: -1"),
    ],
)
def test_navigation_refuses_bad_values_in_every_block_its_stack_runs(override, message):
    """The behaviour server, the navigator and the waypoint follower run in the navigation stack: a bad value
    there is an error naming it, as in the planner's and controller's blocks (it was left to its default)."""
    with pytest.raises(ConfigError, match=message):
        navigation.build(pipeline_params("navigation", overrides=[override]), NAV_TOPICS)


def test_navigation_refuses_a_bad_waypoint_follower_value_with_its_file_and_line(shared_dir):
    # the pipeline's own Nav2 file has no waypoint_follower block; Nav2's default parameters do (loop_rate: 20 on
    # line 460)
    nav2 = shared_dir / "external-data/nav2_bringup/params/nav2_params.yaml"
    navigation.build(pipeline_params("navigation", overrides=[f"nav2_params={nav2}"]), NAV_TOPICS)
    with pytest.raises(
        ConfigError,
        match=r"nav2_params.yaml:460: error: waypoint_follower.ros__parameters.loop_rate: 0 is out of range",
    ):
        overrides = [f"nav2_params={nav2}", "nav2.waypoint_follower.loop_rate=0"]
        navigation.build(pipeline_params("navigation", overrides=overrides), NAV_TOPICS)


@pytest.mark.parametrize("seed", [-1, 2**32, 10**30])
def test_navigation_refuses_a_seed_numpy_cannot_take(seed):
    with pytest.raises(
        ConfigError, match=f"seed: {seed} is out of range: a seed must be an integer from 0 to 4294967295"
    ):
        pipeline_params("navigation", overrides=[f"seed={seed}"])


@pytest.fixture(scope="module")
def room_map(tmp_path_factory):
    out = tmp_path_factory.mktemp("room") / "map.yaml"
    write_world_map("indoor_room", out, margin=0.0)
    return out


def test_localization_initial_pose_and_amcl_keys_from_the_command_line(room_map):
    params = pipeline_params(
        "localization", overrides=[f"map={room_map}", "initial_pose=[1.5,-0.5,0.7]", "amcl.max_particles=800"]
    )
    run = localization.build(params, {"/scan", "/tf", "/tf_static"})
    assert run.mode == "parameters" and run.info["initial_pose"] == "parameters"
    assert run.amcl.max_particles == 800 and run.amcl.set_initial_pose
    node = run.node
    assert node.initialised_ns is not None  # no /initialpose nor ground truth needed
    est = node.filter.estimate().pose
    assert math.hypot(est[0] - 1.5, est[1] + 0.5) < 0.15 and abs(est[2] - 0.7) < 0.2
    assert len(node.filter.poses) <= 800
    # Nav2's own keys do the same, without a Nav2 file
    keys = ["amcl.set_initial_pose=true", "amcl.initial_pose.x=-1.0", "amcl.initial_pose.yaw=3.0"]
    run = localization.build(pipeline_params("localization", overrides=[f"map={room_map}", *keys]), {"/scan", "/tf"})
    assert run.mode == "parameters"
    assert (run.amcl.initial_pose_x, run.amcl.initial_pose_y, run.amcl.initial_pose_yaw) == (-1.0, 0.0, 3.0)
    est = run.node.filter.estimate().pose
    assert abs(est[0] + 1.0) < 0.15 and abs(np.angle(np.exp(1j * (est[2] - 3.0)))) < 0.2  # the mean of the particles
    with pytest.raises(ConfigError, match="initial_pose"):
        pipeline_params("localization", overrides=["initial_pose=[1.0,2.0]"])
