"""Exporting logs: ROS 2 bags (``rosbag2``: sqlite3 or MCAP storage, Humble or Jazzy metadata) and TUM
trajectories (``tum``: from a pose topic or a TF chain), a PCD map as a map_server map (``maps``);
``selection`` picks topics and a time window."""

from navlog.analysis.export.maps import PcdMapFiles, pcd_to_map
from navlog.analysis.export.rosbag2 import BagOptions, ExportSummary, export_rosbag2
from navlog.analysis.export.tum import TumSummary, export_tum

__all__ = ["BagOptions", "ExportSummary", "PcdMapFiles", "TumSummary", "export_rosbag2", "export_tum", "pcd_to_map"]
