"""Regulated Pure Pursuit (``nav2_regulated_pure_pursuit_controller``): its parameters (read and checked; not run yet)."""

from __future__ import annotations

from dataclasses import dataclass

from navlog.replay.nav2.plugins import PluginParams
from navlog.replay.nav2.schema import param


@dataclass(frozen=True)
class RegulatedPurePursuitParams(PluginParams):
    """``nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController`` parameters."""

    plugin: str = "nav2_regulated_pure_pursuit_controller::RegulatedPurePursuitController"
    desired_linear_vel: float = param(0.5, ge=0.0)
    lookahead_dist: float = param(0.6, gt=0.0)
    min_lookahead_dist: float = param(0.3, gt=0.0)
    max_lookahead_dist: float = param(0.9, gt=0.0)
    lookahead_time: float = param(1.5, gt=0.0)
    rotate_to_heading_angular_vel: float = param(1.8, ge=0.0)
    transform_tolerance: float = param(0.1, ge=0.0)
    use_velocity_scaled_lookahead_dist: bool = False
    min_approach_linear_velocity: float = param(0.05, ge=0.0)
    approach_velocity_scaling_dist: float = param(0.6, ge=0.0)
    use_collision_detection: bool = True
    max_allowed_time_to_collision_up_to_carrot: float = param(1.0, ge=0.0)
    use_regulated_linear_velocity_scaling: bool = True
    use_cost_regulated_linear_velocity_scaling: bool = True
    regulated_linear_scaling_min_radius: float = param(0.9, ge=0.0)
    regulated_linear_scaling_min_speed: float = param(0.25, ge=0.0)
    use_rotate_to_heading: bool = True
    allow_reversing: bool = False
    rotate_to_heading_min_angle: float = param(0.785, ge=0.0)
    max_angular_accel: float = param(3.2, gt=0.0)
    max_robot_pose_search_dist: float = -1.0
    cost_scaling_dist: float = param(0.6, ge=0.0)
    cost_scaling_gain: float = param(1.0, ge=0.0)
    inflation_cost_scaling_factor: float = param(3.0, gt=0.0)
    use_fixed_curvature_lookahead: bool = False
    curvature_lookahead_dist: float = param(0.6, gt=0.0)
    use_interpolation: bool = True
    interpolate_curvature_after_goal: bool = False
    use_cancel_deceleration: bool = False
    cancel_deceleration: float = param(3.2, ge=0.0)
