"""A Rerun recording of a navigation log, with a default blueprint.

``build_view(reader, rec)`` reads a log once and draws what a navigation engineer looks at:

- a 3D view in the fixed frame (``map`` when the TF tree has it): LiDAR clouds and laser scans in
  their sensor frames, the TF tree, true and estimated trajectories, plans, occupancy grids,
  goals and waypoints as labelled arrows, the collision monitor's polygons coloured by their action
  and its approach prediction, and the replay outputs (PCD map, trajectory) when given;
- a top-down 2D view: the occupancy grid (or costmap), scan points and the robot footprint, all
  drawn in the pixel space of one fixed canvas in the fixed frame;
- time series: the velocity chain (``/cmd_vel_nav`` -> ``/cmd_vel_smoothed`` -> ``/cmd_vel``),
  speed, odometry drift against ground truth, IMU rates; events as a text log.

``save_view`` writes an ``.rrd`` file, ``stream_view`` sends to a running or spawned viewer.
Everything high-rate goes through ``send_columns``; per-row ``log`` is used only for grids, goals
and static items. Rerun itself is imported only when a view is built.

Modules: ``log_view`` (walking a log, the entry points), ``options``, ``context`` (the stream and
what every drawer shares), one module per kind of thing drawn (``scans``, ``clouds``, ``tf``,
``trajectories``, ``plans``, ``goals``, ``grids``, ``polygons``, ``topdown``, ``timeseries``,
``events``),
``replay_outputs`` (a replay folder's map, PCD and TUM files) and ``blueprint``.
"""

from navlog.analysis.view.log_view import build_view, save_view, stream_view
from navlog.analysis.view.options import ViewOptions, ViewSummary

__all__ = ["ViewOptions", "ViewSummary", "build_view", "save_view", "stream_view"]
