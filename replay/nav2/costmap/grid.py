"""A costmap's parameters and its master grid: size, resolution, origin, footprint, cost array.

The grid follows Nav2: ``costs[my, mx]`` (row 0 = lowest y), world -> cell truncates, cell -> world
is the cell centre. ``CostmapGrid`` is what a layer sees of the layered costmap (``Costmap2D``
adds the layers and their update). A static map comes in as any ``StaticMap`` (an ``OccupancyMap``).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar, Protocol

import numpy as np

from navlog.replay.geometry import cell_to_world, world_to_cell
from navlog.replay.limits import MAX_COSTMAP_CELLS, MAX_RATE_HZ, MAX_TRANSFORM_TOLERANCE_S, budget
from navlog.replay.nav2.costmap.cost_values import FREE_SPACE, NO_INFORMATION
from navlog.replay.nav2.costmap.footprint import footprint_radii, parse_footprint, robot_footprint
from navlog.replay.nav2.schema import param

# Nav2's layers when a costmap's parameters list no ``plugins``: section name -> plugin type
DEFAULT_LAYER_PLUGINS = {
    "static_layer": "nav2_costmap_2d::StaticLayer",
    "obstacle_layer": "nav2_costmap_2d::ObstacleLayer",
    "inflation_layer": "nav2_costmap_2d::InflationLayer",
}


class StaticMap(Protocol):
    """An occupancy map as the static layer reads it (``OccupancyMap`` is one): values -1 or 0..100,
    ``data[my, mx]`` with row 0 the lowest y, ``origin`` (x, y, yaw) of cell (0, 0)'s outer corner."""

    @property
    def data(self) -> np.ndarray: ...

    @property
    def resolution(self) -> float: ...

    @property
    def origin(self) -> tuple[float, float, float]: ...

    @property
    def width(self) -> int: ...

    @property
    def height(self) -> int: ...


class LayerParams(Protocol):
    """What every layer's parameter dataclass has (see ``costmap.registry`` for the layers)."""

    @property
    def plugin(self) -> str: ...

    @property
    def enabled(self) -> bool: ...


@dataclass(frozen=True)
class CostmapParams:
    """One costmap node's parameters (``global_costmap`` or ``local_costmap``) with its layers' parameters."""

    global_frame: str = "map"
    robot_base_frame: str = "base_link"
    transform_tolerance: float = param(0.3, ge=0.0, le=MAX_TRANSFORM_TOLERANCE_S)
    update_frequency: float = param(5.0, gt=0.0, le=MAX_RATE_HZ)
    publish_frequency: float = param(1.0, ge=0.0, le=MAX_RATE_HZ)
    width: int = param(5, gt=0)
    height: int = param(5, gt=0)
    resolution: float = param(0.1, gt=0.0)
    origin_x: float = 0.0
    origin_y: float = 0.0
    rolling_window: bool = False
    track_unknown_space: bool = False
    trinary_costmap: bool = True
    lethal_cost_threshold: int = param(100, ge=0, le=100)
    unknown_cost_value: int = param(255, ge=0, le=255)
    use_maximum: bool = False
    footprint: str = "[]"
    robot_radius: float = param(0.1, ge=0.0)
    footprint_padding: float = param(0.01, ge=0.0)
    plugins: tuple[str, ...] = ("static_layer", "obstacle_layer", "inflation_layer")
    filters: tuple[str, ...] = ()
    always_send_full_costmap: bool = False
    map_topic: str = "map"
    use_sim_time: bool = False
    layers: dict[str, LayerParams] = field(default_factory=dict)
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "always_send_full_costmap",
        "filters",
        "use_sim_time",
        "footprint_topic",
        "initial_transform_timeout",
        "map_vis_z",
        "clearable_layers",
        "subscribe_to_stamped_footprint",
        "introspection_mode",
        "service_introspection_mode",
        "map_subscribe_transient_local",
    )

    def __post_init__(self) -> None:
        cells = (self.width / self.resolution) * (self.height / self.resolution)
        size = f"width {self.width} m, height {self.height} m, resolution {self.resolution} m"
        budget(
            "resolution", f"(width / resolution) x (height / resolution) for {size}", cells, MAX_COSTMAP_CELLS, " cells"
        )

    def footprint_points(self) -> list[tuple[float, float]]:
        """The footprint polygon (unpadded); empty when robot_radius is used."""
        return parse_footprint(self.footprint)


class CostmapGrid:
    """The master grid of a costmap built from a CostmapParams, with its footprint."""

    def __init__(self, params: CostmapParams, name: str = "global_costmap") -> None:
        self.params = params
        self.name = name
        self.footprint = robot_footprint(params)
        self.inscribed_radius, self.circumscribed_radius = footprint_radii(self.footprint)
        self.resolution = float(params.resolution)
        self.size_x = max(int(params.width / self.resolution), 1)
        self.size_y = max(int(params.height / self.resolution), 1)
        self.origin_x, self.origin_y = float(params.origin_x), float(params.origin_y)
        self.default = NO_INFORMATION if params.track_unknown_space else FREE_SPACE
        self.costs = np.full((self.size_y, self.size_x), self.default, dtype=np.uint8)
        self.skipped: dict[str, int] = {}  # what was left out, by reason: the replay report counts them

    # ---------------------------------------------------------- geometry
    def world_to_cell(self, x, y):
        mx = world_to_cell(x, self.origin_x, self.resolution)
        my = world_to_cell(y, self.origin_y, self.resolution)
        if mx.ndim == 0:
            return int(mx), int(my)
        return mx, my

    def cell_to_world(self, mx, my):
        x = cell_to_world(mx, self.origin_x, self.resolution)
        y = cell_to_world(my, self.origin_y, self.resolution)
        if np.ndim(x) == 0:
            return float(x), float(y)
        return x, y

    def contains(self, mx: int, my: int) -> bool:
        return 0 <= mx < self.size_x and 0 <= my < self.size_y

    def cell_centres(self) -> tuple[np.ndarray, np.ndarray]:
        xs = cell_to_world(np.arange(self.size_x), self.origin_x, self.resolution)
        ys = cell_to_world(np.arange(self.size_y), self.origin_y, self.resolution)
        return np.meshgrid(xs, ys)

    def cost_at(self, x: float, y: float) -> int | None:
        mx, my = self.world_to_cell(x, y)
        if not self.contains(mx, my):
            return None
        return int(self.costs[my, mx])
