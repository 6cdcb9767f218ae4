"""A Rerun recording of a navigation log, with a default blueprint.

``build_view(reader, rec)`` reads a log once and draws what a navigation engineer looks at:

- a 3D view in the fixed frame (``map`` when the TF tree has it), its camera starting on the robot
  (``follow``: tracking it): the robot's outline, LiDAR clouds (thinned to one per
  ``cloud_period_s``) and laser scans in their sensor frames, the TF tree (unlabelled axes), true
  and estimated trajectories, plans, occupancy grids cropped to their known cells,
  goals and waypoints as labelled arrows, the collision monitor's polygons coloured by their action
  and its approach prediction, and the replay outputs (PCD map, trajectory) when given;
- a top-down 2D view: the occupancy grid (or costmap), scan points and the robot footprint, all
  drawn in the pixel space of one fixed canvas in the fixed frame;
- time series, every one shown with its unit and range: the velocity chain (``/cmd_vel_nav`` ->
  ``/cmd_vel_smoothed`` -> ``/cmd_vel``) beside the speed and the IMU yaw rate, odometry drift
  against ground truth, IMU acceleration; events as a text log.

Every stream keeps one colour in every view (``context.COLORS``, colour-blind safe).

``save_view`` writes an ``.rrd`` file, ``stream_view`` sends to a running or spawned viewer.
Everything high-rate goes through ``send_columns``; per-row ``log`` is used only for grids, goals
and static items. Rerun itself is imported only when a view is built.

Modules: ``log_view`` (walking a log, the entry points), ``options``, ``context`` (the stream and
what every drawer shares), one module per kind of thing drawn (``scans``, ``clouds``, ``tf``,
``trajectories``, ``plans``, ``goals``, ``grids``, ``polygons``, ``topdown``, ``timeseries``,
``events``, ``robot``),
``replay_outputs`` (a replay folder's map, PCD and TUM files) and ``blueprint`` (the default layout,
also as plain data: ``plan_views``).
"""

from navlog.analysis.view.log_view import build_view, save_view, stream_view
from navlog.analysis.view.options import ViewOptions, ViewSummary

__all__ = ["ViewOptions", "ViewSummary", "build_view", "save_view", "stream_view"]
