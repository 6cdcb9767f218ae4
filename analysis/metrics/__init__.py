"""Metrics of a replay against ground truth: trajectory errors, 2D map and 3D map quality, the report.

- ``trajectory``: the ``Trajectory`` type, timestamp association, Umeyama alignment, ATE and RPE
  (evo's definitions);
- ``maps``: 2D grid metrics (precision/recall/F1 at a tolerance, IoU, distances, coverage) and 3D
  point-map metrics (accuracy and completeness at a tolerance, Chamfer and Hausdorff distances);
- ``report``: ``compute_metrics`` (what ``navlog metrics`` runs) with ``MetricsOptions``, its JSON
  and its text table.

Names are imported on first use, so importing the package stays cheap (scipy and Open3D load with
the module that needs them).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.analysis.metrics.maps import (
        GridMetrics,
        MapMetricError,
        chamfer_hausdorff,
        completeness,
        grid_metrics,
        map_accuracy,
        point_to_mesh_distances,
        visible_surface_samples,
    )
    from navlog.analysis.metrics.report import (
        MetricsOptions,
        compute_metrics,
        format_table,
        ground_truth_trajectory,
        to_json,
        write_json,
    )
    from navlog.analysis.metrics.trajectory import (
        ALIGN_MODES,
        DELTA_UNITS,
        Alignment,
        AteResult,
        ErrorStats,
        RpeResult,
        Trajectory,
        TrajectoryError,
        absolute_trajectory_error,
        align,
        align_planar,
        associate,
        associate_interpolated,
        own_relative_errors,
        planar_ate,
        planar_in_frame,
        planar_relative_error,
        relative_pose_error,
        umeyama,
    )

__all__ = [
    "ALIGN_MODES",
    "DELTA_UNITS",
    "Alignment",
    "AteResult",
    "ErrorStats",
    "GridMetrics",
    "MapMetricError",
    "MetricsOptions",
    "RpeResult",
    "Trajectory",
    "TrajectoryError",
    "absolute_trajectory_error",
    "align",
    "align_planar",
    "associate",
    "associate_interpolated",
    "chamfer_hausdorff",
    "completeness",
    "compute_metrics",
    "format_table",
    "grid_metrics",
    "ground_truth_trajectory",
    "map_accuracy",
    "own_relative_errors",
    "planar_ate",
    "planar_in_frame",
    "planar_relative_error",
    "point_to_mesh_distances",
    "relative_pose_error",
    "to_json",
    "umeyama",
    "visible_surface_samples",
    "write_json",
]

# public name -> the module of this package that defines it
_MODULES = {
    "ALIGN_MODES": "trajectory",
    "DELTA_UNITS": "trajectory",
    "Alignment": "trajectory",
    "AteResult": "trajectory",
    "ErrorStats": "trajectory",
    "RpeResult": "trajectory",
    "Trajectory": "trajectory",
    "TrajectoryError": "trajectory",
    "absolute_trajectory_error": "trajectory",
    "align": "trajectory",
    "align_planar": "trajectory",
    "planar_ate": "trajectory",
    "planar_in_frame": "trajectory",
    "planar_relative_error": "trajectory",
    "own_relative_errors": "trajectory",
    "associate": "trajectory",
    "associate_interpolated": "trajectory",
    "relative_pose_error": "trajectory",
    "umeyama": "trajectory",
    "GridMetrics": "maps",
    "MapMetricError": "maps",
    "chamfer_hausdorff": "maps",
    "completeness": "maps",
    "grid_metrics": "maps",
    "map_accuracy": "maps",
    "point_to_mesh_distances": "maps",
    "visible_surface_samples": "maps",
    "MetricsOptions": "report",
    "compute_metrics": "report",
    "format_table": "report",
    "ground_truth_trajectory": "report",
    "to_json": "report",
    "write_json": "report",
}

__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
