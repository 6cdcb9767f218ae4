"""A 2-D layered costmap as Nav2's ``nav2_costmap_2d`` computes it: static, obstacle and inflation layers.

``Costmap2D(params)`` builds the layers a ``CostmapParams`` lists, each by its Nav2 plugin type
through ``LAYERS``; ``set_static_map``, ``add_observation`` and ``update`` run it. One module per
layer holds that layer's parameters and code (``static_layer``, ``obstacle_layer``,
``inflation_layer``); ``layer`` is the interface they share, ``grid`` the master grid and the
costmap's parameters, ``footprint`` the robot footprint, ``raytrace`` the cells along rays,
``observation`` the sensor observations, ``cost_values`` Nav2's cost values.

Names are imported on first use, so importing the package stays cheap.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from navlog.replay import lazy_exports

if TYPE_CHECKING:
    from navlog.replay.nav2.costmap.cost_values import (
        FREE_SPACE,
        INSCRIBED,
        LETHAL,
        NO_INFORMATION,
        costs_from_occupancy,
        occupancy_values,
    )
    from navlog.replay.nav2.costmap.costmap_2d import Costmap2D, default_costmap_params
    from navlog.replay.nav2.costmap.footprint import (
        footprint_radii,
        pad_footprint,
        parse_footprint,
        radius_footprint,
        robot_footprint,
        transform_footprint,
    )
    from navlog.replay.nav2.costmap.grid import CostmapGrid, CostmapParams
    from navlog.replay.nav2.costmap.inflation_layer import InflationLayer, InflationLayerParams, inflation_costs
    from navlog.replay.nav2.costmap.layer import Bounds, Layer
    from navlog.replay.nav2.costmap.observation import (
        Observation,
        ObservationSourceParams,
        scan_points,
        scan_points_inf_valid,
    )
    from navlog.replay.nav2.costmap.obstacle_layer import ObstacleLayer, ObstacleLayerParams
    from navlog.replay.nav2.costmap.registry import LAYERS
    from navlog.replay.nav2.costmap.static_layer import StaticLayer, StaticLayerParams

__all__ = [
    "FREE_SPACE",
    "INSCRIBED",
    "LAYERS",
    "LETHAL",
    "NO_INFORMATION",
    "Bounds",
    "Costmap2D",
    "CostmapGrid",
    "CostmapParams",
    "InflationLayer",
    "InflationLayerParams",
    "Layer",
    "Observation",
    "ObservationSourceParams",
    "ObstacleLayer",
    "ObstacleLayerParams",
    "StaticLayer",
    "StaticLayerParams",
    "costs_from_occupancy",
    "default_costmap_params",
    "footprint_radii",
    "inflation_costs",
    "occupancy_values",
    "pad_footprint",
    "parse_footprint",
    "radius_footprint",
    "robot_footprint",
    "scan_points",
    "scan_points_inf_valid",
    "transform_footprint",
]

# the module, below this package, that defines each public name
_MODULES = {
    "FREE_SPACE": "cost_values",
    "INSCRIBED": "cost_values",
    "LETHAL": "cost_values",
    "NO_INFORMATION": "cost_values",
    "costs_from_occupancy": "cost_values",
    "occupancy_values": "cost_values",
    "Costmap2D": "costmap_2d",
    "default_costmap_params": "costmap_2d",
    "footprint_radii": "footprint",
    "pad_footprint": "footprint",
    "parse_footprint": "footprint",
    "radius_footprint": "footprint",
    "robot_footprint": "footprint",
    "transform_footprint": "footprint",
    "CostmapGrid": "grid",
    "CostmapParams": "grid",
    "InflationLayer": "inflation_layer",
    "InflationLayerParams": "inflation_layer",
    "inflation_costs": "inflation_layer",
    "Bounds": "layer",
    "Layer": "layer",
    "Observation": "observation",
    "ObservationSourceParams": "observation",
    "scan_points": "observation",
    "scan_points_inf_valid": "observation",
    "ObstacleLayer": "obstacle_layer",
    "ObstacleLayerParams": "obstacle_layer",
    "LAYERS": "registry",
    "StaticLayer": "static_layer",
    "StaticLayerParams": "static_layer",
}
__getattr__, __dir__ = lazy_exports(__name__, _MODULES)
