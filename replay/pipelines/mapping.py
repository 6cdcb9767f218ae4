"""The mapping pipeline: 2D occupancy mapping from /scan, and 3D LiDAR mapping when the log has a LiDAR
(alone when the log has a PointCloud2 but no scan: the 2D mapper is then off, and the manifest says so).

Outputs: /map (OccupancyGrid), /Odometry, /cloud_registered (throttled) and /lidar_mapper/path in
replay.mcap; map.yaml + map.pgm (map_server), map.pcd (binary float32), trajectory.tum.
With ``pose_source: slam`` (what ``auto`` picks on a log without ground truth) the 2D map comes from
the SLAM node (``navlog.replay.nodes.slam``): trajectory.tum is then its pose at every scan,
pose_graph.json its keyframes and edges, replay.mcap's /tf its map -> odom at every scan it placed and /pose
its pose with covariance at every keyframe.
"""

from __future__ import annotations

import json
import logging
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from navlog.errors import ConfigError
from navlog.replay.config import load_yaml
from navlog.replay.io.map_server import save_map
from navlog.replay.io.tum import write_poses
from navlog.replay.mapping.slam2d.params import DEFAULT_ODOM_FRAME, SlamParams, finer_grid_cost
from navlog.replay.mapping.slam2d.toolbox import TOOLBOX_NODE, read_slam_toolbox
from navlog.replay.nodes.lidar_mapper import LidarMapperNode, LidarMapperParams, settle_lidar
from navlog.replay.nodes.occupancy_mapper import DEFAULT_POSE_TOPICS, OccupancyMapperNode, OccupancyMapperParams
from navlog.replay.pipelines import PipelineSpec, log_odometry, register
from navlog.replay.runtime.executor import Node
from navlog.replay.runtime.pipeline import Pipeline

if TYPE_CHECKING:
    from navlog.replay.nodes.slam import SlamNode

logger = logging.getLogger("navlog")


@dataclass(frozen=True)
class Params:
    # which pose the 2D mapper uses: auto = ground_truth when the log has it, else SLAM (scans + odometry TF)
    pose_source: Literal["auto", "ground_truth", "odom", "lidar_mapper", "tf", "slam"] = "auto"
    lidar_mapper: Literal["auto", "on", "off"] = "auto"  # auto: on when the log has the LiDAR topic
    occupancy: OccupancyMapperParams = field(default_factory=OccupancyMapperParams)
    lidar: LidarMapperParams = field(default_factory=LidarMapperParams)
    slam: SlamParams = field(default_factory=SlamParams)  # pose_source slam: slam_toolbox's parameters


def settle(params: Params, reader: Any, log_to: dict[str, str]) -> Params:
    """Before replaying: the odometry the recording names (``log_odometry``: the SLAM's ``odom_frame``
    when it is the default, the ``odom`` pose source's topic when none is set and /odom is not remapped); the LiDAR topic (the log's
    only PointCloud2 when the configured one is absent and there is no scan, or ``lidar.lidar_topic:
    auto``) and a check that its frame has a mount."""
    found = log_odometry(reader)
    if found is not None:
        topic, frame = found
        if params.slam.odom_frame == DEFAULT_ODOM_FRAME and frame != params.slam.base_frame:
            params = replace(params, slam=replace(params.slam, odom_frame=frame))
        default = DEFAULT_POSE_TOPICS["odom"]
        if params.pose_source == "odom" and not params.occupancy.pose_topic and default not in log_to.values():
            # the recording's topic, as the pipeline reads it; a remap onto /odom says which topic it is
            params = replace(params, occupancy=replace(params.occupancy, pose_topic=log_to.get(topic, topic)))
    if params.lidar_mapper == "off":
        return params
    alone = params.occupancy.scan_topic not in {log_to.get(t, t) for t in reader.topics}
    lidar = settle_lidar(params.lidar, reader, log_to, choose=alone or params.lidar_mapper == "on")
    return replace(params, lidar=lidar)


def build(params: Params, log_topics: set[str]) -> Pipeline:
    lidar_on = params.lidar_mapper == "on" or (params.lidar_mapper == "auto" and params.lidar.lidar_topic in log_topics)
    occupancy_on = params.occupancy.scan_topic in log_topics or not lidar_on  # else the 3D mapper runs alone
    source = params.pose_source
    if source == "auto":
        source = (
            "ground_truth"
            if (params.occupancy.pose_topic or DEFAULT_POSE_TOPICS["ground_truth"]) in log_topics
            else "slam"
        )
    if source == "lidar_mapper" and not lidar_on:
        raise ConfigError(
            "pose_source lidar_mapper needs the 3D mapper: set lidar_mapper=on (the log needs a LiDAR topic)"
        )
    slam = slam_node(params) if source == "slam" and occupancy_on else None
    occ = slam or OccupancyMapperNode(replace(params.occupancy, pose_source=source))  # type: ignore[arg-type]
    nodes: list[Node] = []
    inputs = [params.occupancy.scan_topic] if occupancy_on else []
    optional = ["/tf", "/tf_static"]
    if source in ("ground_truth", "odom") and occupancy_on:
        inputs.append(params.occupancy.pose_topic or DEFAULT_POSE_TOPICS[source])
    outputs = [params.occupancy.map_topic] if occupancy_on else []
    if slam is not None:
        outputs.append(slam.p.pose_topic)
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
    if occupancy_on:
        nodes.append(occ)
    info = {
        "pose_source": source,
        "lidar_mapper": "on" if lidar_on else "off",
        "trajectory": "SLAM poses at every scan (optimised keyframes + each scan's pose relative to its keyframe)"
        if slam is not None
        else "3D mapper base_link poses"
        if lidar_on
        else f"robot poses from {source} (scans inserted)",
    }
    if lidar_on:
        info["lidar_topic"] = params.lidar.lidar_topic
    if not occupancy_on:
        info["occupancy_mapper"] = f"off (no {params.occupancy.scan_topic} in the log: the 3D mapper runs alone)"
    return MappingRun(params, source, occ, lidar, slam, occupancy_on, nodes, inputs, optional, outputs, info)


class MappingRun(Pipeline):
    """The mappers of one run: the 2D mapper or SLAM (``occ``; not run when ``occupancy_on`` is False),
    the 3D mapper when on; their maps and trajectory written after the run."""

    def __init__(
        self,
        params: Params,
        source: str,
        occ: OccupancyMapperNode | SlamNode,
        lidar: LidarMapperNode | None,
        slam: SlamNode | None,
        occupancy_on: bool,
        nodes: list[Node],
        inputs: list[str],
        optional: list[str],
        outputs: list[str],
        info: dict[str, str],
    ) -> None:
        # the SLAM's map -> odom goes on the log's /tf: recorded, the log's own transforms not again
        published = ["/tf"] if slam is not None else []
        super().__init__("mapping", nodes, inputs, optional, outputs, published_outputs=published, info=info)
        self.params, self.source = params, source
        self.occ, self.lidar, self.slam, self.occupancy_on = occ, lidar, slam, occupancy_on

    def write_artifacts(self, out: Path) -> dict[str, Path]:
        occ, lidar, slam = self.occ, self.lidar, self.slam
        written: dict[str, Path] = {}
        if lidar is not None:  # what the 3D mapper decided from the data (time field, mount, preset)
            self.info.update({f"lidar_mapper {k}": v for k, v in sorted(lidar.notes.items())})
        if occ.grid.logodds.size:
            yaml_path, pgm_path = save_map(occ.grid.to_map(self.params.occupancy.map_frame), out / "map.yaml")
            written.update({"map_yaml": yaml_path, "map_pgm": pgm_path})
        if lidar is not None:
            stamps, poses = lidar.poses()
            if len(stamps):  # else no cloud was registered: the skipped counts say why
                written.update(lidar.save_pcd(out / "map.pcd"))
            written["trajectory_tum"] = write_poses(out / "trajectory.tum", stamps, poses)
        else:
            written["trajectory_tum"] = write_poses(
                out / "trajectory.tum", [t for t, _ in occ.trajectory], [p for _, p in occ.trajectory]
            )
        if slam is not None:
            from navlog.replay.nodes.slam import slam_artifacts

            written.update(slam_artifacts(slam, out))
            self.info["slam"] = slam.summary()
        return written

    def skipped(self) -> dict[str, int]:
        out = dict(self.occ.skipped_counts())
        if self.lidar is not None:
            out.update({f"lidar_mapper: {k}": v for k, v in self.lidar.skipped_counts().items()})
        return out

    def nothing_produced(self) -> str | None:
        params, lidar = self.params, self.lidar
        if not self.occupancy_on and lidar is not None and not len(lidar.poses()[0]):
            return f"no 3D map: no cloud on {params.lidar.lidar_topic} could be registered"
        if not self.occupancy_on or self.occ.grid.logodds.size:
            return None
        return f"no map: no scan on {params.occupancy.scan_topic} could be placed (pose source {self.source})"


@register
class Mapping(PipelineSpec):
    """2D occupancy mapping (or SLAM) and 3D LiDAR mapping; scored by ``navlog metrics``."""

    name = "mapping"
    params_class = Params
    facts = PipelineSpec.facts | {"metrics"}
    summary_facts = ("metrics",)
    scored_by_metrics = True

    @classmethod
    def foreign_overrides(cls, params_file: Path) -> list[str] | None:
        return slam_toolbox_overrides(params_file)

    @classmethod
    def settle(cls, params: Params, reader: Any, log_to: dict[str, str]) -> Params:
        return settle(params, reader, log_to)

    @classmethod
    def build(cls, params: Params, log_topics: set[str]) -> Pipeline:
        return build(params, log_topics)

    @classmethod
    def map_resolution(cls, params: Params) -> float:
        return float(params.occupancy.grid.resolution)


def slam_toolbox_overrides(path: Path) -> list[str] | None:
    """The values of a slam_toolbox parameter file (its ``slam_toolbox: ros__parameters:`` block, alone or in
    a Nav2 file) as ``KEY=VALUE`` overrides of this pipeline's YAML (``navlog.replay.mapping.slam2d.toolbox``);
    None for a file without that block. Its errors raise one ConfigError listing each with its line."""
    doc = load_yaml(path)
    if not isinstance(doc, dict) or TOOLBOX_NODE not in doc:
        return None
    from navlog.replay.nav2 import load_nav2_params  # (here: Nav2's readers load scipy, which mapping does not need)

    nav2 = load_nav2_params(path, readers={TOOLBOX_NODE: read_slam_toolbox}).require_valid((TOOLBOX_NODE,))
    return [f"{key}={json.dumps(value)}" for key, value in nav2.others.get(TOOLBOX_NODE, {}).items()]


def slam_node(params: Params) -> SlamNode:
    """The SLAM node with the occupancy mapper's topics, frames and grid rules and the slam parameters
    (imported here: gtsam loads only when SLAM runs)."""
    from navlog.replay.nodes.slam import SlamNode, slam_node_params

    grid = params.slam.correlation_search_space_resolution
    cost = finer_grid_cost(grid)
    if cost:
        default = SlamParams.correlation_search_space_resolution
        logger.warning(
            f"slam.correlation_search_space_resolution {grid} m: {cost} "
            f"(--set slam.correlation_search_space_resolution={default} for navlog's)"
        )
    return SlamNode(slam_node_params(params.slam, params.occupancy))
