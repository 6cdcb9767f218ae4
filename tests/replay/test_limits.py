"""Parameters bounded where a value would hang a replay or exhaust memory (``navlog.replay.limits``):
check-config reports each bound as an error on its key, a replay refuses it before running with the
same message, and the largest accepted values still finish."""

from __future__ import annotations

import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from navlog.errors import ConfigError
from navlog.replay import limits
from navlog.replay.config import from_mapping
from navlog.replay.nav2 import parse_nav2_text
from navlog.replay.nav2.collision_monitor.params import CollisionPolygonParams
from navlog.replay.nav2.controllers.dwb.params import DWBParams
from navlog.replay.nav2.controllers.dwb.trajectories import velocity_samples
from navlog.replay.nodes.occupancy_mapper import OccupancyMapperParams

NAVLOG = [sys.executable, "-m", "navlog"]


def _costmap(extra: str) -> str:
    return f"""
local_costmap:
  local_costmap:
    ros__parameters:
      rolling_window: true
{extra}
"""


def _errors(text: str) -> dict[str, str]:
    return {p.path: p.message for p in parse_nav2_text(text).errors}


@pytest.mark.parametrize(
    ("text", "key", "words"),
    [
        (
            "controller_server:\n  ros__parameters:\n    controller_frequency: 5000.0\n",
            "controller_server.ros__parameters.controller_frequency",
            "5000.0 is out of range: must be <= 1000.0",
        ),
        (
            "planner_server:\n  ros__parameters:\n    expected_planner_frequency: 1000000000.0\n",
            "planner_server.ros__parameters.expected_planner_frequency",
            "must be <= 1000.0",
        ),
        (
            _costmap("      update_frequency: .inf"),
            "local_costmap.local_costmap.ros__parameters.update_frequency",
            "inf is out of range: must be <= 1000.0",
        ),
        (
            _costmap("      width: 100\n      height: 100\n      resolution: 0.001"),
            "local_costmap.local_costmap.ros__parameters.resolution",
            "= 10,000,000,000 cells exceeds navlog's budget of 100,000,000 cells",
        ),
        (
            "amcl:\n  ros__parameters:\n    max_particles: 100000000\n",
            "amcl.ros__parameters.max_particles",
            "must be <= 100000",
        ),
        (
            "velocity_smoother:\n  ros__parameters:\n    smoothing_frequency: 1000000.0\n",
            "velocity_smoother.ros__parameters.smoothing_frequency",
            "must be <= 1000.0",
        ),
    ],
)
def test_check_config_reports_the_bound_on_its_key(text, key, words):
    errors = _errors(text)
    assert key in errors, errors
    assert words in errors[key]


def test_costmap_budget_names_the_asked_size():
    message = _errors(_costmap("      width: 100\n      height: 100\n      resolution: 0.001"))[
        "local_costmap.local_costmap.ros__parameters.resolution"
    ]
    assert "width 100 m, height 100 m, resolution 0.001 m" in message
    # at the budget exactly: 10,000 x 10,000 cells is accepted
    assert not _errors(_costmap("      width: 100\n      height: 100\n      resolution: 0.01"))


def test_products_of_plugin_parameters_are_budgeted():
    mppi = _errors(
        """
controller_server:
  ros__parameters:
    controller_plugins: [FollowPath]
    FollowPath:
      plugin: nav2_mppi_controller::MPPIController
      batch_size: 100000
      time_steps: 56
"""
    )
    assert mppi["controller_server.ros__parameters.FollowPath.batch_size"] == (
        "batch_size x time_steps (100000 x 56) = 5,600,000 samples exceeds navlog's budget of 2,000,000 samples; "
        "lower it"
    )
    dwb = _errors(
        """
controller_server:
  ros__parameters:
    controller_plugins: [FollowPath]
    FollowPath:
      plugin: dwb_core::DWBLocalPlanner
      vx_samples: 1000
      vy_samples: 1
      vtheta_samples: 1000
"""
    )
    assert (
        "(1000 x 1 x 1000) = 2,000,000 trajectories" in dwb["controller_server.ros__parameters.FollowPath.vx_samples"]
    )
    monitor = _errors(
        """
collision_monitor:
  ros__parameters:
    polygons: [FootprintApproach]
    FootprintApproach:
      type: polygon
      action_type: approach
      points: "[[0.3, 0.3], [0.3, -0.3], [-0.3, -0.3], [-0.3, 0.3]]"
      time_before_collision: 10.0
      simulation_time_step: 0.0001
"""
    )
    key = "collision_monitor.ros__parameters.FootprintApproach.simulation_time_step"
    assert "(10.0 s / 0.0001 s) = 100,000 steps exceeds navlog's budget of 10,000 steps" in monitor[key]


def test_shipped_values_are_within_every_bound(params_dir):
    for name in sorted(params_dir.glob("*.yaml")):
        assert not parse_nav2_text(name.read_text(), str(name)).errors, name


def test_typed_pipeline_parameters_are_bounded():
    with pytest.raises(ConfigError, match=r"occupancy.publish_period: 1e-06 is out of range: must be >= 0.05"):
        from_mapping(OccupancyMapperParams, {"publish_period": 0.000001}, "occupancy")
    with pytest.raises(ConfigError, match=r"publish_period: -1.0 is out of range"):
        from_mapping(OccupancyMapperParams, {"publish_period": -1.0})
    with pytest.raises(ConfigError, match=r"publish_period: inf is out of range: must be <= 1000000.0"):
        from_mapping(OccupancyMapperParams, {"publish_period": float("inf")})
    with pytest.raises(ConfigError, match=r"minimum_travel_distance: -1.0 is out of range: must be >= 0.0"):
        from_mapping(OccupancyMapperParams, {"minimum_travel_distance": -1.0})
    with pytest.raises(ConfigError, match=r"transform_timeout: 1e\+300 is out of range: must be <= 3600.0"):
        from_mapping(OccupancyMapperParams, {"transform_timeout": 1e300})


@pytest.mark.parametrize("seed", [-1, 2**32, 2**70])
def test_a_seed_out_of_range_is_one_error(seed):
    with pytest.raises(
        ConfigError, match=rf"seed: {seed} is out of range: a seed must be an integer from 0 to 4294967295"
    ):
        limits.check_seed(seed)
    assert limits.check_seed(limits.MAX_SEED) == limits.MAX_SEED


def test_record_refuses_a_negative_seed_before_running(tmp_path):
    out = tmp_path / "run.mcap"
    cmd = [*NAVLOG, "record", "--world", "indoor_room", "--robot", "go2", "--scenario", "teleop", "--seed", "-1"]
    proc = subprocess.run([*cmd, "-o", str(out)], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 2, proc.stderr
    assert proc.stderr.strip() == (
        "navlog: error: seed: -1 is out of range: a seed must be an integer from 0 to 4294967295"
    )
    assert "Traceback" not in proc.stderr
    assert list(tmp_path.iterdir()) == []


def test_replay_refuses_a_bound_before_running_with_check_configs_message(teleop_log, tmp_path):
    nav2 = tmp_path / "fast.yaml"
    text = Path("config/nav2/nav_go2.yaml").read_text()
    nav2.write_text(text.replace("controller_frequency: 20.0", "controller_frequency: 20000.0", 1))
    checked = subprocess.run([*NAVLOG, "check-config", str(nav2)], capture_output=True, text=True, timeout=120)
    assert checked.returncode == 1
    line = next(x for x in checked.stdout.splitlines() if "controller_frequency" in x)
    assert line.endswith(
        "controller_server.ros__parameters.controller_frequency: 20000.0 is out of range: must be <= 1000.0"
    )
    out = tmp_path / "out"
    proc = subprocess.run(
        [*NAVLOG, "replay", str(teleop_log), "--pipeline", "navigation", "-o", str(out)]
        + ["--set", f"nav2_params={nav2}", "--no-metrics"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    assert str(nav2) in proc.stderr and line in proc.stderr
    assert not out.exists()


def test_replay_refuses_a_map_period_that_would_hang(teleop_log, tmp_path):
    out = tmp_path / "out"
    proc = subprocess.run(
        [*NAVLOG, "replay", str(teleop_log), "--pipeline", "mapping", "-o", str(out)]
        + ["--set", "occupancy.publish_period=0.000001", "--no-metrics"],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 2, proc.stderr
    assert "override 'occupancy.publish_period=0.000001' (over " in proc.stderr, proc.stderr
    assert proc.stderr.strip().endswith(
        "mapping.yaml): occupancy.publish_period: 1e-06 is out of range: must be >= 0.05"
    ), proc.stderr
    assert not out.exists()


# -- the largest accepted values finish (no timing asserted: a hang is what the time-outs catch)


def test_the_smallest_accepted_map_period_finishes(teleop_log, tmp_path):
    out = tmp_path / "out"
    proc = subprocess.run(
        [*NAVLOG, "replay", str(teleop_log), "--pipeline", "mapping", "-o", str(out)]
        + ["--set", f"occupancy.publish_period={limits.MIN_MAP_PERIOD_S}", "--no-metrics", "-q"],
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert proc.returncode == 0, proc.stderr
    assert (out / "map.pgm").is_file()


def test_the_largest_accepted_dwb_and_monitor_sizes_are_computed():
    side = int(round(limits.MAX_DWB_SAMPLES ** (1 / 3)))  # 46 x 46 x 46 = 97,336 within the budget
    p = DWBParams(
        vx_samples=side,
        vy_samples=side,
        vtheta_samples=side,
        min_vel_x=-0.5,
        max_vel_x=0.5,
        min_vel_y=-0.3,
        max_vel_y=0.3,
        max_vel_theta=1.0,
        max_speed_xy=1.0,
        acc_lim_x=2.5,
        acc_lim_y=2.5,
        acc_lim_theta=3.2,
        decel_lim_x=-2.5,
        decel_lim_y=-2.5,
        decel_lim_theta=-3.2,
    )
    t0 = time.perf_counter()
    twists = velocity_samples(p, (0.0, 0.0, 0.0), 0.1)
    assert len(twists) >= side**3 - 1  # every combination but the zero twist
    assert time.perf_counter() - t0 < 120  # generous: a hang, not a speed, is what this catches
    poly = CollisionPolygonParams(time_before_collision=limits.MAX_SIM_TIME_S, simulation_time_step=0.006)
    assert poly.time_before_collision / poly.simulation_time_step == pytest.approx(10_000)
    with pytest.raises(ConfigError, match="simulation_time_step"):
        CollisionPolygonParams(time_before_collision=limits.MAX_SIM_TIME_S, simulation_time_step=0.005)
    assert np.isfinite(twists).all()
