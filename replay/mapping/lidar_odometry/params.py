"""The LiDAR odometry's parameters, with their defaults and their checks in one place."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

Method = Literal["point_to_plane", "gicp"]


@dataclass(frozen=True)
class LidarOdometryParams:
    """Parameters of the LiDAR odometry; distances in metres."""

    min_range: float = 0.3
    max_range: float = 30.0
    scan_voxel: float = 0.25  # scan downsampling for registration
    map_voxel: float = 0.1  # local map resolution
    method: Method = "point_to_plane"
    max_correspondence: float = 0.3
    max_iterations: int = 30
    convergence: float = 1e-6  # relative fitness and RMSE change that stops ICP
    min_fitness: float = 0.3  # below it a registration is rejected and the prediction kept
    normal_radius: float = 0.3
    normal_max_nn: int = 20
    local_map_radius: float = 15.0
    local_map_max_points: int = 150_000
    keyframe_distance: float = 0.25
    keyframe_angle_deg: float = 15.0
    deskew: bool = True
    deskew_slots: int = 20
    save_voxel: float = 0.05  # global map resolution (the saved PCD)
    save_every_n_frames: int = 0  # > 0: also keep a chunk of every N frames
    min_points: int = 100  # fewer valid points after filtering: the frame is skipped
    threads: int = 1  # Open3D threads during a call; 1 keeps results bit-identical

    def __post_init__(self) -> None:
        positive = (
            "max_range",
            "scan_voxel",
            "map_voxel",
            "max_correspondence",
            "normal_radius",
            "local_map_radius",
            "save_voxel",
        )
        for name in positive:
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be positive, got {getattr(self, name)}")
        if not 0 <= self.min_range < self.max_range:
            raise ValueError(f"min_range must be in [0, max_range), got {self.min_range}")
        if self.method not in ("point_to_plane", "gicp"):
            raise ValueError(f"method must be point_to_plane or gicp, got {self.method!r}")
        for name in ("max_iterations", "normal_max_nn", "local_map_max_points", "deskew_slots", "threads"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be at least 1, got {getattr(self, name)}")
        if (
            self.save_every_n_frames < 0
            or self.min_points < 0
            or self.keyframe_distance < 0
            or self.keyframe_angle_deg < 0
        ):
            raise ValueError("save_every_n_frames, min_points and keyframe spacing must not be negative")
