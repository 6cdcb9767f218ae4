"""Costmap layer plugins by Nav2 type name: the parameters each reads and the layer class that runs it.

``nav2_costmap_2d::VoxelLayer`` runs as the obstacle layer (2-D, its height range capped). The
other layers and filters Nav2 ships are known, so a file using them is not an error, but navlog
neither reads nor runs them.
"""

from __future__ import annotations

from navlog.replay.nav2.costmap.inflation_layer import InflationLayer, InflationLayerParams
from navlog.replay.nav2.costmap.layer import Layer
from navlog.replay.nav2.costmap.obstacle_layer import ObstacleLayer, ObstacleLayerParams
from navlog.replay.nav2.costmap.static_layer import StaticLayer, StaticLayerParams
from navlog.replay.nav2.plugins import Plugin, PluginRegistry

LAYERS: PluginRegistry[Layer] = PluginRegistry(
    "costmap layer",
    {
        "nav2_costmap_2d::StaticLayer": Plugin(StaticLayerParams, StaticLayer),
        "nav2_costmap_2d::ObstacleLayer": Plugin(ObstacleLayerParams, ObstacleLayer),
        "nav2_costmap_2d::VoxelLayer": Plugin(ObstacleLayerParams, ObstacleLayer),
        "nav2_costmap_2d::InflationLayer": Plugin(InflationLayerParams, InflationLayer),
        # known to Nav2, read but not implemented
        "nav2_costmap_2d::RangeSensorLayer": None,
        "nav2_costmap_2d::DenoiseLayer": None,
        "nav2_costmap_2d::PluginContainerLayer": None,
        "nav2_costmap_2d::KeepoutFilter": None,
        "nav2_costmap_2d::SpeedFilter": None,
        "nav2_costmap_2d::BinaryFilter": None,
        "spatio_temporal_voxel_layer/SpatioTemporalVoxelLayer": None,
    },
)
