"""The navigation pipeline: Nav2's planner, controller, behaviours and navigator, then its safety filters.

``NavigationStack`` (``navlog.replay.nodes.navigation``) runs the global and local costmaps, the
planner server, the controller server, the behaviour server and the navigator on the goals; it
publishes ``/plan``, ``/cmd_vel_nav``, ``/local_plan``, both costmaps, ``/goal_pose`` and its events.
After it, the velocity smoother and the collision monitor (the safety pipeline, ``auto``: when the
Nav2 file configures them) turn ``/cmd_vel_nav`` into ``/cmd_vel``.

The same pipeline runs live (``navlog record --scenario nav_tour``: the scenario names the Nav2 file
and the goals, and the robot drives on ``/cmd_vel``) and in replay (``navlog replay LOG --pipeline
navigation --params nav2.yaml --set goals=...``): open loop on the log's TF, odometry, scans and map,
the same parameters regenerate the recorded ``/plan`` and ``/cmd_vel_nav`` bit for bit.

Nav2 parameters: the file (``nav2_params``), with overrides as the planner pipeline takes them: ``--set
controller_server.FollowPath.desired_linear_vel=0.4`` (a node block, then a full or short key path), or
any key of the file with ``--set nav2.KEY=VALUE`` (``nav2.velocity_smoother.max_velocity=[0.4,0.0,1.0]``:
the smoother's and the monitor's names are their switches here). The filters run on the same overrides.

Goals: a goals YAML (``goals``: a name in config/goals/ or a path), or, empty, ``/goal_pose`` from the log.
Writes ``navigation.json``: per goal its result (succeeded or failed with Nav2's error code), time,
recoveries and replans; the safety filters' summary when they ran.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Literal

from navlog.errors import ConfigError
from navlog.replay.io import json_text
from navlog.replay.io.map_server import load_map
from navlog.replay.limits import check_seed
from navlog.replay.nav2 import load_nav2_params
from navlog.replay.nav2.overrides import nav2_override_items
from navlog.replay.pipelines import PipelineSpec, log_odometry, register, safety
from navlog.replay.pipelines.planner import OnMapToGoals, load_named_goals
from navlog.replay.runtime.executor import Node
from navlog.replay.runtime.pipeline import Pipeline

if TYPE_CHECKING:
    from navlog.replay.nodes.navigation import NavGoal, NavigationStack

# every block the stack runs: an error in one is raised before the run, not left to its defaults
NAV2_BLOCKS = (
    "global_costmap",
    "local_costmap",
    "planner_server",
    "controller_server",
    "bt_navigator",
    "behavior_server",
    "waypoint_follower",
)
DEFAULT_NAV2 = "nav_go2"


@dataclass(frozen=True)
class Params:
    nav2_params: str = DEFAULT_NAV2  # a Nav2 parameter file: a name in config/nav2/ or a path
    goals: str = ""  # a goals YAML (name in config/goals/ or a path); empty: /goal_pose from the log
    mode: Literal["waypoints", "through_poses"] = "waypoints"
    map: str = ""  # a map_server YAML for the static layer; empty: /map from the log
    velocity_smoother: Literal["auto", "on", "off"] = "auto"  # auto: on when the Nav2 file configures it
    collision_monitor: Literal["auto", "on", "off"] = "auto"
    cmd_topic: str = "/cmd_vel_nav"  # the controller's and behaviours' commands
    output_topic: str = "/cmd_vel"  # what the robot drives on
    odom_topic: str = "/odom"
    seed: int = 0  # the seed of a sampling controller (MPPI)
    # Nav2 overrides of the file's node blocks (--set NODE.KEY=VALUE, KEY a full or short path, as the planner's)
    global_costmap: dict[str, Any] = field(default_factory=dict)  # --set global_costmap.KEY=VALUE
    local_costmap: dict[str, Any] = field(default_factory=dict)  # --set local_costmap.KEY=VALUE
    planner_server: dict[str, Any] = field(default_factory=dict)  # --set planner_server.KEY=VALUE
    controller_server: dict[str, Any] = field(default_factory=dict)  # --set controller_server.FollowPath.KEY=VALUE
    behavior_server: dict[str, Any] = field(default_factory=dict)  # --set behavior_server.KEY=VALUE
    bt_navigator: dict[str, Any] = field(default_factory=dict)  # --set bt_navigator.KEY=VALUE
    # any Nav2 key, full or short (the smoother's and monitor's: nav2.velocity_smoother.max_velocity=[...])
    nav2: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        check_seed(self.seed)


OVERRIDE_BLOCKS = (
    "global_costmap",
    "local_costmap",
    "planner_server",
    "controller_server",
    "behavior_server",
    "bt_navigator",
    "nav2",
)


def nav2_overrides(params: Params) -> list[str]:
    """The ``KEY=VALUE`` Nav2 overrides of ``--set NODE.KEY`` and ``--set nav2.KEY``."""
    return nav2_override_items({name: getattr(params, name) for name in OVERRIDE_BLOCKS})


def filter_switches(params: Params, nav2: Any) -> dict[str, str]:
    """'on'/'off' for the velocity smoother and the collision monitor (auto: on when the file has the block)."""
    out = {}
    for name in ("velocity_smoother", "collision_monitor"):
        mode = getattr(params, name)
        out[name] = ("on" if getattr(nav2, name) is not None else "off") if mode == "auto" else mode
    return out


def with_odometry(params: Params, topic: str, frame: str) -> Params:
    """``params`` reading the robot's odometry on ``topic`` in ``frame``: the stack's ``odom_topic``
    (unless set to another than /odom), and the Nav2 file's odometry topics and ``odom`` frames
    (``navlog.replay.nav2.overrides.odometry_overrides``) as ``nav2`` overrides before the given ones."""
    from dataclasses import replace

    from navlog.replay.config import load_yaml
    from navlog.replay.nav2.overrides import DEFAULT_ODOM_TOPIC, odometry_overrides

    doc = load_yaml(safety.nav2_file(params.nav2_params))
    nav2 = {**odometry_overrides(doc, topic, frame), **params.nav2}
    odom_topic = topic if params.odom_topic == DEFAULT_ODOM_TOPIC else params.odom_topic
    return replace(params, odom_topic=odom_topic, nav2=nav2)


def settle(params: Params, reader: Any) -> Params:
    """Before replaying: the odometry the recording names (``log_odometry``), when it is not /odom in ``odom``."""
    found = log_odometry(reader)
    return with_odometry(params, *found) if found is not None else params


def build(params: Params, log_topics: set[str]) -> Pipeline:
    from navlog.replay.nodes.navigation import NavGoal, NavigationStack

    path = safety.nav2_file(params.nav2_params)
    overrides = nav2_overrides(params)
    nav2 = load_nav2_params(path, overrides).require_valid(NAV2_BLOCKS)
    missing = [name for name in ("controller_server", "planner_server") if getattr(nav2, name) is None]
    if missing:
        raise ConfigError(
            f"{path}: no {' and no '.join(missing)} block: navigation needs a planner and a controller "
            "(a Nav2 file such as config/nav2/nav_go2.yaml has both); give one with --params"
        )
    goals: list[NavGoal] = []
    if params.goals:
        named, _ = load_named_goals(params.goals)
        goals = [NavGoal(name, pose) for name, pose in named]
    static_map = load_map(params.map) if params.map else None
    switches = filter_switches(params, nav2)
    filtered = "on" in switches.values()
    stack = NavigationStack(
        nav2,
        goals=goals,
        mode=params.mode,
        static_map=static_map,
        seed=params.seed,
        cmd_topic=params.cmd_topic if filtered else params.output_topic,
        odom_topic=params.odom_topic,
    )
    nodes = list(stack.nodes)
    produced = set(stack.outputs)  # regenerated: the log's copies are not read (nor recorded twice)
    inputs = ["/tf"] + ([] if goals else ["/goal_pose"])
    optional = ["/tf_static", params.odom_topic, "/map", *stack.sensor_topics]
    outputs = list(stack.outputs)
    filters: Pipeline | None = None
    if filtered:
        filters = safety.build(
            safety.Params(
                nav2_params=str(path),
                velocity_smoother=switches["velocity_smoother"],  # type: ignore[arg-type]
                collision_monitor=switches["collision_monitor"],  # type: ignore[arg-type]
                input_topic=params.cmd_topic,
                output_topic=params.output_topic,
            ),
            log_topics | produced,  # the stack publishes its footprint live and in replay alike
            nav2_overrides=overrides,
        )
        nodes += filters.nodes
        optional += [t for t in filters.inputs + filters.optional_inputs if t not in produced]
        outputs += [t for t in filters.outputs if t not in outputs]
    optional = [t for t in dict.fromkeys(optional) if t not in inputs and t not in produced]

    info = {
        "nav2_params": str(path),
        "goals": params.goals or "/goal_pose from the log",
        "velocity_smoother": switches["velocity_smoother"],
        "collision_monitor": switches["collision_monitor"],
    }
    return NavigationRun(path, stack, goals, filters, nodes, inputs, optional, outputs, info)


class NavigationRun(Pipeline):
    """Nav2's stack on ``goals`` (empty: /goal_pose from the log), then the safety ``filters`` when on."""

    def __init__(
        self,
        path: Path,
        stack: NavigationStack,
        goals: list[NavGoal],
        filters: Pipeline | None,
        nodes: list[Node],
        inputs: list[str],
        optional: list[str],
        outputs: list[str],
        info: dict[str, str],
    ) -> None:
        super().__init__("navigation", nodes, inputs, optional, outputs, info=info)
        self.path, self.stack, self.goals, self.filters = path, stack, goals, filters

    def report(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "nav2_params": self.path.name,
            "goals": [
                {
                    "name": r.name,
                    "goal": [round(v, 6) for v in r.goal],
                    "status": r.status,
                    "code": r.code,
                    "message": r.message,
                    "time_s": round((r.end_ns - r.start_ns) / 1e9, 9),
                    "recoveries": r.recoveries,
                    "replans": r.replans,
                }
                for r in self.stack.results
            ],
        }
        out["planned_goals"] = len(self.goals)
        out["succeeded"] = sum(r.status == "succeeded" for r in self.stack.results)
        out["failed"] = sum(r.status == "failed" for r in self.stack.results)
        if self.filters is not None:
            out["safety_filters"] = {"chain": self.filters.info.get("chain", "")}
        return out

    def write_artifacts(self, out: Path) -> dict[str, Path]:
        written: dict[str, Path] = {}
        if self.filters is not None:
            written.update(self.filters.write_artifacts(out))
        nav = out / "navigation.json"
        nav.write_text(json_text.dumps(self.report(), indent=2, sort_keys=True) + "\n")
        written["navigation"] = nav
        return written

    def skipped(self) -> dict[str, int]:
        out = {f"navigation: {k}": v for k, v in self.stack.skipped().items()}
        if self.filters is not None:
            out.update(self.filters.skipped())
        return out

    def nothing_produced(self) -> str | None:
        if self.stack.results:
            return None
        if not self.goals:
            return "no goal: the log has no /goal_pose; give the goals with --set goals=GOALS.yaml"
        return "no goal ended: the log ends before the first goal was reached or failed"

    def done(self) -> bool:
        return bool(self.stack.done)


@register
class Navigation(OnMapToGoals):
    """Nav2's planner, controller, behaviours and navigator on goals, then the safety filters; it drives the robot."""

    name = "navigation"
    params_class = Params
    params_file_key = "nav2_params"  # `navlog replay/record --pipeline navigation --params nav2_params.yaml`
    facts = PipelineSpec.facts | {"goals", "min_clearance", "safety", "navigation", "all_goals_reached"}

    @classmethod
    def settle(cls, params: Params, reader: Any, log_to: dict[str, str]) -> Params:
        return settle(params, reader)

    @classmethod
    def build(cls, params: Params, log_topics: set[str]) -> Pipeline:
        return build(params, log_topics)
