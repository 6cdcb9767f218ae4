"""The localization pipeline: Nav2's AMCL on a saved map, over a log's scans and odometry TF.

``navlog replay LOG --pipeline localization --set map=MAP.yaml``: the AMCL node
(``navlog.replay.nodes.amcl``) reads the scan topic, odom -> base from /tf, the laser mount from
/tf_static and /initialpose; its parameters come from the ``amcl`` block of a Nav2 parameter file
(``nav2_params``: a path or a name in config/nav2/; ``--params nav2_params.yaml`` fills it; empty:
Nav2's defaults; ``--set amcl.KEY=VALUE`` or ``nav2.KEY=VALUE`` override its keys, full or short, as the
planner pipeline's), checked as ``navlog check-config`` checks them. The log's own map -> odom (a
perfect localiser's, in navlog's logs) is filtered out of the TF tree AMCL reads and counted among
the skipped inputs: AMCL publishes its own.

The initial pose (``initial_pose``): the pose itself, ``--set initial_pose=[x,y,yaw]`` (map frame, m and
rad), or a mode: ``parameters`` (the file's ``set_initial_pose`` and ``initial_pose``, which ``--set
amcl.set_initial_pose=true --set amcl.initial_pose.x=1.0`` may override), ``ground_truth`` (the first pose on ``ground_truth_topic``, whose frame is taken
as the map frame), ``initialpose`` (wait for /initialpose in the log), or ``auto``: the parameters
when ``set_initial_pose`` is true, else ground truth when the log has it, else /initialpose. The
filter's random numbers come from ``seed`` (``numpy.random.SeedSequence``): the same log, map,
parameters and seed give the same bytes.

Outputs: /amcl_pose, /particle_cloud and AMCL's map -> odom on /tf in replay.mcap (the log's own /tf is not
recorded again); trajectory.tum (the
pose of ``trajectory_frame`` in the map frame at every scan, as AMCL's TF gives it) and
localization.json (updates, resamples, particles, the first update's and the last estimate).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np

from navlog.errors import ConfigError
from navlog.replay.io import json_text
from navlog.replay.io.map_server import load_map
from navlog.replay.io.tum import write_poses
from navlog.replay.limits import check_finite_pose, check_seed
from navlog.replay.nav2 import default_nav2_params, load_nav2_params
from navlog.replay.nav2.amcl import AmclParams
from navlog.replay.nav2.overrides import apply_nav2_overrides, nav2_override_items
from navlog.replay.nav2.params import parse_nav2_params
from navlog.replay.nodes.amcl import AmclNode
from navlog.replay.pipelines import PipelineSpec, existing_file, log_odometry, register
from navlog.replay.pipelines.safety import nav2_file
from navlog.replay.runtime.pipeline import Pipeline


@dataclass(frozen=True)
class Params:
    map: str = ""  # the map_server YAML to localise on (required)
    nav2_params: str = ""  # a Nav2 parameter file with an amcl block: a path or a name in config/nav2/; "": defaults
    # a mode, or the pose itself, [x, y, yaw] in the map frame (m, m, rad): --set initial_pose=[1.0,2.0,0.5]
    initial_pose: Literal["auto", "parameters", "ground_truth", "initialpose"] | tuple[float, float, float] = "auto"
    ground_truth_topic: str = "/odom/ground_truth"
    trajectory_frame: str = "base_link"  # the frame whose map pose trajectory.tum holds ("" = base_frame_id)
    scan_topic: str = ""  # "" = "/" + the amcl block's scan_topic
    seed: int = 0
    amcl: dict[str, Any] = field(default_factory=dict)  # Nav2 overrides of the amcl block: --set amcl.KEY=VALUE
    nav2: dict[str, Any] = field(default_factory=dict)  # any Nav2 key, full or short: --set nav2.KEY=VALUE

    def __post_init__(self) -> None:
        check_seed(self.seed)
        if not isinstance(self.initial_pose, str):
            check_finite_pose(self.initial_pose, "initial_pose")


def default_amcl_document() -> dict[str, Any]:
    """Nav2's amcl defaults as a parameter document, so that ``--set amcl.KEY`` resolves without a file."""
    values = {
        f.name: f.default
        for f in fields(AmclParams)
        if not f.name.startswith("initial_pose_") and isinstance(f.default, (bool, int, float, str))
    }
    pose = {"x": 0.0, "y": 0.0, "z": 0.0, "yaw": 0.0}
    return {"amcl": {"ros__parameters": {**values, "initial_pose": pose}}}


def amcl_params(params: Params) -> tuple[AmclParams, str]:
    """The amcl block of the Nav2 file (or Nav2's defaults) with the ``--set amcl.KEY`` and ``nav2.KEY``
    overrides, and where it came from; errors raised at once."""
    overrides = nav2_override_items({"amcl": params.amcl, "nav2": params.nav2})
    if params.nav2_params:
        nav2 = load_nav2_params(nav2_file(params.nav2_params), overrides)
    elif overrides:
        nav2 = parse_nav2_params(apply_nav2_overrides(default_amcl_document(), overrides), source="<defaults>")
    else:
        nav2 = default_nav2_params()
    nav2 = nav2.require_valid(("amcl",))
    return (nav2.amcl or AmclParams()), nav2.source


def build(params: Params, log_topics: set[str]) -> Pipeline:
    if not params.map:
        raise ConfigError(
            "pipeline 'localization' needs a map: --set map=MAP.yaml (a map_server YAML, e.g. from "
            "`navlog world-map indoor_room --margin 0 -o MAP.yaml` or a mapping replay's map.yaml)"
        )
    amcl, source = amcl_params(params)
    if params.scan_topic:
        amcl = replace(amcl, scan_topic=params.scan_topic)
    mode = params.initial_pose
    if isinstance(mode, tuple):  # the pose itself
        x, y, yaw = mode
        amcl = replace(amcl, set_initial_pose=True, initial_pose_x=x, initial_pose_y=y, initial_pose_yaw=yaw)
        mode = "parameters"
    if mode == "auto":
        mode = (
            "parameters"
            if amcl.set_initial_pose
            else "ground_truth"
            if params.ground_truth_topic in log_topics
            else "initialpose"
        )
    if mode == "parameters" and not amcl.set_initial_pose:
        amcl = replace(amcl, set_initial_pose=True)
    occ_map = load_map(params.map)
    rng = np.random.default_rng(np.random.SeedSequence(params.seed).spawn(1)[0])
    node = AmclNode(
        amcl,
        occ_map,
        rng,
        trajectory_frame=params.trajectory_frame,
        initial_pose_topic=params.ground_truth_topic if mode == "ground_truth" else "",
    )
    inputs = [node.scan_topic, "/tf"]
    optional = ["/tf_static", "/initialpose"]
    if mode == "ground_truth":
        inputs.append(params.ground_truth_topic)

    info = {
        "initial_pose": mode,
        "nav2_params": source,
        "map": params.map,
        "motion_model": amcl.robot_model_type,
        "map_to_odom": "the log's map -> odom is ignored; AMCL's goes on /tf (recorded)",
    }
    return LocalizationRun(params, amcl, source, mode, node, inputs, optional, info)


class LocalizationRun(Pipeline):
    """AMCL on a map over one log; trajectory.tum and localization.json written after the run."""

    def __init__(
        self,
        params: Params,
        amcl: AmclParams,
        source: str,
        mode: str,
        node: AmclNode,
        inputs: list[str],
        optional: list[str],
        info: dict[str, str],
    ) -> None:
        super().__init__(
            "localization",
            [node],
            inputs,
            optional,
            ["/amcl_pose", "/particle_cloud"],
            published_outputs=["/tf"],
            info=info,
        )
        self.params, self.amcl, self.source, self.mode, self.node = params, amcl, source, mode, node

    def report(self) -> dict[str, Any]:
        params, node = self.params, self.node
        out: dict[str, Any] = {
            "nav2_params": Path(self.source).name if params.nav2_params else self.source,
            "map": Path(params.map).name,
            "initial_pose": self.mode,
            "seed": params.seed,
            "scans_localised": len(node.trajectory),
            "filter_updates": node.updates,
            "resamples": node.resamples,
            "particles": len(node.filter.poses),
        }
        if len(node.filter.poses):
            est = node.filter.estimate()
            out["estimate"] = {
                "x": round(float(est.pose[0]), 6),
                "y": round(float(est.pose[1]), 6),
                "yaw": round(float(est.pose[2]), 6),
                "std_xy_m": round(float(np.sqrt(max(0.0, np.trace(est.covariance[:2, :2])))), 6),
                "std_yaw_rad": round(float(np.sqrt(max(0.0, est.covariance[2, 2]))), 6),
                "clusters": est.clusters,
            }
        return out

    def write_artifacts(self, out: Path) -> dict[str, Path]:
        node = self.node
        written = {
            "trajectory_tum": write_poses(
                out / "trajectory.tum", [t for t, _ in node.trajectory], [p for _, p in node.trajectory]
            )
        }
        path = out / "localization.json"
        path.write_text(json_text.dumps(self.report(), indent=2, sort_keys=True) + "\n")
        written["localization"] = path
        return written

    def skipped(self) -> dict[str, int]:
        return self.node.skipped_counts()

    def nothing_produced(self) -> str | None:
        node, amcl = self.node, self.amcl
        if node.trajectory:
            return None
        if node.initialised_ns is None:
            return (
                f"no initial pose: the log has no /initialpose and initial_pose is {self.mode}; set one with "
                "--set initial_pose=ground_truth (a log with ground truth) or set_initial_pose in the Nav2 file"
            )
        return f"no scan on {node.scan_topic} could be localised (odometry TF {amcl.odom_frame_id} -> {amcl.base_frame_id})"


@register
class Localization(PipelineSpec):
    """Nav2's AMCL on a saved map over a log's scans and odometry TF."""

    name = "localization"
    params_class = Params
    params_file_key = "nav2_params"  # `navlog replay --pipeline localization --params nav2_params.yaml`

    @classmethod
    def settle(cls, params: Params, reader: Any, log_to: dict[str, str]) -> Params:
        """AMCL's ``odom_frame_id``: the odometry frame the recording names (``log_odometry``), unless set."""
        found = log_odometry(reader)
        if found is None or "odom_frame_id" in params.amcl:
            return params
        return replace(params, amcl={**params.amcl, "odom_frame_id": found[1]})

    @classmethod
    def build(cls, params: Params, log_topics: set[str]) -> Pipeline:
        return build(params, log_topics)

    @classmethod
    def static_map(cls, params: Params) -> Path | None:
        return existing_file(params.map)
