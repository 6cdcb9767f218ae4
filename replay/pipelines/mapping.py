"""The mapping pipeline: 2D occupancy mapping from /scan, and 3D LiDAR mapping when the log has a LiDAR.

Outputs: /map (OccupancyGrid), /Odometry, /cloud_registered (throttled) and /lidar_mapper/path in
replay.mcap; map.yaml + map.pgm (map_server), map.pcd (binary float32), trajectory.tum.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Literal

from navlog.errors import ConfigError
from navlog.replay.io.map_server import save_map
from navlog.replay.io.tum import write_poses
from navlog.replay.nodes.lidar_mapper import LidarMapperNode, LidarMapperParams
from navlog.replay.nodes.occupancy_mapper import DEFAULT_POSE_TOPICS, OccupancyMapperNode, OccupancyMapperParams
from navlog.replay.runtime.executor import Node
from navlog.replay.runtime.pipeline import Pipeline


@dataclass(frozen=True)
class Params:
    # which pose the 2D mapper uses: auto = ground_truth when the log has it, else the TF tree
    pose_source: Literal["auto", "ground_truth", "odom", "lidar_mapper", "tf"] = "auto"
    lidar_mapper: Literal["auto", "on", "off"] = "auto"  # auto: on when the log has the LiDAR topic
    occupancy: OccupancyMapperParams = field(default_factory=OccupancyMapperParams)
    lidar: LidarMapperParams = field(default_factory=LidarMapperParams)


def build(params: Params, log_topics: set[str]) -> Pipeline:
    lidar_on = params.lidar_mapper == "on" or (params.lidar_mapper == "auto" and params.lidar.lidar_topic in log_topics)
    source = params.pose_source
    if source == "auto":
        source = (
            "ground_truth"
            if (params.occupancy.pose_topic or DEFAULT_POSE_TOPICS["ground_truth"]) in log_topics
            else "tf"
        )
    if source == "lidar_mapper" and not lidar_on:
        raise ConfigError(
            "pose_source lidar_mapper needs the 3D mapper: set lidar_mapper=on (the log needs a LiDAR topic)"
        )
    occ = OccupancyMapperNode(replace(params.occupancy, pose_source=source))
    nodes: list[Node] = []
    inputs = [params.occupancy.scan_topic]
    optional = ["/tf", "/tf_static"]
    if source in ("ground_truth", "odom"):
        inputs.append(occ.pose_topic)
    outputs = [params.occupancy.map_topic]
    lidar = None
    if lidar_on:
        lidar = LidarMapperNode(params.lidar)
        nodes.append(lidar)
        inputs.append(params.lidar.lidar_topic)
        optional += [
            t
            for t, use in (
                (params.lidar.imu_topic, params.lidar.use_imu),
                (params.lidar.odom_topic, params.lidar.use_odom),
            )
            if use
        ]
        outputs += [params.lidar.odometry_topic, params.lidar.cloud_topic, params.lidar.path_topic]
    nodes.append(occ)

    def write_artifacts(out: Path) -> dict[str, Path]:
        written: dict[str, Path] = {}
        if occ.grid.logodds.size:
            yaml_path, pgm_path = save_map(occ.grid.to_map(params.occupancy.map_frame), out / "map.yaml")
            written.update({"map_yaml": yaml_path, "map_pgm": pgm_path})
        if lidar is not None:
            written.update(lidar.save_pcd(out / "map.pcd"))
            stamps, poses = lidar.poses()
            written["trajectory_tum"] = write_poses(out / "trajectory.tum", stamps, poses)
        else:
            written["trajectory_tum"] = write_poses(
                out / "trajectory.tum", [t for t, _ in occ.trajectory], [p for _, p in occ.trajectory]
            )
        return written

    def skipped() -> dict[str, int]:
        out = dict(occ.counts())
        if lidar is not None:
            out.update({f"lidar_mapper: {k}": v for k, v in lidar.skipped_counts().items()})
        return out

    info = {
        "pose_source": source,
        "lidar_mapper": "on" if lidar_on else "off",
        "trajectory": "3D mapper base_link poses" if lidar_on else f"robot poses from {source} (scans inserted)",
    }

    def nothing_produced() -> str | None:
        if occ.grid.logodds.size:
            return None
        return f"no map: no scan on {params.occupancy.scan_topic} could be placed (pose source {source})"

    return Pipeline("mapping", nodes, inputs, optional, outputs, write_artifacts, skipped, info, nothing_produced)
