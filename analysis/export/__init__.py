"""Exporting logs: ROS 2 bags (``rosbag2``: sqlite3 or MCAP storage, Humble or Jazzy metadata) and TUM
trajectories (``tum``: from a pose topic or a TF chain); ``selection`` picks topics and a time window."""

from navlog.analysis.export.rosbag2 import BagOptions, ExportSummary, export_rosbag2
from navlog.analysis.export.tum import TumSummary, export_tum

__all__ = ["BagOptions", "ExportSummary", "TumSummary", "export_rosbag2", "export_tum"]
