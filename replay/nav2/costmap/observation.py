"""Sensor observations for the obstacle layers: their source parameters, and scans as points.

An ``Observation`` holds points already transformed into the costmap's global frame with the sensor
origin in that frame; the costmap node does the TF lookups. ``scan_points`` projects a LaserScan as
laser_geometry does.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from navlog.replay.nav2.schema import param


@dataclass(frozen=True)
class ObservationSourceParams:
    """One observation source of an obstacle layer (Nav2's ObservationBuffer parameters)."""

    topic: str = ""
    sensor_frame: str = ""
    observation_persistence: float = param(0.0, ge=0.0)
    expected_update_rate: float = param(0.0, ge=0.0)
    data_type: str = param("PointCloud", choices=("LaserScan", "PointCloud2", "PointCloud"))
    min_obstacle_height: float = 0.0
    max_obstacle_height: float = 0.0
    inf_is_valid: bool = False
    marking: bool = True
    clearing: bool = False
    obstacle_max_range: float = param(2.5, ge=0.0)
    obstacle_min_range: float = param(0.0, ge=0.0)
    raytrace_max_range: float = param(3.0, ge=0.0)
    raytrace_min_range: float = param(0.0, ge=0.0)
    clear_after_reading: bool = False
    transport_type: str = "raw"
    READ_ONLY: ClassVar[tuple[str, ...]] = ("expected_update_rate", "transport_type", "clear_after_reading")


@dataclass
class Observation:
    """Points (N, 3) in the costmap's global frame, with the sensor origin in that frame."""

    origin: np.ndarray  # (3,)
    points: np.ndarray  # (N, 3)
    source: str


def scan_points(msg: Any) -> np.ndarray:
    """A LaserScan's valid returns as (N, 3) points in the sensor frame, as laser_geometry projects them.

    Ranges in [range_min, range_max) are kept; NaN and inf are dropped (see ``scan_points_inf_valid``).
    """
    r = np.asarray(msg.ranges, dtype=np.float64)
    ang = float(msg.angle_min) + np.arange(len(r)) * float(msg.angle_increment)
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(r) & (r < float(msg.range_max)) & (r >= float(msg.range_min))
    r, ang = r[ok], ang[ok]
    return np.column_stack([r * np.cos(ang), r * np.sin(ang), np.zeros_like(r)])


def scan_points_inf_valid(msg: Any) -> np.ndarray:
    """As ``scan_points`` with inf_is_valid: +inf becomes range_max - 1e-4 (a clearing ray)."""
    r = np.asarray(msg.ranges, dtype=np.float64).copy()
    r[np.isposinf(r)] = float(msg.range_max) - 1e-4
    ang = float(msg.angle_min) + np.arange(len(r)) * float(msg.angle_increment)
    with np.errstate(invalid="ignore"):
        ok = np.isfinite(r) & (r < float(msg.range_max)) & (r >= float(msg.range_min))
    r, ang = r[ok], ang[ok]
    return np.column_stack([r * np.cos(ang), r * np.sin(ang), np.zeros_like(r)])
