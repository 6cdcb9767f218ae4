"""Small costmaps for the costmap tests: parameters from layers, maps from arrays, one-source obstacle layers."""

from __future__ import annotations

import numpy as np

from navlog.replay.nav2.costmap import (
    Costmap2D,
    CostmapParams,
    Observation,
    ObservationSourceParams,
    ObstacleLayerParams,
)
from navlog.replay.occupancy_map import OccupancyMap

SQUARE_02 = "[[0.2, 0.2], [0.2, -0.2], [-0.2, -0.2], [-0.2, 0.2]]"  # inscribed radius 0.2


def costmap_params(**kw) -> CostmapParams:
    layers = kw.pop("layers")
    return CostmapParams(plugins=tuple(layers), layers=layers, **kw)


def static_map(data: np.ndarray, res: float = 0.05) -> OccupancyMap:
    return OccupancyMap(data=data.astype(np.int8), resolution=res, origin=(0.0, 0.0, 0.0))


def obstacle_costmap(**source_kw) -> Costmap2D:
    src = ObservationSourceParams(
        topic="/scan", data_type="LaserScan", marking=True, clearing=True, max_obstacle_height=2.0, **source_kw
    )
    layer = ObstacleLayerParams(observation_sources=("scan",), sources={"scan": src}, footprint_clearing_enabled=False)
    return Costmap2D(
        costmap_params(width=10, height=10, resolution=0.1, track_unknown_space=True, layers={"obstacle_layer": layer})
    )


def observation(points, origin=(5.05, 5.05, 0.2)):
    return Observation(origin=np.array(origin, float), points=np.array(points, float), source="scan")
