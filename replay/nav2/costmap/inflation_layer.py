"""Nav2's inflation layer: costs decaying with the distance to obstacles, from the robot's footprint out."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from navlog.replay.limits import MAX_INFLATION_CELLS, MAX_INFLATION_RADIUS_M, budget
from navlog.replay.nav2.costmap.cost_values import FREE_SPACE, INSCRIBED, LETHAL
from navlog.replay.nav2.costmap.grid import CostmapGrid
from navlog.replay.nav2.costmap.kernels import kernels
from navlog.replay.nav2.costmap.layer import Bounds, Layer, Robot
from navlog.replay.nav2.plugins import PluginParams
from navlog.replay.nav2.schema import param


@dataclass(frozen=True)
class InflationLayerParams(PluginParams):
    """``nav2_costmap_2d::InflationLayer`` parameters."""

    plugin: str = "nav2_costmap_2d::InflationLayer"
    enabled: bool = True
    inflation_radius: float = param(0.55, ge=0.0, le=MAX_INFLATION_RADIUS_M)
    cost_scaling_factor: float = param(10.0, ge=0.0)
    inflate_unknown: bool = False
    inflate_around_unknown: bool = False


def inflation_costs(d_cells: np.ndarray, resolution: float, inscribed: float, k: float) -> np.ndarray:
    """Nav2's inflation cost for distances in cells to the nearest lethal cell."""
    d = np.asarray(d_cells, dtype=np.float64)
    metres = d * resolution
    cost = np.floor(252.0 * np.exp(-k * (metres - inscribed))).astype(np.int64)
    cost = np.where(metres <= inscribed, INSCRIBED, cost)
    cost = np.where(d == 0, LETHAL, cost)
    return np.clip(cost, 0, 255).astype(np.uint8)


class InflationLayer(Layer[InflationLayerParams]):
    """Costs that fall off with the distance to the nearest lethal cell, up to ``inflation_radius``.

    The update bounds grow by the radius; distances come from an exact Euclidean distance transform
    over the bounds plus the radius only, as the newest Nav2 computes them, and costs from a table by
    integer squared distance (Nav2 caches them per cell offset). The radius spans at most
    ``MAX_INFLATION_CELLS`` cells of the costmap's resolution (BoundError otherwise, on creation and
    whenever the costmap takes another resolution).
    """

    def __init__(self, name: str, params: InflationLayerParams, costmap: CostmapGrid) -> None:
        super().__init__(name, params, costmap)
        self.need_full = True
        self._table_key: tuple | None = None
        self._table = np.empty(0, dtype=np.uint8)
        self._check_cell_radius()

    @property
    def cell_radius(self) -> int:
        return int(math.ceil(self.p.inflation_radius / self.cm.resolution))

    def _check_cell_radius(self) -> None:
        """BoundError on ``<costmap>.<layer>.inflation_radius`` when the radius spans more than
        ``MAX_INFLATION_CELLS`` cells at the costmap's resolution."""
        budget(
            f"{self.cm.name}.{self.name}.inflation_radius",
            f"inflation_radius / resolution ({self.p.inflation_radius} m / {self.cm.resolution} m)",
            self.p.inflation_radius / self.cm.resolution,
            MAX_INFLATION_CELLS,
            " cells",
        )

    def match_size(self) -> None:
        self._check_cell_radius()
        self.need_full = True

    def update_bounds(self, robot: Robot, bounds: Bounds | None) -> Bounds | None:
        cm = self.cm
        if self.need_full:
            self.need_full = False
            return 0, 0, cm.size_x, cm.size_y
        if bounds is None:
            return None
        r = self.cell_radius
        x0, y0, x1, y1 = bounds
        return max(x0 - r, 0), max(y0 - r, 0), min(x1 + r, cm.size_x), min(y1 + r, cm.size_y)

    def _cost_table(self) -> np.ndarray:
        """Inflation cost by squared distance in cells (0 .. r^2), then 0 for 'beyond the radius'."""
        r = self.cell_radius
        key = (r, self.cm.resolution, self.cm.inscribed_radius, self.p.cost_scaling_factor)
        if self._table_key != key:
            d = np.sqrt(np.arange(r * r + 1, dtype=np.float64))  # as the distance transform computes them
            table = inflation_costs(d, self.cm.resolution, self.cm.inscribed_radius, self.p.cost_scaling_factor)
            self._table = np.append(table, np.uint8(FREE_SPACE))
            self._table_key = key
        return self._table

    def update_costs(self, master: np.ndarray, b: Bounds) -> None:
        cm = self.cm
        r = self.cell_radius
        x0, y0, x1, y1 = b
        rx0, ry0 = max(x0 - r, 0), max(y0 - r, 0)
        rx1, ry1 = min(x1 + r, cm.size_x), min(y1 + r, cm.size_y)
        kernels().inflate_window(
            master[ry0:ry1, rx0:rx1],
            y0 - ry0,
            y1 - ry0,
            x0 - rx0,
            x1 - rx0,
            self._cost_table(),
            bool(self.p.inflate_around_unknown),
            bool(self.p.inflate_unknown),
        )
