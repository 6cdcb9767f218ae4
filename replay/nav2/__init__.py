"""Nav2 without ROS: parameter files read and checked, costmap layers, planners, the velocity smoother
and the collision monitor; room for controllers and the navigator.

Parameters: ``load_nav2_params(path)`` reads a ``nav2_params.yaml`` as Nav2 would into typed
dataclasses and lists every ``Problem`` (``ERROR``, ``WARNING``, ``NOTE``) with its YAML path and
line; ``apply_nav2_overrides`` applies ``--set KEY=VALUE`` overrides (full or short key paths).

Packages and modules, one per Nav2 component; each plugin module holds its parameter dataclass and
its code, and a registry per plugin kind maps Nav2 plugin type names to both, as pluginlib does:

- ``costmap``: the layered costmap and its layers (``costmap.LAYERS``);
- ``planners``: NavFn and a Smac-2D-like planner (``planners.PLANNERS``, ``planners.make_planner``);
- ``controllers``: the controller server's controllers and checkers (parameters only, so far);
- ``velocity_smoother`` (``VelocitySmoother``) and ``collision_monitor`` (``CollisionMonitor``:
  polygons, sources, actions), each with its parameters;
- ``behaviors``: the behaviour server's Spin, BackUp and Wait; ``navigator``: the BT navigator's default
  trees (replanning, recoveries) and the waypoint follower, as a state machine on sim time;
- ``amcl``: AMCL's particle filter (``ParticleFilter``: motion models, likelihood field, KLD
  resampling, recovery) and its parameters (``AmclParams``);
- ``params`` (the file), ``overrides``, ``schema`` (Nav2's reading of a section: the typed-parameter
  reader of ``navlog.replay.config`` with Nav2's differences), ``plugins``
  (the registry type).

Names are imported on first use, so importing the package stays cheap.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.replay.nav2.overrides import apply_nav2_overrides, resolve_key
    from navlog.replay.nav2.params import (
        IMPLEMENTED_NODES,
        READ_ONLY_NODES,
        Nav2Params,
        default_nav2_params,
        load_nav2_params,
        parse_nav2_params,
        parse_nav2_text,
    )
    from navlog.replay.nav2.schema import ERROR, NOTE, WARNING, Problem

__all__ = [
    "ERROR",
    "IMPLEMENTED_NODES",
    "NOTE",
    "READ_ONLY_NODES",
    "WARNING",
    "Nav2Params",
    "Problem",
    "apply_nav2_overrides",
    "default_nav2_params",
    "load_nav2_params",
    "parse_nav2_params",
    "parse_nav2_text",
    "resolve_key",
]

# the module, below this package, that defines each public name
_MODULES = {
    "apply_nav2_overrides": "overrides",
    "resolve_key": "overrides",
    "IMPLEMENTED_NODES": "params",
    "READ_ONLY_NODES": "params",
    "Nav2Params": "params",
    "default_nav2_params": "params",
    "load_nav2_params": "params",
    "parse_nav2_params": "params",
    "parse_nav2_text": "params",
    "ERROR": "schema",
    "NOTE": "schema",
    "WARNING": "schema",
    "Problem": "schema",
}
__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
