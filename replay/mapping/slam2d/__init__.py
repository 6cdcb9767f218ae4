"""2D SLAM from laser scans and odometry (slam_toolbox's role), as pure computation.

- ``Slam2D`` (``slam``): keyframes by travel, correlative scan matching against the running
  buffer, loop closures against older keyframes, the pose graph, the map and the trajectory;
  ``LaserScan2D`` is a scan as it takes it, ``Keyframe`` one it kept, ``SlamCounts`` what it did;
- ``SlamParams`` (``params``): its parameters under slam_toolbox's names;
- ``ScanMatcher``, ``SearchWindow``, ``MatchResult``, ``LookupGrid`` (``scan_matcher``): the
  multi-resolution correlative matcher (branch and bound, then least squares);
- ``PoseGraph``, ``Edge`` (``pose_graph``): keyframe poses and their edges, optimised incrementally by gtsam's iSAM2.

Names are imported on first use, so reading the parameters does not load gtsam.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.replay.mapping.slam2d.params import SlamParams
    from navlog.replay.mapping.slam2d.pose_graph import Edge, PoseGraph
    from navlog.replay.mapping.slam2d.scan_matcher import LookupGrid, MatchResult, ScanMatcher, SearchWindow
    from navlog.replay.mapping.slam2d.slam import Keyframe, LaserScan2D, Slam2D, SlamCounts

__all__ = [
    "Edge",
    "Keyframe",
    "LaserScan2D",
    "LookupGrid",
    "MatchResult",
    "PoseGraph",
    "ScanMatcher",
    "SearchWindow",
    "Slam2D",
    "SlamCounts",
    "SlamParams",
]

# the module, below this package, that defines each public name
_MODULES = {
    "Edge": "pose_graph",
    "Keyframe": "slam",
    "LaserScan2D": "slam",
    "LookupGrid": "scan_matcher",
    "MatchResult": "scan_matcher",
    "PoseGraph": "pose_graph",
    "ScanMatcher": "scan_matcher",
    "SearchWindow": "scan_matcher",
    "Slam2D": "slam",
    "SlamCounts": "slam",
    "SlamParams": "params",
}
__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
