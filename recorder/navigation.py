"""Navigation runs: what a ``navigate`` scenario adds to a recording.

- ``MapServerNode`` publishes the world's obstacles, grown by the scenario's ``map_margin``, on /map
  at t = 0 (latched), as map_server serves the Go2 setup's fixed map;
- ``navigation_pipeline`` builds the navigation pipeline (``navlog.replay.pipelines.navigation``)
  from the scenario's Nav2 file and goals, the run's seed, and any ``--set`` overrides: the same
  pipeline ``navlog replay --pipeline navigation`` runs on the log afterwards.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from navlog.recorder.scenarios import ScenarioSpec
from navlog.recorder.world import World, occupancy
from navlog.replay.runtime.executor import Node
from navlog.replay.runtime.pipeline import Pipeline

MAP_TOPIC = "/map"
ONCE_NS = 10**18  # the period of a timer that fires once


class MapServerNode(Node):
    """Publishes one OccupancyGrid on /map at t = 0 (the topic is latched in the recorded QoS)."""

    name = "map_server"

    def __init__(self, grid: Any, topic: str = MAP_TOPIC) -> None:
        super().__init__()
        self.grid, self.topic = grid, topic

    def setup(self) -> None:
        self.create_timer(ONCE_NS, self._publish, start_ns=0)

    def _publish(self, t_ns: int) -> None:
        from navlog.replay import messages

        self.publish(self.topic, messages.OCCUPANCY_GRID, self.grid.to_msg(t_ns))


def world_map_node(scenario: ScenarioSpec, world: World) -> MapServerNode | None:
    """The map server of a navigate scenario with ``map: world``, else None."""
    if scenario.kind != "navigate" or scenario.map != "world":
        return None
    return MapServerNode(occupancy(world, margin=scenario.map_margin))


def navigation_pipeline(
    scenario: ScenarioSpec, seed: int, nav2_params: str | Path | None = None, overrides: Sequence[str] = ()
) -> Pipeline:
    """The navigation pipeline of a navigate scenario (``nav2_params`` replaces the scenario's file)."""
    from navlog.replay.pipelines import pipeline_spec
    from navlog.replay.session import pipeline_params

    sets = [
        f"nav2_params={nav2_params or scenario.nav2_params}",
        f"goals={scenario.goals}",
        f"mode={scenario.navigation}",
        f"seed={seed}",
        *overrides,
    ]
    params = pipeline_params("navigation", None, overrides=sets)
    return pipeline_spec("navigation").build(params, set())


def amcl_node(scenario: ScenarioSpec, world: World, seed: int) -> Node:
    """Nav2's AMCL, live: the ``amcl`` block of the scenario's Nav2 file (Nav2's defaults without one), the
    world's obstacles as its map, the filter started at the scenario's start pose, its random numbers
    from the run's seed (the localization pipeline's stream: a replay with the same seed draws the same)."""
    from dataclasses import replace

    import numpy as np

    from navlog.replay.nav2 import default_nav2_params, load_nav2_params
    from navlog.replay.nav2.amcl import AmclParams
    from navlog.replay.nodes.amcl import AmclNode
    from navlog.replay.pipelines.safety import nav2_file

    nav2 = load_nav2_params(nav2_file(scenario.nav2_params)) if scenario.nav2_params else default_nav2_params()
    params = nav2.require_valid(["amcl"]).amcl or AmclParams()
    x, y, yaw = scenario.start
    params = replace(params, set_initial_pose=True, initial_pose_x=x, initial_pose_y=y, initial_pose_yaw=yaw)
    rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])
    return AmclNode(params, occupancy(world, margin=0.0), rng)
