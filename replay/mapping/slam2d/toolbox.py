"""slam_toolbox's parameter file (``mapper_params_online_async.yaml`` and its kin) read for the 2D SLAM.

The ``slam_toolbox: ros__parameters:`` block of a ROS 2 parameter file, on its own or beside Nav2's
nodes, becomes the mapping pipeline's parameters (``read_slam_toolbox``):

- a key the SLAM has under the same name and meaning fills the ``slam:`` section (every ``SlamParams``
  field: slam_toolbox's own and navlog's additions alike);
- ``scan_topic``, ``map_frame`` and ``transform_timeout`` fill the map's (``occupancy:``);
- a key slam_toolbox declares that navlog does not use is noted with why (``NOT_USED``), among them
  ``loop_match_maximum_variance_coarse``, which slam_toolbox measures otherwise;
- ``mode: localization`` is refused (this SLAM maps; AMCL localises on a saved map);
- any other key is an error with a did-you-mean, as a misspelt key slam_toolbox would ignore.

Values are checked as the ``slam:`` section's are (types, ranges, the search squares' sizes).
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

from navlog.replay.config import ERROR, NOTE, ParamReader
from navlog.replay.mapping.slam2d.params import SlamParams, finer_grid_cost

TOOLBOX_NODE = "slam_toolbox"

# slam_toolbox key -> the mapping pipeline's key for the same value (the map's topic, frame and TF wait)
OCCUPANCY_KEYS = {
    "scan_topic": "occupancy.scan_topic",
    "map_frame": "occupancy.map_frame",
    "transform_timeout": "occupancy.transform_timeout",
}

_ROS = "a setting of the running node; a replay has no use for it"
_KARTO = (
    "a setting of Karto's matcher; navlog's weighs each match against the odometry by its covariance "
    "(slam.match_sigmas, slam.odometry_sigmas)"
)
_SOLVER = "the pose graph is optimised by gtsam (iSAM2); its loop edges' robust kernel is slam.loop_kernel"
_MAP_FILE = "the map is written to the replay's folder; continuing a saved pose graph is not implemented"
# keys slam_toolbox declares (Humble to Rolling) that the SLAM reads and does not use, with why
NOT_USED: dict[str, str] = {
    **dict.fromkeys(
        (
            "debug_logging",
            "stack_size_to_use",
            "enable_interactive_mode",
            "interactive_mode",
            "paused_new_measurements",
            "paused_processing",
            "use_lifecycle_manager",
            "scan_queue_size",
            "localization_on_configure",
            "use_sim_time",
            "tf_buffer_duration",
        ),
        _ROS,
    ),
    "transform_publish_period": "the replay publishes map -> odom at every scan it places",
    "use_scan_matching": "scan matching is always on here (pose_source=odom maps on the odometry alone)",
    **dict.fromkeys(
        (
            "use_scan_barycenter",
            "use_response_expansion",
            "distance_variance_penalty",
            "angle_variance_penalty",
            "minimum_angle_penalty",
            "minimum_distance_penalty",
            "fine_search_angle_offset",
            "link_scan_maximum_distance",
        ),
        _KARTO,
    ),
    "loop_search_space_resolution": "the loop search runs on the correlation grid "
    "(correlation_search_space_resolution)",
    "loop_search_space_smear_deviation": "the loop search uses correlation_search_space_smear_deviation",
    "loop_match_maximum_variance_coarse": "slam_toolbox measures this variance otherwise: navlog's is the "
    f"match's Hessian's (default {SlamParams.loop_match_maximum_variance_coarse} m^2; "
    "set slam.loop_match_maximum_variance_coarse to change it)",
    **dict.fromkeys(
        (
            "solver_plugin",
            "ceres_linear_solver",
            "ceres_preconditioner",
            "ceres_trust_strategy",
            "ceres_dogleg_type",
            "ceres_loss_function",
        ),
        _SOLVER,
    ),
    **dict.fromkeys(("use_map_saver", "map_file_name", "map_start_pose", "map_start_at_dock", "map_name"), _MAP_FILE),
    **dict.fromkeys(
        (
            "lifelong_search_use_tree",
            "lifelong_minimum_score",
            "lifelong_iou_match",
            "lifelong_node_removal_score",
            "lifelong_overlap_score_scale",
            "lifelong_constraint_multiplier",
            "lifelong_nearby_penalty",
            "lifelong_candidates_scale",
        ),
        "lifelong mapping is not implemented",
    ),
}

_SLAM_KEYS = tuple(f.name for f in dataclasses.fields(SlamParams) if f.name not in NOT_USED)


def read_slam_toolbox(r: ParamReader, params: dict, path: tuple) -> dict[str, Any]:
    """The block's ``ros__parameters`` (``params``, at key ``path``) as the mapping pipeline's keys and
    values (``{"slam.resolution": 0.1, "occupancy.scan_topic": "/base_scan"}``), for the keys it sets.

    Every problem goes to ``r`` with its key path: a refused value leaves its key out.
    """
    slam: dict[str, Any] = {}
    occupancy: dict[str, Any] = {}
    for key, value in params.items():
        name, kpath = str(key), path + (key,)
        if name in _SLAM_KEYS:
            slam[name] = value
            grid = name == "correlation_search_space_resolution" and isinstance(value, (int, float))
            cost = finer_grid_cost(value) if grid else None
            if cost:
                r.add(NOTE, kpath, f"taken: {cost} (see the SLAM guide for what it costs)")
        elif name in OCCUPANCY_KEYS:
            timeout = name == "transform_timeout"
            ok, out = r.convert(value, float if timeout else str, kpath, {"ge": 0.0} if timeout else None)
            if ok and (math.isfinite(out) if timeout else out.strip()):
                occupancy[OCCUPANCY_KEYS[name]] = out
            elif ok:
                r.add(
                    ERROR,
                    kpath,
                    "expected a finite number of seconds" if timeout else f"expected a name, got {value!r}",
                )
        elif name == "mode":
            if value != "mapping":
                r.add(
                    ERROR,
                    kpath,
                    f"mode {value!r}: navlog's SLAM maps (mode: mapping); to localise on a saved map, replay "
                    "with --pipeline localization --set map=MAP.yaml (AMCL)",
                )
        elif name in NOT_USED:
            r.add(NOTE, kpath, f"read, not used: {NOT_USED[name]}")
        else:
            r.unknown_key(name, kpath, [*_SLAM_KEYS, *OCCUPANCY_KEYS, "mode", *NOT_USED])
    errors = sum(p.severity == ERROR for p in r.problems)
    checked = r.read(SlamParams, slam, path)
    if sum(p.severity == ERROR for p in r.problems) > errors:
        return occupancy  # the slam values together break a rule (reported); none is taken
    return {**{f"slam.{k}": getattr(checked, k) for k in slam}, **occupancy}
