"""Nav2's collision monitor (``nav2_collision_monitor``, Jazzy) without ROS: parameters and decisions.

The monitor sits between the velocity smoother and the robot (/cmd_vel_smoothed -> /cmd_vel): for
each command it looks at its sources' points in the base frame and, when they enter its polygons,
stops, slows down, limits, or scales the command by the predicted time to collision (approach).

- ``params``: ``CollisionMonitorParams`` (with ``CollisionPolygonParams``, ``VelocitySubPolygonParams``,
  ``CollisionSourceParams``) and ``read_collision_monitor``, used by ``navlog.replay.nav2.params``;
- ``polygons``: the shapes (``Polygon``, ``Circle``, ``VelocityPolygon``, ``make_shape``),
  ``Velocity``, the approach kinematics (``project_state``, ``transform_points``) and Nav2's ray casting
  (``points_in_polygon``, over a polygon's ``polygon_edges``: a ``PolygonEdges`` table kept per shape);
  ``NO_POINTS``, the shared read-only (0, 2) array of no points;
- ``sources``: scans, point clouds and range readings as base-frame points, the staleness rule, and
  ``planar_points_beyond`` (``planar_block_beyond`` for a transform given as floats), the test that lets a
  scan too far from every shape go untransformed, and ``scan_nearest``, a scan's least kept range;
- ``monitor``: ``CollisionMonitor.process``, one ``Decision`` per command.

The executor node is ``navlog.replay.nodes.collision_monitor.CollisionMonitorNode``.
"""

from __future__ import annotations

from navlog.replay.nav2.collision_monitor.monitor import (
    ACTION_CODES,
    INVALID_SOURCE,
    Action,
    CollisionMonitor,
    Decision,
    limit_ratio,
)
from navlog.replay.nav2.collision_monitor.params import (
    CollisionMonitorParams,
    CollisionPolygonParams,
    CollisionSourceParams,
    VelocitySubPolygonParams,
    parse_polygon_points,
    read_collision_monitor,
)
from navlog.replay.nav2.collision_monitor.polygons import (
    NO_POINTS,
    Circle,
    Polygon,
    PolygonEdges,
    Shape,
    Velocity,
    VelocityPolygon,
    in_velocity_range,
    make_shape,
    points_in_polygon,
    polygon_edges,
    project_state,
    transform_points,
)
from navlog.replay.nav2.collision_monitor.sources import (
    cloud_points,
    planar_block_beyond,
    planar_points_beyond,
    range_points,
    scan_nearest,
    scan_points,
    scan_points_nearest,
    source_fresh,
    to_base,
)

__all__ = [
    "ACTION_CODES",
    "INVALID_SOURCE",
    "NO_POINTS",
    "Action",
    "Circle",
    "CollisionMonitor",
    "CollisionMonitorParams",
    "CollisionPolygonParams",
    "CollisionSourceParams",
    "Decision",
    "Polygon",
    "PolygonEdges",
    "Shape",
    "Velocity",
    "VelocityPolygon",
    "VelocitySubPolygonParams",
    "cloud_points",
    "in_velocity_range",
    "limit_ratio",
    "make_shape",
    "parse_polygon_points",
    "planar_block_beyond",
    "planar_points_beyond",
    "points_in_polygon",
    "polygon_edges",
    "project_state",
    "range_points",
    "read_collision_monitor",
    "scan_nearest",
    "scan_points",
    "scan_points_nearest",
    "source_fresh",
    "to_base",
    "transform_points",
]
