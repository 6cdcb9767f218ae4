"""The safety pipeline: Nav2's velocity smoother and collision monitor between a controller and the robot.

``/cmd_vel_nav`` -> velocity smoother -> ``/cmd_vel_smoothed`` -> collision monitor -> ``/cmd_vel``
(topics are parameters; ``velocity_smoother: off`` or ``collision_monitor: off`` drops a filter and
the chain closes over it). Both read a Nav2 parameter file (``nav2_params``: a name in
config/nav2/ or a path; ``--params nav2_params.yaml`` fills it; default the KiBot configuration,
``config/nav2/kibot_safety.yaml``). The monitor reads its observation sources (scans, clouds,
ranges), /tf and /tf_static; a closed-loop smoother reads odometry. Override any key of the file with
``--set nav2.KEY=VALUE`` (full or short: ``nav2.velocity_smoother.max_velocity=[0.4,0.0,1.0]``,
``nav2.FootprintApproach.time_before_collision=1.5``). For a teleop log, read its
/cmd_vel as the controller's commands: ``--remap /cmd_vel_nav=/cmd_vel``.

Approach polygons without ``points`` follow the robot footprint: with ``footprint: auto`` the
footprint topic when the log has it, else the costmap's padded footprint from the Nav2 file (the
local costmap's, else the global costmap's: what Nav2 publishes on ``published_footprint``).

Outputs: the smoothed and the monitored commands and the monitor's events (/navlog/events) in
replay.mcap; ``safety.json``: commands in and out, per polygon the commands it limited, slowed,
stopped or scaled on approach, its minimum predicted time to collision and the time it held the
robot stopped. Run live (``navlog record --pipeline safety``), the pipeline declares the command
topic it takes (``Pipeline.commands``): the scenario publishes there and the robot drives on the output.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal

from navlog.errors import ConfigError
from navlog.replay.config import find_config, known_configs, suggest
from navlog.replay.io import json_text
from navlog.replay.nav2 import Nav2Params, load_nav2_params
from navlog.replay.nav2.collision_monitor import CollisionMonitorParams, Decision
from navlog.replay.nav2.costmap import robot_footprint
from navlog.replay.nav2.overrides import nav2_override_items
from navlog.replay.nav2.velocity_smoother import VelocitySmootherParams
from navlog.replay.nodes.collision_monitor import EVENTS_TOPIC, CollisionMonitorNode
from navlog.replay.nodes.velocity_smoother import VelocitySmootherNode
from navlog.replay.pipelines import PipelineSpec, register
from navlog.replay.runtime.executor import Node
from navlog.replay.runtime.pipeline import Pipeline

DEFAULT_NAV2 = "kibot_safety"
# the monitor's action types as the summary counts them
ACTION_COUNTS = {"stop": "stopped", "slowdown": "slowed", "limit": "limited", "approach": "approach"}


@dataclass(frozen=True)
class Params:
    nav2_params: str = DEFAULT_NAV2  # a Nav2 parameter file: a name in config/nav2/ or a path
    velocity_smoother: Literal["on", "off"] = "on"
    collision_monitor: Literal["on", "off"] = "on"
    input_topic: str = "/cmd_vel_nav"  # the controller's commands
    smoothed_topic: str = "/cmd_vel_smoothed"  # smoother -> monitor
    output_topic: str = "/cmd_vel"  # what the robot drives on
    odom_topic: str = ""  # closed-loop smoother's odometry; empty: "/" + its odom_topic parameter
    # approach polygons without points: auto = the log's footprint topic if it has it, else the costmap's
    footprint: Literal["auto", "topic", "costmap"] = "auto"
    # Nav2 overrides, any key of the file, full or short: --set nav2.velocity_smoother.max_velocity=[0.4,0.0,1.0]
    nav2: dict[str, Any] = field(default_factory=dict)


def nav2_file(spec: str) -> Path:
    """A Nav2 parameter file: a path, or a name in config/nav2/ (ConfigError naming the known ones)."""
    path = Path(spec)
    if path.is_file():
        return path
    found = find_config("nav2", spec)
    if found is None:
        known = known_configs("nav2")
        raise ConfigError(
            f"Nav2 parameter file '{spec}' not found{suggest(spec, known)}; give a path "
            f"(--params nav2_params.yaml) or a name in config/nav2/: {', '.join(known) or 'none'}"
        )
    return found


def safety_nav2_params(params: Params, overrides: Sequence[str] | None = None) -> Nav2Params:
    """The Nav2 parameters of the filters that are on, with ``overrides`` (default: those of ``--set
    nav2.KEY``), errors in their blocks raised at once."""
    if overrides is None:
        overrides = nav2_override_items({"nav2": params.nav2})
    nav2 = load_nav2_params(nav2_file(params.nav2_params), overrides)
    blocks = [name for name in ("velocity_smoother", "collision_monitor") if getattr(params, name) == "on"]
    return nav2.require_valid(blocks)


def approach_footprint(nav2: Nav2Params, cm: CollisionMonitorParams, mode: str, log_topics: set[str]):
    """The footprint (base frame) for polygons without points, or None to follow their topics."""
    topics = sorted(
        "/" + t.lstrip("/")
        for name in cm.polygons
        if (p := cm.polygon_params.get(name)) is not None and p.enabled and p.type == "polygon" and not p.points
        for t in [p.footprint_topic if p.action_type == "approach" else p.polygon_sub_topic]
        if t
    )
    if not topics or mode == "topic" or (mode == "auto" and all(t in log_topics for t in topics)):
        return None
    costmap = nav2.local_costmap or nav2.global_costmap
    if costmap is None:
        raise ConfigError(
            f"{nav2.source}: polygons without points follow {', '.join(topics)}, which the log lacks, and the "
            "file has no local_costmap or global_costmap to take the footprint from; add a costmap with "
            "robot_radius or footprint, or give the polygons points"
        )
    return robot_footprint(costmap)


class SafetySummary(Node):
    """Counts the commands in and out and, per polygon, the monitor's decisions (reads ``last_decision``)."""

    name = "safety_summary"

    def __init__(self, input_topic: str, output_topic: str, monitor: CollisionMonitorNode | None) -> None:
        super().__init__()
        self.input_topic, self.output_topic, self.monitor = input_topic, output_topic, monitor
        self.commands_in = 0
        self.commands_out = 0
        self.actions: dict[str, Counter[str]] = {}
        self.min_ttc: dict[str, float] = {}
        self.stopped_ns: Counter[str] = Counter()
        self._held: tuple[str, int] | None = None  # (polygon, since) while a polygon holds the robot at zero
        self._seen: Decision | None = None
        self._last_t = 0

    def setup(self) -> None:
        self.subscribe(self.input_topic, self._on_input)
        self.subscribe(self.output_topic, self._on_output)
        if self.monitor is not None:  # added after the monitor: its decision is made when this runs
            self.subscribe(self.monitor.input_topic, self._on_decided)

    def _on_input(self, msg: Any, t: int) -> None:
        self.commands_in += 1

    def _on_output(self, msg: Any, t: int) -> None:
        self.commands_out += 1

    def _on_decided(self, msg: Any, t: int) -> None:
        assert self.monitor is not None  # subscribed only with a monitor
        d = self.monitor.last_decision
        if d is None or d is self._seen:  # a command the monitor skipped
            return
        self._seen, self._last_t = d, t
        a = d.action
        if a.polygon:
            self.actions.setdefault(a.polygon, Counter())[ACTION_COUNTS.get(a.action_type, a.action_type)] += 1
        for poly, ttc in d.collision_times.items():
            if ttc >= 0.0 and ttc < self.min_ttc.get(poly, float("inf")):
                self.min_ttc[poly] = ttc
        holder = a.polygon if a.polygon and a.velocity.is_zero() else ""
        if self._held is not None and self._held[0] != holder:
            self.stopped_ns[self._held[0]] += t - self._held[1]
            self._held = None
        if holder and self._held is None:
            self._held = (holder, t)

    def summary(self) -> dict[str, Any]:
        stopped = Counter(self.stopped_ns)
        if self._held is not None:
            stopped[self._held[0]] += self._last_t - self._held[1]
        names = sorted(set(self.actions) | set(self.min_ttc) | set(stopped))
        polygons = {
            name: {
                **{k: self.actions.get(name, Counter())[k] for k in ACTION_COUNTS.values()},
                "min_time_to_collision_s": round(self.min_ttc[name], 6) if name in self.min_ttc else None,
                "stopped_s": round(stopped[name] / 1e9, 9),
            }
            for name in names
        }
        return {"commands_in": self.commands_in, "commands_out": self.commands_out, "polygons": polygons}


def build(params: Params, log_topics: set[str], nav2_overrides: Sequence[str] | None = None) -> Pipeline:
    """The filters that are on; ``nav2_overrides`` (``KEY=VALUE``) replace those of ``params.nav2`` (the
    navigation pipeline gives its own, so that its stack and its filters read the same parameters)."""
    if params.velocity_smoother == "off" and params.collision_monitor == "off":
        raise ConfigError("pipeline 'safety': velocity_smoother and collision_monitor are both off; turn one on")
    nav2 = safety_nav2_params(params, nav2_overrides)
    nodes: list[Node] = []
    inputs = [params.input_topic]
    optional: list[str] = []
    topic = params.input_topic
    smoother = monitor = None
    if params.velocity_smoother == "on":
        out = params.smoothed_topic if params.collision_monitor == "on" else params.output_topic
        vs = nav2.velocity_smoother or VelocitySmootherParams()
        smoother = VelocitySmootherNode(vs, input_topic=topic, output_topic=out, odom_topic=params.odom_topic or None)
        inputs += [t for t in smoother.input_topics() if t not in inputs]
        nodes.append(smoother)
        topic = out
    if params.collision_monitor == "on":
        cm = nav2.collision_monitor
        if cm is None or not cm.polygons:
            raise ConfigError(
                f"{nav2.source}: no collision_monitor polygons; add a 'collision_monitor' block with 'polygons' "
                "or replay with --set collision_monitor=off"
            )
        footprint = approach_footprint(nav2, cm, params.footprint, log_topics)
        monitor = CollisionMonitorNode(cm, input_topic=topic, output_topic=params.output_topic, footprint=footprint)
        reads = ["/tf", "/tf_static", *sorted({"/" + s.topic.lstrip("/") for s in monitor.sources.values()})]
        optional += [t for t in [*reads, *monitor.shape_topics] if t not in inputs]
        nodes.append(monitor)
        topic = params.output_topic
    summary = SafetySummary(params.input_topic, topic, monitor)
    nodes.append(summary)
    outputs = ([smoother.output_topic] if smoother else []) + ([params.output_topic, EVENTS_TOPIC] if monitor else [])

    info = {
        "chain": " -> ".join(
            [params.input_topic]
            + (["velocity_smoother", smoother.output_topic] if smoother else [])
            + (["collision_monitor", params.output_topic] if monitor else [])
        ),
        "nav2_params": nav2.source,
    }
    if monitor is not None and any(s.is_set() for s in monitor.monitor.footprint_shapes()):
        info["footprint"] = "costmap footprint from the Nav2 file"
    commands = (params.input_topic, topic)
    return SafetyRun(params, nav2, smoother, monitor, summary, nodes, inputs, optional, outputs, info, commands)


class SafetyRun(Pipeline):
    """The velocity smoother and the collision monitor of one run (either may be off), counted by ``summary``."""

    def __init__(
        self,
        params: Params,
        nav2: Nav2Params,
        smoother: VelocitySmootherNode | None,
        monitor: CollisionMonitorNode | None,
        summary: SafetySummary,
        nodes: list[Node],
        inputs: list[str],
        optional: list[str],
        outputs: list[str],
        info: dict[str, str],
        commands: tuple[str, str],
    ) -> None:
        super().__init__("safety", nodes, inputs, optional, outputs, info=info, commands=commands)
        self.params, self.nav2, self.smoother, self.monitor, self.summary = params, nav2, smoother, monitor, summary

    def report(self) -> dict[str, Any]:
        smoother, monitor = self.smoother, self.monitor
        out = self.summary.summary()
        out["nav2_params"] = Path(self.nav2.source).name
        if smoother is not None:
            out["velocity_smoother"] = {
                "published": smoother.published,
                "skipped": dict(sorted(smoother.skipped_counts().items())),
            }
        if monitor is not None:
            s = monitor.summary()
            out["collision_monitor"] = {
                k: (round(v, 9) if isinstance(v, float) else v) for k, v in s.items() if k != "actions"
            }
        return out

    def write_artifacts(self, out: Path) -> dict[str, Path]:
        path = out / "safety.json"
        path.write_text(json_text.dumps(self.report(), indent=2, sort_keys=True) + "\n")
        return {"safety": path}

    def skipped(self) -> dict[str, int]:
        out: dict[str, int] = {}
        if self.smoother is not None:
            out.update({f"velocity_smoother: {k}": v for k, v in self.smoother.skipped_counts().items()})
        if self.monitor is not None:
            out.update({f"collision_monitor: {k}": v for k, v in self.monitor.skipped_counts().items()})
        return out

    def nothing_produced(self) -> str | None:
        if self.summary.commands_in:
            return None
        topic = self.params.input_topic
        return f"no command on {topic} (for a teleop log, read its commands with --remap {topic}=/cmd_vel)"


@register
class Safety(PipelineSpec):
    """Nav2's velocity smoother and collision monitor between a controller's commands and the robot."""

    name = "safety"
    params_class = Params
    params_file_key = "nav2_params"  # `navlog replay/record --pipeline safety --params nav2_params.yaml`
    facts = PipelineSpec.facts | {"safety"}
    summary_facts = ("safety",)

    @classmethod
    def build(cls, params: Params, log_topics: set[str]) -> Pipeline:
        return build(params, log_topics)
