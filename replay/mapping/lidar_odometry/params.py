"""The LiDAR odometry's parameters, with their defaults and their checks in one place, and the
presets they start from: ``indoor`` (the defaults) and ``outdoor``, or ``auto``, sized from the
first sweep the way KISS-ICP sizes its voxels from the maximum range (``for_sweep``)."""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Literal

import numpy as np

Method = Literal["vgicp", "point_to_plane", "gicp"]
METHODS = ("vgicp", "point_to_plane", "gicp")
Preset = Literal["auto", "indoor", "outdoor"]


@dataclass(frozen=True)
class LidarOdometryParams:
    """Parameters of the LiDAR odometry; distances in metres."""

    min_range: float = 0.3
    max_range: float = 30.0
    scan_voxel: float = 0.1  # scan downsampling for registration
    map_voxel: float = 0.1  # local map resolution (Open3D methods)
    # vgicp: small_gicp's voxelized GICP against an incremental Gaussian voxel map (``voxel_map.py``);
    # point_to_plane / gicp: Open3D's legacy ICP against the local map of ``local_map.py``
    method: Method = "vgicp"
    gaussian_voxel: float = 0.3  # vgicp: the Gaussian voxel map's resolution
    covariance_nn: int = 10  # vgicp: neighbours of a scan point's covariance
    # vgicp: threads of the scan's covariances and their k-d tree; each point's covariance is computed
    # on its own, so any count gives the same bits (unlike ``threads``)
    covariance_threads: int = 2
    max_correspondence: float = 0.3
    max_iterations: int = 30
    convergence: float = 1e-6  # relative fitness and RMSE change that stops ICP
    min_fitness: float = 0.3  # below it a registration is rejected and the prediction kept
    normal_radius: float = 0.3
    normal_max_nn: int = 20
    local_map_radius: float = 15.0
    local_map_max_points: int = 150_000  # Open3D methods (vgicp: voxels expire by age instead)
    keyframe_distance: float = 0.25
    keyframe_angle_deg: float = 15.0
    deskew: bool = True
    deskew_slots: int = 20
    save_voxel: float = 0.05  # global map resolution (the saved PCD)
    save_every_n_frames: int = 0  # > 0: also keep a chunk of every N frames
    min_points: int = 100  # fewer valid points after filtering: the frame is skipped
    threads: int = 1  # Open3D / small_gicp threads during a call; 1 keeps results bit-identical
    # KISS-ICP's adaptive threshold: the correspondence distance is 3 sigma of the motion model's
    # deviation from the registered poses (max_correspondence until there is a deviation to measure)
    adaptive_threshold: bool = False
    min_motion: float = 0.1  # a frame moving less than this (m) adds no deviation sample

    def __post_init__(self) -> None:
        positive = (
            "max_range",
            "scan_voxel",
            "map_voxel",
            "gaussian_voxel",
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
        if self.min_motion < 0:
            raise ValueError(f"min_motion must not be negative, got {self.min_motion}")
        if self.method not in METHODS:
            raise ValueError(f"method must be one of {', '.join(METHODS)}, got {self.method!r}")
        for name in (
            "max_iterations",
            "normal_max_nn",
            "covariance_nn",
            "covariance_threads",
            "local_map_max_points",
            "deskew_slots",
            "threads",
        ):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be at least 1, got {getattr(self, name)}")
        if (
            self.save_every_n_frames < 0
            or self.min_points < 0
            or self.keyframe_distance < 0
            or self.keyframe_angle_deg < 0
        ):
            raise ValueError("save_every_n_frames, min_points and keyframe spacing must not be negative")


_NO_LIDAR_REACHES = 1000.0  # m: a return further away is a corrupt coordinate
MAX_AUTO_RANGE = 200.0  # the largest range ``auto`` adapts to


def scaled(params: LidarOdometryParams, max_range: float) -> LidarOdometryParams:
    """``params`` sized for a sensor seeing ``max_range`` metres: voxel ``max_range / 100`` (KISS-ICP's
    rule) for the scan filter and the Gaussian voxel map, half of it for the Open3D local map, a
    fifth for the saved map, the local map as wide as the range, and the adaptive correspondence
    threshold from twice the voxel."""
    voxel = max_range / 100.0
    return replace(
        params,
        max_range=max_range,
        scan_voxel=voxel,
        map_voxel=voxel / 2,
        gaussian_voxel=voxel,
        normal_radius=1.5 * voxel,
        max_correspondence=2.0 * voxel,
        local_map_radius=max_range,
        local_map_max_points=max(params.local_map_max_points, 400_000),
        keyframe_distance=max(params.keyframe_distance, voxel),
        save_voxel=max(params.save_voxel, voxel / 5),
        adaptive_threshold=True,
    )


def preset(params: LidarOdometryParams, name: Preset) -> LidarOdometryParams:
    """The parameters a preset starts from: ``indoor`` keeps ``params``; ``outdoor`` sizes them for
    100 m (KISS-ICP's default range); ``auto`` keeps them until ``for_sweep`` has seen a sweep."""
    return scaled(params, 100.0) if name == "outdoor" else params


def observed_range(ranges: np.ndarray) -> float:
    """The range a sweep reaches: the 99th percentile of its finite ranges (robust to stray returns;
    absurd ones, beyond a kilometre, are left out), 0 for an empty sweep."""
    r = np.asarray(ranges, dtype=np.float64)
    r = r[np.isfinite(r) & (r <= _NO_LIDAR_REACHES)]
    return float(np.percentile(r, 99)) if len(r) else 0.0


def for_sweep(params: LidarOdometryParams, ranges: np.ndarray) -> LidarOdometryParams:
    """``auto``: ``params`` unchanged when the first sweep's ``observed_range`` is within their
    ``max_range`` (indoors); otherwise sized by ``scaled`` for that range (at most ``MAX_AUTO_RANGE``)."""
    reach = observed_range(ranges)
    if reach <= params.max_range:
        return params
    return scaled(params, min(float(np.ceil(reach * 1.1)), MAX_AUTO_RANGE))
