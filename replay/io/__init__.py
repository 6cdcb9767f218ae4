"""Log and map I/O: reading any ROS 2 log, writing navlog MCAP logs, salvaging truncated ones, map files.

- ``open_log(path)`` opens a .mcap file, a .db3 file or a rosbag2 folder as a ``LogReader``
  (``McapLogReader``, ``SplitMcapLogReader``, ``RosbagLogReader``), each with its own ``typestore``;
- ``McapLogWriter`` writes ROS 2 MCAP logs; ``recover_mcap`` salvages a truncated one;
- ``load_map`` / ``save_map`` read and write map_server YAML + image (an ``OccupancyMap``);
- ``read_pcd`` / ``write_pcd`` read and write point-cloud maps (PCD: read through Open3D, written with pypcd4);
- ``write_poses`` writes a TUM trajectory.

Names are imported on first use, so importing the package stays cheap.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.replay.io.formats import open_log
    from navlog.replay.io.logwriter import McapLogWriter, check_output
    from navlog.replay.io.map_server import load_map, save_map
    from navlog.replay.io.mcap_reader import MCAP_MAGIC, McapLogReader, SplitMcapLogReader
    from navlog.replay.io.pcd import read_pcd, write_pcd
    from navlog.replay.io.reader import LogReader, ReadReport, TopicInfo
    from navlog.replay.io.recovery import RecoveryResult, recover_mcap
    from navlog.replay.io.rosbag2_reader import RosbagLogReader
    from navlog.replay.io.tum import TumPoses, read_tum, write_poses, write_tum
    from navlog.replay.io.typestore import LogTypestore, types_from_schema

__all__ = [
    "MCAP_MAGIC",
    "LogReader",
    "LogTypestore",
    "McapLogReader",
    "McapLogWriter",
    "ReadReport",
    "RecoveryResult",
    "RosbagLogReader",
    "SplitMcapLogReader",
    "TopicInfo",
    "TumPoses",
    "check_output",
    "load_map",
    "open_log",
    "read_pcd",
    "read_tum",
    "recover_mcap",
    "save_map",
    "types_from_schema",
    "write_pcd",
    "write_poses",
    "write_tum",
]

# the module, below this package, that defines each public name
_MODULES = {
    "open_log": "formats",
    "LogReader": "reader",
    "ReadReport": "reader",
    "TopicInfo": "reader",
    "MCAP_MAGIC": "mcap_reader",
    "McapLogReader": "mcap_reader",
    "SplitMcapLogReader": "mcap_reader",
    "RosbagLogReader": "rosbag2_reader",
    "LogTypestore": "typestore",
    "types_from_schema": "typestore",
    "McapLogWriter": "logwriter",
    "check_output": "logwriter",
    "RecoveryResult": "recovery",
    "recover_mcap": "recovery",
    "load_map": "map_server",
    "save_map": "map_server",
    "read_pcd": "pcd",
    "write_pcd": "pcd",
    "read_tum": "tum",
    "TumPoses": "tum",
    "write_poses": "tum",
    "write_tum": "tum",
}
__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
