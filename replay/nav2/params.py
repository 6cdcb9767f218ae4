"""Nav2 parameter files as ROS 2 users write them, read into typed, validated configuration.

A file holds ``node: ros__parameters: {...}`` blocks (costmaps one level deeper:
``global_costmap: global_costmap: ros__parameters:``), with plugin sections named by lists such as
``plugins``, ``planner_plugins``, ``controller_plugins``, ``observation_sources`` or ``polygons``.

``load_nav2_params(path)`` never stops at the first problem: it reads everything it can into frozen
dataclasses (defaults as in Nav2 for whatever is missing or wrong) and collects every ``Problem``
with its YAML path and line: misspelled keys with a did-you-mean, unknown plugins, wrong types,
out-of-range values, parameters Nav2 renamed, and -- as notes -- what navlog reads but does not
implement. ``Nav2Params.require_valid()`` turns the errors into one ``ConfigError`` for code that
needs a working configuration; ``navlog check-config`` prints them all.

Nodes and plugins implemented (typed): global_costmap / local_costmap (static, obstacle, voxel as
2-D obstacle, inflation layers), planner_server (NavFn, Smac 2D), controller_server (Regulated Pure
Pursuit, MPPI main parameters, goal and progress checkers), velocity_smoother, collision_monitor.
Read and listed as not implemented: amcl, bt_navigator, map_server, smoother_server, behavior
servers, waypoint_follower, route_server, docking_server and the rest in ``READ_ONLY_NODES``.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import typing
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

import yaml

from navlog.errors import ConfigError
from navlog.replay.config import load_yaml, suggest

ERROR = "error"
WARNING = "warning"
NOTE = "note"


@dataclass(frozen=True)
class Problem:
    severity: str  # error | warning | note
    path: str  # YAML key path, e.g. global_costmap.global_costmap.ros__parameters.obstacle_layer
    message: str
    line: int | None = None

    def format(self, file: str = "") -> str:
        where = f"{file}:{self.line}: " if file and self.line else (f"{file}: " if file else "")
        return f"{where}{self.severity}: {self.path}: {self.message}"


def _spec(default: Any = dataclasses.MISSING, *, ge=None, gt=None, le=None, lt=None, choices=None, **kw):
    """A dataclass field with range / choice metadata used by the reader."""
    meta = {"ge": ge, "gt": gt, "le": le, "lt": lt, "choices": choices}
    if isinstance(default, (list, dict)):
        raise TypeError("use tuples for list defaults")
    return field(default=default, metadata=meta, **kw)


# ---------------------------------------------------------------- costmap


@dataclass(frozen=True)
class StaticLayerParams:
    plugin: str = "nav2_costmap_2d::StaticLayer"
    enabled: bool = True
    subscribe_to_updates: bool = False
    map_subscribe_transient_local: bool = True
    transform_tolerance: float = _spec(0.0, ge=0.0)
    map_topic: str = ""
    footprint_clearing_enabled: bool = False
    restore_cleared_footprint: bool = True
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "subscribe_to_updates",
        "map_subscribe_transient_local",
        "footprint_clearing_enabled",
        "restore_cleared_footprint",
    )


@dataclass(frozen=True)
class ObservationSourceParams:
    topic: str = ""
    sensor_frame: str = ""
    observation_persistence: float = _spec(0.0, ge=0.0)
    expected_update_rate: float = _spec(0.0, ge=0.0)
    data_type: str = _spec("PointCloud", choices=("LaserScan", "PointCloud2", "PointCloud"))
    min_obstacle_height: float = 0.0
    max_obstacle_height: float = 0.0
    inf_is_valid: bool = False
    marking: bool = True
    clearing: bool = False
    obstacle_max_range: float = _spec(2.5, ge=0.0)
    obstacle_min_range: float = _spec(0.0, ge=0.0)
    raytrace_max_range: float = _spec(3.0, ge=0.0)
    raytrace_min_range: float = _spec(0.0, ge=0.0)
    clear_after_reading: bool = False
    transport_type: str = "raw"
    READ_ONLY: ClassVar[tuple[str, ...]] = ("expected_update_rate", "transport_type", "clear_after_reading")


@dataclass(frozen=True)
class ObstacleLayerParams:
    plugin: str = "nav2_costmap_2d::ObstacleLayer"
    enabled: bool = True
    footprint_clearing_enabled: bool = True
    min_obstacle_height: float = 0.0
    max_obstacle_height: float = 2.0
    combination_method: int = _spec(1, ge=0, le=2)
    observation_sources: tuple[str, ...] = ()
    sources: dict[str, ObservationSourceParams] = field(default_factory=dict)
    # VoxelLayer parameters: read; the voxel layer runs as a 2-D obstacle layer whose height range
    # is capped at origin_z + z_resolution * z_voxels.
    publish_voxel_map: bool = False
    origin_z: float = 0.0
    z_resolution: float = _spec(0.2, gt=0.0)
    z_voxels: int = _spec(10, ge=1, le=16)
    unknown_threshold: int = _spec(15, ge=0)
    mark_threshold: int = _spec(0, ge=0)
    READ_ONLY: ClassVar[tuple[str, ...]] = ("publish_voxel_map", "unknown_threshold", "mark_threshold")
    VOXEL_ONLY: ClassVar[tuple[str, ...]] = (
        "publish_voxel_map",
        "origin_z",
        "z_resolution",
        "z_voxels",
        "unknown_threshold",
        "mark_threshold",
    )

    @property
    def is_voxel(self) -> bool:
        return self.plugin == "nav2_costmap_2d::VoxelLayer"


@dataclass(frozen=True)
class InflationLayerParams:
    plugin: str = "nav2_costmap_2d::InflationLayer"
    enabled: bool = True
    inflation_radius: float = _spec(0.55, ge=0.0)
    cost_scaling_factor: float = _spec(10.0, ge=0.0)
    inflate_unknown: bool = False
    inflate_around_unknown: bool = False


LayerParams = typing.Union[StaticLayerParams, ObstacleLayerParams, InflationLayerParams]


@dataclass(frozen=True)
class CostmapParams:
    global_frame: str = "map"
    robot_base_frame: str = "base_link"
    transform_tolerance: float = _spec(0.3, ge=0.0)
    update_frequency: float = _spec(5.0, gt=0.0)
    publish_frequency: float = _spec(1.0, ge=0.0)
    width: int = _spec(5, gt=0)
    height: int = _spec(5, gt=0)
    resolution: float = _spec(0.1, gt=0.0)
    origin_x: float = 0.0
    origin_y: float = 0.0
    rolling_window: bool = False
    track_unknown_space: bool = False
    trinary_costmap: bool = True
    lethal_cost_threshold: int = _spec(100, ge=0, le=100)
    unknown_cost_value: int = _spec(255, ge=0, le=255)
    use_maximum: bool = False
    footprint: str = "[]"
    robot_radius: float = _spec(0.1, ge=0.0)
    footprint_padding: float = _spec(0.01, ge=0.0)
    plugins: tuple[str, ...] = ("static_layer", "obstacle_layer", "inflation_layer")
    filters: tuple[str, ...] = ()
    always_send_full_costmap: bool = False
    map_topic: str = "map"
    use_sim_time: bool = False
    layers: dict[str, LayerParams] = field(default_factory=dict)
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "always_send_full_costmap",
        "filters",
        "use_sim_time",
        "footprint_topic",
        "initial_transform_timeout",
        "map_vis_z",
        "clearable_layers",
        "subscribe_to_stamped_footprint",
        "introspection_mode",
        "service_introspection_mode",
        "map_subscribe_transient_local",
    )

    def footprint_points(self) -> list[tuple[float, float]]:
        """The footprint polygon (unpadded); empty when robot_radius is used."""
        return parse_footprint(self.footprint)


def parse_footprint(text: str) -> list[tuple[float, float]]:
    """Nav2's footprint string '[[x, y], ...]' as points ('[]' -> [])."""
    try:
        value = yaml.safe_load(text) if text.strip() else []
    except yaml.YAMLError:
        raise ValueError(f"footprint {text!r} is not of the form [[x, y], [x, y], ...]") from None
    if value in (None, []):
        return []
    if (
        not isinstance(value, list)
        or len(value) < 3
        or any(not isinstance(p, list) or len(p) != 2 for p in value)
        or any(isinstance(v, bool) or not isinstance(v, (int, float)) for p in value for v in p)
    ):
        raise ValueError(f"footprint {text!r} must be '[]' or at least 3 points [[x, y], [x, y], ...]")
    return [(float(p[0]), float(p[1])) for p in value]


# ---------------------------------------------------------------- planners


@dataclass(frozen=True)
class NavfnParams:
    plugin: str = "nav2_navfn_planner::NavfnPlanner"
    tolerance: float = _spec(0.5, ge=0.0)
    use_astar: bool = False
    allow_unknown: bool = True
    use_final_approach_orientation: bool = False


@dataclass(frozen=True)
class Smac2DParams:
    plugin: str = "nav2_smac_planner::SmacPlanner2D"
    tolerance: float = _spec(0.125, ge=0.0)
    downsample_costmap: bool = False
    downsampling_factor: int = _spec(1, ge=1)
    allow_unknown: bool = True
    max_iterations: int = 1000000
    max_on_approach_iterations: int = 1000
    max_planning_time: float = _spec(2.0, gt=0.0)
    cost_travel_multiplier: float = _spec(2.0, ge=0.0)
    use_final_approach_orientation: bool = False
    terminal_checking_interval: int = _spec(5000, ge=1)
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "downsample_costmap",
        "downsampling_factor",
        "max_planning_time",
        "terminal_checking_interval",
        "smoother",
    )


PlannerParams = typing.Union[NavfnParams, Smac2DParams]


@dataclass(frozen=True)
class PlannerServerParams:
    expected_planner_frequency: float = _spec(1.0, ge=0.0)
    planner_plugins: tuple[str, ...] = ("GridBased",)
    costmap_update_timeout: float = _spec(1.0, ge=0.0)
    use_sim_time: bool = False
    planners: dict[str, PlannerParams] = field(default_factory=dict)
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "expected_planner_frequency",
        "costmap_update_timeout",
        "use_sim_time",
        "introspection_mode",
    )


# ---------------------------------------------------------------- controller server


@dataclass(frozen=True)
class GoalCheckerParams:
    plugin: str = "nav2_controller::SimpleGoalChecker"
    xy_goal_tolerance: float = _spec(0.25, ge=0.0)
    yaw_goal_tolerance: float = _spec(0.25, ge=0.0)
    stateful: bool = True
    trans_stopped_velocity: float = _spec(0.25, ge=0.0)
    rot_stopped_velocity: float = _spec(0.25, ge=0.0)


@dataclass(frozen=True)
class ProgressCheckerParams:
    plugin: str = "nav2_controller::SimpleProgressChecker"
    required_movement_radius: float = _spec(0.5, ge=0.0)
    movement_time_allowance: float = _spec(10.0, ge=0.0)
    required_movement_angle: float = _spec(0.5, ge=0.0)


@dataclass(frozen=True)
class RegulatedPurePursuitParams:
    plugin: str = "nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController"
    desired_linear_vel: float = _spec(0.5, ge=0.0)
    lookahead_dist: float = _spec(0.6, gt=0.0)
    min_lookahead_dist: float = _spec(0.3, gt=0.0)
    max_lookahead_dist: float = _spec(0.9, gt=0.0)
    lookahead_time: float = _spec(1.5, gt=0.0)
    rotate_to_heading_angular_vel: float = _spec(1.8, ge=0.0)
    transform_tolerance: float = _spec(0.1, ge=0.0)
    use_velocity_scaled_lookahead_dist: bool = False
    min_approach_linear_velocity: float = _spec(0.05, ge=0.0)
    approach_velocity_scaling_dist: float = _spec(0.6, ge=0.0)
    use_collision_detection: bool = True
    max_allowed_time_to_collision_up_to_carrot: float = _spec(1.0, ge=0.0)
    use_regulated_linear_velocity_scaling: bool = True
    use_cost_regulated_linear_velocity_scaling: bool = True
    regulated_linear_scaling_min_radius: float = _spec(0.9, ge=0.0)
    regulated_linear_scaling_min_speed: float = _spec(0.25, ge=0.0)
    use_rotate_to_heading: bool = True
    allow_reversing: bool = False
    rotate_to_heading_min_angle: float = _spec(0.785, ge=0.0)
    max_angular_accel: float = _spec(3.2, gt=0.0)
    max_robot_pose_search_dist: float = -1.0
    cost_scaling_dist: float = _spec(0.6, ge=0.0)
    cost_scaling_gain: float = _spec(1.0, ge=0.0)
    inflation_cost_scaling_factor: float = _spec(3.0, gt=0.0)
    use_fixed_curvature_lookahead: bool = False
    curvature_lookahead_dist: float = _spec(0.6, gt=0.0)
    use_interpolation: bool = True
    interpolate_curvature_after_goal: bool = False
    use_cancel_deceleration: bool = False
    cancel_deceleration: float = _spec(3.2, ge=0.0)


@dataclass(frozen=True)
class MPPIParams:
    plugin: str = "nav2_mppi_controller::MPPIController"
    time_steps: int = _spec(56, ge=1)
    model_dt: float = _spec(0.05, gt=0.0)
    batch_size: int = _spec(1000, ge=1)
    ax_max: float = _spec(3.0, ge=0.0)
    ax_min: float = _spec(-3.0, le=0.0)
    ay_max: float = _spec(3.0, ge=0.0)
    ay_min: float = _spec(-3.0, le=0.0)
    az_max: float = _spec(3.5, ge=0.0)
    vx_std: float = _spec(0.2, ge=0.0)
    vy_std: float = _spec(0.2, ge=0.0)
    wz_std: float = _spec(0.2, ge=0.0)
    vx_max: float = _spec(0.5, ge=0.0)
    vx_min: float = _spec(-0.35, le=0.0)
    vy_max: float = _spec(0.5, ge=0.0)
    wz_max: float = _spec(1.9, ge=0.0)
    iteration_count: int = _spec(1, ge=1)
    prune_distance: float = _spec(1.7, gt=0.0)
    transform_tolerance: float = _spec(0.1, ge=0.0)
    temperature: float = _spec(0.3, gt=0.0)
    gamma: float = _spec(0.015, ge=0.0)
    motion_model: str = _spec("DiffDrive", choices=("DiffDrive", "Omni", "Ackermann"))
    visualize: bool = False
    regenerate_noises: bool = False
    retry_attempt_limit: int = _spec(1, ge=0)
    enforce_path_inversion: bool = False
    critics: tuple[str, ...] = ()
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "visualize",
        "regenerate_noises",
        "retry_attempt_limit",
        "enforce_path_inversion",
        "publish_optimal_trajectory",
        "publish_critics_stats",
        "inversion_xy_tolerance",
        "inversion_yaw_tolerance",
        "shift_control_sequence",
        "open_loop",
    )


ControllerParams = typing.Union[RegulatedPurePursuitParams, MPPIParams]


@dataclass(frozen=True)
class ControllerServerParams:
    controller_frequency: float = _spec(20.0, gt=0.0)
    costmap_update_timeout: float = _spec(0.3, ge=0.0)
    min_x_velocity_threshold: float = _spec(0.0001, ge=0.0)
    min_y_velocity_threshold: float = _spec(0.0001, ge=0.0)
    min_theta_velocity_threshold: float = _spec(0.0001, ge=0.0)
    failure_tolerance: float = 0.0
    progress_checker_plugins: tuple[str, ...] = ("progress_checker",)
    goal_checker_plugins: tuple[str, ...] = ("goal_checker",)
    controller_plugins: tuple[str, ...] = ("FollowPath",)
    use_realtime_priority: bool = False
    odom_topic: str = "odom"
    speed_limit_topic: str = "speed_limit"
    enable_stamped_cmd_vel: bool = False
    use_sim_time: bool = False
    controllers: dict[str, ControllerParams] = field(default_factory=dict)
    goal_checkers: dict[str, GoalCheckerParams] = field(default_factory=dict)
    progress_checkers: dict[str, ProgressCheckerParams] = field(default_factory=dict)
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "costmap_update_timeout",
        "use_realtime_priority",
        "speed_limit_topic",
        "enable_stamped_cmd_vel",
        "use_sim_time",
        "failure_tolerance",
        "publish_zero_velocity",
        "introspection_mode",
    )


# ---------------------------------------------------------------- velocity smoother, collision monitor


@dataclass(frozen=True)
class VelocitySmootherParams:
    smoothing_frequency: float = _spec(20.0, gt=0.0)
    feedback: str = _spec("OPEN_LOOP", choices=("OPEN_LOOP", "CLOSED_LOOP"))
    scale_velocities: bool = False
    max_velocity: tuple[float, ...] = (0.5, 0.0, 2.5)
    min_velocity: tuple[float, ...] = (-0.5, 0.0, -2.5)
    max_accel: tuple[float, ...] = (2.5, 0.0, 3.2)
    max_decel: tuple[float, ...] = (-2.5, 0.0, -3.2)
    deadband_velocity: tuple[float, ...] = (0.0, 0.0, 0.0)
    velocity_timeout: float = _spec(1.0, ge=0.0)
    odom_topic: str = "odom"
    odom_duration: float = _spec(0.1, gt=0.0)
    use_realtime_priority: bool = False
    enable_stamped_cmd_vel: bool = False
    stamp_smoothed_velocity_with_smoothing_time: bool = False
    use_sim_time: bool = False
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "use_realtime_priority",
        "enable_stamped_cmd_vel",
        "stamp_smoothed_velocity_with_smoothing_time",
        "use_sim_time",
    )


@dataclass(frozen=True)
class CollisionPolygonParams:
    type: str = _spec("polygon", choices=("polygon", "circle", "velocity_polygon"))
    points: str = ""
    radius: float = _spec(0.0, ge=0.0)
    footprint_topic: str = ""
    action_type: str = _spec("stop", choices=("stop", "slowdown", "limit", "approach", "none"))
    min_points: int = _spec(4, ge=1)
    slowdown_ratio: float = _spec(0.5, ge=0.0, le=1.0)
    linear_limit: float = _spec(0.5, ge=0.0)
    angular_limit: float = _spec(0.5, ge=0.0)
    time_before_collision: float = _spec(2.0, gt=0.0)
    simulation_time_step: float = _spec(0.1, gt=0.0)
    visualize: bool = False
    polygon_pub_topic: str = ""
    polygon_sub_topic: str = ""
    enabled: bool = True
    sources_names: tuple[str, ...] = ()
    READ_ONLY: ClassVar[tuple[str, ...]] = ("visualize", "polygon_pub_topic", "polygon_sub_topic", "max_points")

    def point_list(self) -> list[tuple[float, float]]:
        return parse_footprint(self.points) if self.points else []


@dataclass(frozen=True)
class CollisionSourceParams:
    type: str = _spec("scan", choices=("scan", "pointcloud", "range", "polygon", "costmap"))
    topic: str = ""
    min_height: float = 0.05
    max_height: float = 0.5
    enabled: bool = True
    source_timeout: float = _spec(-1.0)
    transport_type: str = "raw"
    use_global_height: bool = False
    obstacles_angle: float = _spec(math.pi / 180.0, ge=0.0)
    sampling_distance: float = _spec(0.1, gt=0.0)
    READ_ONLY: ClassVar[tuple[str, ...]] = ("transport_type", "use_global_height")


@dataclass(frozen=True)
class CollisionMonitorParams:
    base_frame_id: str = "base_footprint"
    odom_frame_id: str = "odom"
    cmd_vel_in_topic: str = "cmd_vel_smoothed"
    cmd_vel_out_topic: str = "cmd_vel"
    state_topic: str = ""
    transform_tolerance: float = _spec(0.1, ge=0.0)
    source_timeout: float = _spec(2.0, ge=0.0)
    base_shift_correction: bool = True
    stop_pub_timeout: float = _spec(1.0, ge=0.0)
    polygons: tuple[str, ...] = ()
    observation_sources: tuple[str, ...] = ()
    use_realtime_priority: bool = False
    enable_stamped_cmd_vel: bool = False
    use_sim_time: bool = False
    polygon_params: dict[str, CollisionPolygonParams] = field(default_factory=dict)
    source_params: dict[str, CollisionSourceParams] = field(default_factory=dict)
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "state_topic",
        "use_realtime_priority",
        "enable_stamped_cmd_vel",
        "use_sim_time",
    )


# ---------------------------------------------------------------- plugin registry

COSTMAP_LAYERS: dict[str, type | None] = {
    "nav2_costmap_2d::StaticLayer": StaticLayerParams,
    "nav2_costmap_2d::ObstacleLayer": ObstacleLayerParams,
    "nav2_costmap_2d::VoxelLayer": ObstacleLayerParams,
    "nav2_costmap_2d::InflationLayer": InflationLayerParams,
    # known to Nav2, read but not implemented
    "nav2_costmap_2d::RangeSensorLayer": None,
    "nav2_costmap_2d::DenoiseLayer": None,
    "nav2_costmap_2d::PluginContainerLayer": None,
    "nav2_costmap_2d::KeepoutFilter": None,
    "nav2_costmap_2d::SpeedFilter": None,
    "nav2_costmap_2d::BinaryFilter": None,
    "spatio_temporal_voxel_layer/SpatioTemporalVoxelLayer": None,
}
PLANNERS: dict[str, type | None] = {
    "nav2_navfn_planner::NavfnPlanner": NavfnParams,
    "nav2_smac_planner::SmacPlanner2D": Smac2DParams,
    "nav2_smac_planner::SmacPlannerHybrid": None,
    "nav2_smac_planner::SmacPlannerLattice": None,
    "nav2_theta_star_planner::ThetaStarPlanner": None,
}
CONTROLLERS: dict[str, type | None] = {
    "nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController": RegulatedPurePursuitParams,
    "nav2_mppi_controller::MPPIController": MPPIParams,
    "dwb_core::DWBLocalPlanner": None,
    "nav2_rotation_shim_controller::RotationShimController": None,
    "nav2_graceful_controller::GracefulController": None,
}
GOAL_CHECKERS = ("nav2_controller::SimpleGoalChecker", "nav2_controller::StoppedGoalChecker")
PROGRESS_CHECKERS = ("nav2_controller::SimpleProgressChecker", "nav2_controller::PoseProgressChecker")

# Parameters Nav2 renamed: old name -> new name. Nav2 ignores the old one silently.
RENAMED = {
    "raytrace_range": "raytrace_max_range",
    "obstacle_range": "obstacle_max_range",
    "max_obstacle_range": "obstacle_max_range",
    "min_obstacle_range": "obstacle_min_range",
    "max_raytrace_range": "raytrace_max_range",
    "min_raytrace_range": "raytrace_min_range",
    "progress_checker_plugin": "progress_checker_plugins",
    "max_points": "min_points",
}

IMPLEMENTED_NODES = (
    "global_costmap",
    "local_costmap",
    "planner_server",
    "controller_server",
    "velocity_smoother",
    "collision_monitor",
)
READ_ONLY_NODES = (
    "amcl",
    "bt_navigator",
    "map_server",
    "map_saver",
    "smoother_server",
    "behavior_server",
    "recoveries_server",
    "waypoint_follower",
    "route_server",
    "docking_server",
    "loopback_simulator",
    "robot_state_publisher",
    "lifecycle_manager",
    "lifecycle_manager_navigation",
    "lifecycle_manager_localization",
    "slam_toolbox",
    "collision_detector",
    "opennav_docking",
    "amcl_map_client",
    "amcl_rclcpp_node",
    "bt_navigator_rclcpp_node",
    "controller_server_rclcpp_node",
    "planner_server_rclcpp_node",
    "bt_navigator_navigate_to_pose_rclcpp_node",
    "bt_navigator_navigate_through_poses_rclcpp_node",
    "local_costmap_client",
    "local_costmap_rclcpp_node",
    "global_costmap_client",
    "global_costmap_rclcpp_node",
    "route_server_rclcpp_node",
    "/**",
)


def normalize_plugin(name: str) -> str:
    """'pkg/Class' (Humble and older) -> 'pkg::Class'."""
    return (
        name.replace("/", "::") if "::" not in name and name.count("/") == 1 and not name.startswith("spatio") else name
    )


# ---------------------------------------------------------------- reading


class _Reader:
    """Collects problems while reading sections into dataclasses."""

    def __init__(self, lines: dict[tuple, int]) -> None:
        self.problems: list[Problem] = []
        self.lines = lines

    def add(self, severity: str, path: tuple, message: str) -> None:
        line = None
        for n in range(len(path), 0, -1):
            line = self.lines.get(tuple(path[:n]))
            if line is not None:
                break
        self.problems.append(Problem(severity, ".".join(str(p) for p in path), message, line))

    # -- values
    def convert(self, value: Any, tp: Any, path: tuple, meta: dict) -> tuple[bool, Any]:
        name = path[-1]
        origin = typing.get_origin(tp)
        ok, out = True, value
        if tp is bool:
            ok = isinstance(value, bool)
            expected = "true or false"
        elif tp is int:
            ok = isinstance(value, int) and not isinstance(value, bool)
            expected = "an integer"
        elif tp is float:
            ok = isinstance(value, (int, float)) and not isinstance(value, bool)
            out = float(value) if ok else value
            expected = "a number"
        elif tp is str:
            ok = isinstance(value, str)
            expected = "a string"
            if name in ("footprint", "points") and isinstance(value, list):
                # Humble's collision monitor `points` is a flat list [x1, y1, x2, y2, ...]
                if (
                    name == "points"
                    and value
                    and all(isinstance(v, (int, float)) for v in value)
                    and len(value) % 2 == 0
                ):
                    return True, str([[float(value[i]), float(value[i + 1])] for i in range(0, len(value), 2)])
                self.add(
                    ERROR,
                    path,
                    'expected a string like "[[0.2, 0.2], [0.2, -0.2], ...]", got a list '
                    "(ROS 2 parameters cannot hold nested lists: quote it)",
                )
                return False, None
        elif origin is tuple and typing.get_args(tp)[0] is str:
            if isinstance(value, str):  # costmap observation_sources: "scan cloud"
                return True, tuple(value.split())
            ok = isinstance(value, list) and all(isinstance(v, str) for v in value)
            out = tuple(value) if ok else value
            expected = "a list of strings"
        elif origin is tuple:
            ok = isinstance(value, list) and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
            out = tuple(float(v) for v in value) if ok else value
            expected = "a list of numbers"
        else:
            return True, value
        if not ok:
            self.add(ERROR, path, f"expected {expected}, got {value!r}; Nav2 would refuse it (default used)")
            return False, None
        if isinstance(out, (int, float)) and not isinstance(out, bool):
            for key, test, word in (
                ("ge", lambda v, b: v >= b, ">="),
                ("gt", lambda v, b: v > b, ">"),
                ("le", lambda v, b: v <= b, "<="),
                ("lt", lambda v, b: v < b, "<"),
            ):
                bound = meta.get(key)
                if bound is not None and not test(out, bound):
                    self.add(ERROR, path, f"{out} is out of range: must be {word} {bound}")
                    return False, None
        choices = meta.get("choices")
        if choices and out not in choices:
            self.add(ERROR, path, f"{out!r} is not one of {', '.join(choices)}{suggest(str(out), choices)}")
            return False, None
        return True, out

    def read(
        self,
        cls: type,
        data: Any,
        path: tuple,
        *,
        sections: tuple[str, ...] = (),
        extra: dict | None = None,
        skip: tuple[str, ...] = (),
    ) -> Any:
        """Build ``cls`` from mapping ``data``; ``sections`` are sub-mapping names the caller handles."""
        if data is None:
            data = {}
        if not isinstance(data, dict):
            self.add(ERROR, path, f"expected a mapping of parameters, got {data!r}")
            data = {}
        hints = typing.get_type_hints(cls)
        fields = {f.name: f for f in dataclasses.fields(cls) if f.init and typing.get_origin(hints[f.name]) is not dict}
        read_only = set(getattr(cls, "READ_ONLY", ()))
        kwargs: dict[str, Any] = {}
        for key, value in data.items():
            kpath = path + (key,)
            key = str(key)
            if key in sections or key in skip:
                continue
            if key in fields:
                ok, out = self.convert(value, hints[key], kpath, fields[key].metadata)
                if ok:
                    kwargs[key] = out
                if key in read_only:
                    self.add(NOTE, kpath, "read, not implemented by navlog")
                continue
            if key in read_only:
                self.add(NOTE, kpath, "read, not implemented by navlog")
                continue
            self.unknown_key(key, kpath, list(fields) + list(sections), is_section=isinstance(value, dict))
        if extra:
            kwargs.update(extra)
        try:
            return cls(**kwargs)
        except (TypeError, ValueError) as exc:  # pragma: no cover - dataclass defaults always fit
            self.add(ERROR, path, str(exc))
            return cls()

    def unknown_key(self, key: str, kpath: tuple, known: list[str], is_section: bool = False) -> None:
        if key in RENAMED:
            self.add(ERROR, kpath, f"'{key}' was renamed to '{RENAMED[key]}' in Nav2; the old name is ignored")
            return
        hint = suggest(key, known)
        what = "section" if is_section else "parameter"
        if hint:
            self.add(ERROR, kpath, f"unknown {what} '{key}'{hint}; Nav2 would ignore it silently")
        else:
            self.add(WARNING, kpath, f"unknown {what} '{key}': Nav2 does not declare it and ignores it")


def _line_map(text: str) -> dict[tuple, int]:
    """YAML key path -> 1-based line of the key."""
    lines: dict[tuple, int] = {}
    try:
        root = yaml.compose(text)
    except yaml.YAMLError:
        return lines

    def walk(node, path):
        if isinstance(node, yaml.MappingNode):
            for k, v in node.value:
                p = path + (k.value,)
                lines.setdefault(p, k.start_mark.line + 1)
                walk(v, p)

    walk(root, ())
    return lines


@dataclass(frozen=True)
class Nav2Params:
    """Everything read from one Nav2 parameter file."""

    source: str
    raw: dict
    global_costmap: CostmapParams | None = None
    local_costmap: CostmapParams | None = None
    planner_server: PlannerServerParams | None = None
    controller_server: ControllerServerParams | None = None
    velocity_smoother: VelocitySmootherParams | None = None
    collision_monitor: CollisionMonitorParams | None = None
    not_implemented: tuple[str, ...] = ()  # node blocks read but not implemented
    problems: tuple[Problem, ...] = ()

    @property
    def errors(self) -> list[Problem]:
        return [p for p in self.problems if p.severity == ERROR]

    @property
    def warnings(self) -> list[Problem]:
        return [p for p in self.problems if p.severity == WARNING]

    def require_valid(self, prefixes: typing.Sequence[str] = ()) -> Nav2Params:
        """Raise one ConfigError listing every error (under ``prefixes`` if given)."""
        errors = [p for p in self.errors if not prefixes or any(p.path.startswith(x) for x in prefixes)]
        if errors:
            lines = "\n  ".join(p.format(self.source) for p in errors)
            raise ConfigError(
                f"{self.source}: {len(errors)} error(s) in the Nav2 parameters "
                f"(run `navlog check-config {self.source}`):\n  {lines}"
            )
        return self


def load_nav2_params(path: str | Path, overrides: typing.Sequence[str] = ()) -> Nav2Params:
    """Read a Nav2 parameter file (YAML syntax errors raise ConfigError with the line)."""
    path = Path(path)
    doc = load_yaml(path)
    text = path.read_text()
    if overrides:
        doc = apply_nav2_overrides(doc if isinstance(doc, dict) else {}, overrides, source=str(path))
    return parse_nav2_params(doc, source=str(path), lines=_line_map(text))


def parse_nav2_text(text: str, source: str = "<string>") -> Nav2Params:
    try:
        doc = yaml.safe_load(text)
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        where = f" line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        raise ConfigError(f"{source}:{where}: malformed YAML: {getattr(exc, 'problem', exc)}") from None
    return parse_nav2_params(doc, source=source, lines=_line_map(text))


def _ros_params(r: _Reader, node_block: Any, path: tuple) -> dict | None:
    if not isinstance(node_block, dict):
        r.add(ERROR, path, f"expected a mapping with 'ros__parameters', got {node_block!r}")
        return None
    if "ros__parameters" not in node_block:
        others = [k for k in node_block if isinstance(k, str)]
        close = [k for k in others if suggest(k, ["ros__parameters"])]
        if close:
            r.add(
                ERROR,
                path + (close[0],),
                f"'{close[0]}' should be 'ros__parameters' (two underscores): ROS 2 ignores the whole block",
            )
        else:
            r.add(ERROR, path, "no 'ros__parameters' mapping: ROS 2 would not read these parameters")
        return None
    params = node_block["ros__parameters"]
    if params is None:
        return {}
    if not isinstance(params, dict):
        r.add(ERROR, path + ("ros__parameters",), f"expected a mapping, got {params!r}")
        return None
    return params


def parse_nav2_params(doc: Any, source: str = "<string>", lines: dict | None = None) -> Nav2Params:
    r = _Reader(lines or {})
    if doc is None:
        doc = {}
    if not isinstance(doc, dict):
        raise ConfigError(f"{source}: a Nav2 parameter file is a mapping of node names, got {type(doc).__name__}")
    out: dict[str, Any] = {}
    read_only: list[str] = []
    for node, block in doc.items():
        node = str(node)
        path = (node,)
        if node in ("global_costmap", "local_costmap"):
            if isinstance(block, dict) and "ros__parameters" in block:
                params = _ros_params(r, block, path)
                cpath = path + ("ros__parameters",)
            else:
                inner = block.get(node) if isinstance(block, dict) else None
                if isinstance(block, dict):
                    for other in block:
                        if (
                            other != node
                            and other not in READ_ONLY_NODES
                            and not str(other).endswith(("_client", "_rclcpp_node"))
                        ):
                            r.unknown_key(str(other), path + (other,), [node], is_section=True)
                if inner is None:
                    r.add(
                        ERROR,
                        path,
                        f"expected '{node}: {node}: ros__parameters:' (the costmap node lives in the "
                        f"'{node}' namespace)",
                    )
                    continue
                params = _ros_params(r, inner, path + (node,))
                cpath = path + (node, "ros__parameters")
            if params is not None:
                out[node] = _read_costmap(r, params, cpath)
        elif node == "planner_server":
            params = _ros_params(r, block, path)
            if params is not None:
                out[node] = _read_planner_server(r, params, path + ("ros__parameters",))
        elif node == "controller_server":
            params = _ros_params(r, block, path)
            if params is not None:
                out[node] = _read_controller_server(r, params, path + ("ros__parameters",))
        elif node == "velocity_smoother":
            params = _ros_params(r, block, path)
            if params is not None:
                out[node] = _read_velocity_smoother(r, params, path + ("ros__parameters",))
        elif node == "collision_monitor":
            params = _ros_params(r, block, path)
            if params is not None:
                out[node] = _read_collision_monitor(r, params, path + ("ros__parameters",))
        elif node in READ_ONLY_NODES or node.endswith(("_rclcpp_node", "_client")):
            read_only.append(node)
            r.add(NOTE, path, "read, not implemented by navlog (parameters not checked)")
        else:
            hint = suggest(node, IMPLEMENTED_NODES + READ_ONLY_NODES)
            if hint:
                r.add(ERROR, path, f"unknown node '{node}'{hint}; Nav2 would never read this block")
            else:
                read_only.append(node)
                r.add(WARNING, path, f"node '{node}' is not a Nav2 node navlog knows (parameters not checked)")
    return Nav2Params(
        source=source,
        raw=doc,
        not_implemented=tuple(read_only),
        problems=tuple(r.problems),
        **out,
    )


# -- per node


def _plugin_type(r: _Reader, section: Any, path: tuple, registry: dict, default: str | None, kind: str):
    """(normalized plugin type or None, params class or None, known?)."""
    ptype = section.get("plugin") if isinstance(section, dict) else None
    if ptype is None:
        if default is None:
            r.add(ERROR, path, f"{kind} has no 'plugin' parameter")
            return None, None
        ptype = default
    if not isinstance(ptype, str):
        r.add(ERROR, path + ("plugin",), f"expected a plugin name string, got {ptype!r}")
        return None, None
    norm = normalize_plugin(ptype)
    if norm not in registry:
        r.add(
            ERROR,
            path + ("plugin",),
            f"unknown {kind} plugin '{ptype}'{suggest(norm, registry)}; Nav2 fails to load it at launch",
        )
        close = difflib.get_close_matches(norm, [k for k in registry if registry[k] is not None], n=1, cutoff=0.6)
        if close:  # check the rest of the section as the plugin it was meant to be, but do not use it
            cls = registry[close[0]]
            if cls is ObstacleLayerParams:
                _read_obstacle_layer(r, section, path, close[0])
            else:
                r.read(cls, section, path, extra={"plugin": close[0]})
        return None, None
    if registry[norm] is None:
        r.add(NOTE, path + ("plugin",), f"{kind} plugin '{norm}' is read, not implemented by navlog")
        return norm, None
    return norm, registry[norm]


def _read_costmap(r: _Reader, params: dict, path: tuple) -> CostmapParams:
    plugins_value = params.get("plugins")
    plugin_names = tuple(CostmapParams.plugins)
    if isinstance(plugins_value, list) and all(isinstance(p, str) for p in plugins_value):
        plugin_names = tuple(plugins_value)
    filter_names = tuple(params.get("filters") or ()) if isinstance(params.get("filters"), list) else ()
    sections = tuple(k for k, v in params.items() if isinstance(v, dict))
    layers: dict[str, LayerParams] = {}
    for name in plugin_names:
        lpath = path + (name,)
        section = params.get(name)
        if section is None:
            default = (
                {
                    "static_layer": "nav2_costmap_2d::StaticLayer",
                    "obstacle_layer": "nav2_costmap_2d::ObstacleLayer",
                    "inflation_layer": "nav2_costmap_2d::InflationLayer",
                }.get(name)
                if "plugins" not in params
                else None
            )
            if default is None:
                r.add(
                    ERROR,
                    path + ("plugins",),
                    f"plugin '{name}' is listed but there is no '{name}:' section "
                    f"with a 'plugin' type{suggest(name, sections)}",
                )
                continue
            section = {}
        else:
            default = None
        norm, cls = _plugin_type(r, section, lpath, COSTMAP_LAYERS, default, "costmap layer")
        if cls is None:
            continue
        if cls is ObstacleLayerParams:
            layers[name] = _read_obstacle_layer(r, section, lpath, norm)
        else:
            layers[name] = r.read(cls, section, lpath, extra={"plugin": norm})
    for name in sections:
        if name in plugin_names or name in filter_names:
            continue
        r.add(WARNING, path + (name,), f"section '{name}' is not in plugins {list(plugin_names)}: Nav2 ignores it")
    cm = r.read(CostmapParams, params, path, sections=sections, extra={"layers": layers})
    try:
        fp = parse_footprint(cm.footprint)
    except ValueError as exc:
        r.add(ERROR, path + ("footprint",), str(exc))
        cm = dataclasses.replace(cm, footprint="[]")
        fp = []
    if fp and "robot_radius" in params:
        r.add(NOTE, path + ("robot_radius",), "footprint is set, so robot_radius is not used")
    # the inflation radius must reach past the inscribed radius
    from navlog.replay.nav2.costmap import footprint_radii, robot_footprint

    inscribed, _ = footprint_radii(robot_footprint(cm))
    for name, layer in layers.items():
        if isinstance(layer, InflationLayerParams) and layer.inflation_radius < inscribed:
            r.add(
                ERROR,
                path + (name, "inflation_radius"),
                f"inflation_radius {layer.inflation_radius} is below the inscribed radius {inscribed:.3f} of the "
                "padded footprint: Nav2 logs an error and the robot may plan into walls",
            )
    kinds = [type(layers[n]).__name__ for n in plugin_names if n in layers]
    if "InflationLayerParams" in kinds and kinds.index("InflationLayerParams") != len(kinds) - 1:
        r.add(WARNING, path + ("plugins",), "the inflation layer is not last: layers after it are not inflated")
    return cm


def _read_obstacle_layer(r: _Reader, section: dict, path: tuple, plugin: str) -> ObstacleLayerParams:
    voxel = plugin == "nav2_costmap_2d::VoxelLayer"
    raw_sources = section.get("observation_sources", "")
    names: tuple[str, ...] = ()
    if isinstance(raw_sources, str):
        names = tuple(raw_sources.split())
    elif isinstance(raw_sources, list) and all(isinstance(s, str) for s in raw_sources):
        names = tuple(raw_sources)
    sections = tuple(k for k, v in section.items() if isinstance(v, dict))
    sources: dict[str, ObservationSourceParams] = {}
    for name in names:
        spath = path + (name,)
        sec = section.get(name)
        if not isinstance(sec, dict):
            r.add(
                ERROR,
                path + ("observation_sources",),
                f"observation source '{name}' has no '{name}:' section{suggest(name, sections)}",
            )
            continue
        src = r.read(ObservationSourceParams, sec, spath)
        if not src.topic:
            r.add(WARNING, spath, f"no 'topic': Nav2 subscribes to '{name}'")
            src = dataclasses.replace(src, topic=name)
        if src.marking and "max_obstacle_height" not in sec:
            r.add(
                WARNING,
                spath + ("max_obstacle_height",),
                "not set: the per-source default is 0.0, so every point above z = 0 in the global frame is dropped",
            )
        if src.raytrace_max_range < src.obstacle_max_range and src.clearing:
            r.add(
                WARNING,
                spath + ("raytrace_max_range",),
                f"raytrace_max_range {src.raytrace_max_range} < obstacle_max_range {src.obstacle_max_range}: "
                "marked obstacles beyond the raytrace range are never cleared",
            )
        if src.obstacle_min_range > src.obstacle_max_range:
            r.add(ERROR, spath + ("obstacle_min_range",), "obstacle_min_range is above obstacle_max_range")
        if src.raytrace_min_range > src.raytrace_max_range:
            r.add(ERROR, spath + ("raytrace_min_range",), "raytrace_min_range is above raytrace_max_range")
        if src.data_type == "PointCloud":
            r.add(
                ERROR,
                spath + ("data_type",),
                ("is 'PointCloud'" if "data_type" in sec else "not set, so it is 'PointCloud'")
                + ": Nav2 accepts only 'LaserScan' or 'PointCloud2' and fails at launch",
            )
        sources[name] = src
    for name in sections:
        if name not in names:
            r.add(WARNING, path + (name,), f"section '{name}' is not in observation_sources: Nav2 ignores it")
    layer = r.read(
        ObstacleLayerParams,
        section,
        path,
        sections=sections,
        extra={"plugin": plugin, "sources": sources, "observation_sources": names},
    )
    if not voxel:
        for key in ObstacleLayerParams.VOXEL_ONLY:
            if key in section:
                r.add(WARNING, path + (key,), f"'{key}' is a VoxelLayer parameter; the ObstacleLayer ignores it")
    else:
        r.add(
            NOTE,
            path + ("plugin",),
            "VoxelLayer runs as a 2-D obstacle layer (height capped at "
            "origin_z + z_resolution * z_voxels); the voxel grid itself is not implemented",
        )
    return layer


def _read_plugins(r, params, path, list_key, registry, kind, default_names, default_type, target):
    names = params.get(list_key, default_names)
    if isinstance(names, str):
        names = [names]
    if not isinstance(names, (list, tuple)) or not all(isinstance(n, str) for n in names):
        return {}
    out = {}
    for name in names:
        ppath = path + (name,)
        sec = params.get(name)
        dtype = default_type if (list_key not in params or params.get(list_key) == list(default_names)) else None
        if sec is None and dtype is None:
            sections = [k for k, v in params.items() if isinstance(v, dict)]
            r.add(
                ERROR,
                path + (list_key,),
                f"{kind} '{name}' is listed but has no '{name}:' section{suggest(name, sections)}",
            )
            continue
        sec = sec if isinstance(sec, dict) else {}
        norm, cls = _plugin_type(r, sec, ppath, registry, dtype, kind)
        if cls is None:
            continue
        target_sections = tuple(k for k, v in sec.items() if isinstance(v, dict)) if cls is MPPIParams else ()
        obj = r.read(cls, sec, ppath, sections=target_sections, extra={"plugin": norm})
        if cls is MPPIParams:
            for crit in target_sections:
                if crit not in obj.critics and crit not in ("TrajectoryVisualizer", "AckermannConstraints"):
                    r.add(
                        WARNING,
                        ppath + (crit,),
                        f"section '{crit}' is not in critics: MPPI ignores it{suggest(crit, obj.critics)}",
                    )
                else:
                    r.add(NOTE, ppath + (crit,), "read, not checked")
        out[name] = obj
    return out


def _read_planner_server(r: _Reader, params: dict, path: tuple) -> PlannerServerParams:
    planners = _read_plugins(
        r, params, path, "planner_plugins", PLANNERS, "planner", ["GridBased"], "nav2_navfn_planner::NavfnPlanner", None
    )
    names = params.get("planner_plugins", ["GridBased"])
    sections = tuple(k for k, v in params.items() if isinstance(v, dict))
    for s in sections:
        if isinstance(names, list) and s not in names:
            r.add(WARNING, path + (s,), f"section '{s}' is not in planner_plugins: Nav2 ignores it")
    return r.read(PlannerServerParams, params, path, sections=sections, extra={"planners": planners})


def _read_controller_server(r: _Reader, params: dict, path: tuple) -> ControllerServerParams:
    sections = tuple(k for k, v in params.items() if isinstance(v, dict))
    controllers = _read_plugins(
        r,
        params,
        path,
        "controller_plugins",
        CONTROLLERS,
        "controller",
        ["FollowPath"],
        "dwb_core::DWBLocalPlanner",
        None,
    )
    gc_names = params.get("goal_checker_plugins", ["goal_checker"])
    pc_key = "progress_checker_plugins" if "progress_checker_plugins" in params else "progress_checker_plugin"
    pc_names = params.get(pc_key, ["progress_checker"])
    if isinstance(pc_names, str):
        pc_names = [pc_names]
    goal_checkers, progress_checkers = {}, {}
    for names, cls, registry, store, kind in (
        (gc_names, GoalCheckerParams, GOAL_CHECKERS, goal_checkers, "goal checker"),
        (pc_names, ProgressCheckerParams, PROGRESS_CHECKERS, progress_checkers, "progress checker"),
    ):
        if not isinstance(names, list):
            continue
        for name in names:
            sec = params.get(name)
            cpath = path + (name,)
            if not isinstance(sec, dict):
                r.add(ERROR, path, f"{kind} '{name}' is listed but has no '{name}:' section")
                continue
            ptype = normalize_plugin(str(sec.get("plugin", "")))
            if ptype not in registry:
                r.add(
                    ERROR, cpath + ("plugin",), f"unknown {kind} plugin '{sec.get('plugin')}'{suggest(ptype, registry)}"
                )
                continue
            store[name] = r.read(cls, sec, cpath, extra={"plugin": ptype})
    known = set(controllers) | set(goal_checkers) | set(progress_checkers)
    listed = set()
    for key in ("controller_plugins", "goal_checker_plugins", "progress_checker_plugins", "progress_checker_plugin"):
        v = params.get(key)
        listed |= set([v] if isinstance(v, str) else (v or []))
    for s in sections:
        if s not in known and s not in listed:
            r.add(WARNING, path + (s,), f"section '{s}' is not listed in any *_plugins: Nav2 ignores it")
    skip = ("progress_checker_plugin",) if pc_key == "progress_checker_plugin" else ()
    if skip:
        r.add(
            WARNING,
            path + ("progress_checker_plugin",),
            "'progress_checker_plugin' is the Humble name; Jazzy reads 'progress_checker_plugins' (a list)",
        )
    return r.read(
        ControllerServerParams,
        params,
        path,
        sections=sections,
        skip=skip,
        extra={
            "controllers": controllers,
            "goal_checkers": goal_checkers,
            "progress_checkers": progress_checkers,
            "progress_checker_plugins": tuple(pc_names) if isinstance(pc_names, list) else ("progress_checker",),
        },
    )


def _read_velocity_smoother(r: _Reader, params: dict, path: tuple) -> VelocitySmootherParams:
    vs = r.read(VelocitySmootherParams, params, path)
    keys = ("max_velocity", "min_velocity", "max_accel", "max_decel", "deadband_velocity")
    sizes = {k: len(getattr(vs, k)) for k in keys}
    for k, n in sizes.items():
        if n not in (3, 6):
            r.add(ERROR, path + (k,), f"has {n} entries: expected 3 (vx, vy, wz) or 6")
    if len(set(sizes.values())) > 1:
        r.add(ERROR, path, f"velocity vectors differ in length: {sizes}")
    axes = ("vx", "vy", "wz", "vz", "wx", "wy")
    for k, sign, word in (
        ("max_decel", -1, "<= 0"),
        ("max_accel", 1, ">= 0"),
        ("min_velocity", -1, "<= 0"),
        ("max_velocity", 1, ">= 0"),
    ):
        for i, v in enumerate(getattr(vs, k)):
            if v * sign < 0:
                r.add(
                    ERROR,
                    path + (k,),
                    f"{k}[{i}] ({axes[i] if i < 6 else i}) = {v}: must be {word}; Nav2 rejects the configuration",
                )
    return vs


def _read_collision_monitor(r: _Reader, params: dict, path: tuple) -> CollisionMonitorParams:
    sections = tuple(k for k, v in params.items() if isinstance(v, dict))
    polygons, sources = {}, {}
    poly_names = params.get("polygons", [])
    src_names = params.get("observation_sources", [])
    if isinstance(src_names, str):
        src_names = src_names.split()
    for names, cls, store, kind in (
        (poly_names, CollisionPolygonParams, polygons, "polygon"),
        (src_names, CollisionSourceParams, sources, "observation source"),
    ):
        if not isinstance(names, list):
            continue
        for name in names:
            sec = params.get(name)
            if not isinstance(sec, dict):
                r.add(
                    ERROR,
                    path + ("polygons" if kind == "polygon" else "observation_sources",),
                    f"{kind} '{name}' is listed but has no '{name}:' section{suggest(str(name), sections)}",
                )
                continue
            obj = r.read(cls, sec, path + (name,))
            if cls is CollisionPolygonParams:
                if obj.points:
                    try:
                        obj.point_list()
                    except ValueError as exc:
                        r.add(ERROR, path + (name, "points"), str(exc))
                if obj.type == "polygon" and not obj.points and not obj.footprint_topic:
                    r.add(ERROR, path + (name,), "a polygon needs 'points' or 'footprint_topic'")
                if obj.type == "circle" and obj.radius <= 0.0:
                    r.add(ERROR, path + (name, "radius"), "a circle needs a radius > 0")
            store[name] = obj
    listed = set(poly_names if isinstance(poly_names, list) else []) | set(
        src_names if isinstance(src_names, list) else []
    )
    for s in sections:
        if s not in listed:
            r.add(
                WARNING,
                path + (s,),
                f"section '{s}' is in neither polygons nor observation_sources: ignored{suggest(s, sorted(listed))}",
            )
    return r.read(
        CollisionMonitorParams,
        params,
        path,
        sections=sections,
        extra={
            "polygon_params": polygons,
            "source_params": sources,
            "observation_sources": tuple(src_names) if isinstance(src_names, list) else (),
        },
    )


# ---------------------------------------------------------------- overrides


def _leaf_paths(doc: Any, prefix: tuple = ()) -> list[tuple]:
    out = []
    if isinstance(doc, dict):
        for k, v in doc.items():
            p = prefix + (str(k),)
            out.append(p)
            out.extend(_leaf_paths(v, p))
    return out


def _is_subsequence(short: list[str], full: tuple) -> bool:
    it = iter(full)
    return all(any(part == f for f in it) for part in short)


def resolve_key(doc: dict, key: str) -> tuple:
    """The full key path for ``key``: a full Nav2 path, or a shorter unambiguous form.

    ``global_costmap.inflation_layer.inflation_radius`` finds
    ``global_costmap.global_costmap.ros__parameters.inflation_layer.inflation_radius``; the short form's
    parts must appear in order in the full path, the last part being the parameter itself.
    """
    parts = key.split(".")
    paths = _leaf_paths(doc)
    if tuple(parts) in paths:
        return tuple(parts)
    candidates = [p for p in paths if p[-1] == parts[-1] and _is_subsequence(parts, p) and p[0] == parts[0]]
    if not candidates:
        candidates = [p for p in paths if p[-1] == parts[-1] and _is_subsequence(parts, p)]
    if len(candidates) == 1:
        return candidates[0]
    if len(candidates) > 1:
        shown = ", ".join(".".join(c) for c in candidates[:6])
        raise ConfigError(
            f"--set {key}: ambiguous, it matches {len(candidates)} parameters: {shown}; give more of the path"
        )
    # a new parameter in an existing section
    sections = [p for p in paths if _is_subsequence(parts[:-1], p) and p[-1] == parts[-2]] if len(parts) > 1 else []
    sections = [s for s in sections if isinstance(_get(doc, s), dict)]
    if len(sections) == 1 and parts[-1] in _known_names():
        return sections[0] + (parts[-1],)
    names = sorted({p[-1] for p in paths} | _known_names())
    raise ConfigError(
        f"--set {key}: no such parameter{suggest(parts[-1], names)}"
        + (f"; sections matching: {', '.join('.'.join(s) for s in sections[:6])}" if sections else "")
    )


def _known_names() -> set[str]:
    """Every parameter name navlog knows (to accept --set of a parameter the file does not have)."""
    names: set[str] = set()
    for cls in (
        StaticLayerParams,
        ObservationSourceParams,
        ObstacleLayerParams,
        InflationLayerParams,
        CostmapParams,
        NavfnParams,
        Smac2DParams,
        PlannerServerParams,
        GoalCheckerParams,
        ProgressCheckerParams,
        RegulatedPurePursuitParams,
        MPPIParams,
        ControllerServerParams,
        VelocitySmootherParams,
        CollisionPolygonParams,
        CollisionSourceParams,
        CollisionMonitorParams,
    ):
        names |= {f.name for f in dataclasses.fields(cls)} | set(getattr(cls, "READ_ONLY", ()))
    return names


def _get(doc: dict, path: tuple) -> Any:
    node: Any = doc
    for p in path:
        node = node[p]
    return node


def apply_nav2_overrides(doc: dict, overrides: typing.Sequence[str], source: str = "") -> dict:
    """A copy of ``doc`` with each ``KEY=VALUE`` applied (KEY full or short, VALUE parsed as YAML)."""
    import copy

    out = copy.deepcopy(doc)
    for item in overrides:
        if "=" not in item:
            raise ConfigError(
                f"--set '{item}': expected KEY=VALUE, e.g. global_costmap.inflation_layer.inflation_radius=0.5"
            )
        key, raw = item.split("=", 1)
        try:
            value = yaml.safe_load(raw)
        except yaml.YAMLError:
            raise ConfigError(f"--set '{item}': the value is not valid YAML") from None
        path = resolve_key(out, key.strip())
        node = out
        for p in path[:-1]:
            node = node[p]
        node[path[-1]] = value
    return out
