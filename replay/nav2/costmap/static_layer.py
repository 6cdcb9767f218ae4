"""Nav2's static layer: the map (``/map`` or a map_server file) as costs."""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from navlog.replay.geometry import world_to_cell
from navlog.replay.nav2.costmap.cost_values import FREE_SPACE, LETHAL, NO_INFORMATION
from navlog.replay.nav2.costmap.grid import CostmapGrid, StaticMap
from navlog.replay.nav2.costmap.layer import Bounds, Layer, Robot, union_bounds, update_with_max
from navlog.replay.nav2.plugins import PluginParams
from navlog.replay.nav2.schema import param


@dataclass(frozen=True)
class StaticLayerParams(PluginParams):
    """``nav2_costmap_2d::StaticLayer`` parameters (the map's interpretation is the costmap's: ``CostmapParams``)."""

    plugin: str = "nav2_costmap_2d::StaticLayer"
    enabled: bool = True
    subscribe_to_updates: bool = False
    map_subscribe_transient_local: bool = True
    transform_tolerance: float = param(0.0, ge=0.0)
    map_topic: str = ""
    footprint_clearing_enabled: bool = False
    restore_cleared_footprint: bool = True
    READ_ONLY: ClassVar[tuple[str, ...]] = (
        "subscribe_to_updates",
        "map_subscribe_transient_local",
        "footprint_clearing_enabled",
        "restore_cleared_footprint",
    )


class StaticLayer(Layer[StaticLayerParams]):
    """The map as costs: LETHAL at or above lethal_cost_threshold, unknown as NO_INFORMATION or FREE_SPACE.

    A non-rolling costmap has the map's geometry and takes its costs as they are; a rolling window
    (or any other geometry) samples them at its cells' centres.
    """

    takes_map = True

    def __init__(self, name: str, params: StaticLayerParams, costmap: CostmapGrid) -> None:
        super().__init__(name, params, costmap)
        self.map_costs: np.ndarray | None = None
        self.map: StaticMap | None = None
        self.has_new = False

    def interpret(self, occ: StaticMap) -> np.ndarray:
        cp = self.cm.params
        raw = occ.data.astype(np.int16) & 0xFF  # unsigned bytes: -1 arrives as 255
        out = np.zeros(raw.shape, dtype=np.uint8)
        unknown = raw == cp.unknown_cost_value
        lethal = (raw >= cp.lethal_cost_threshold) & ~unknown
        if not cp.trinary_costmap:
            scaled = (raw.astype(np.float64) / cp.lethal_cost_threshold * LETHAL).astype(np.int64)
            out = np.clip(scaled, 0, 255).astype(np.uint8)
        out[lethal] = LETHAL
        out[unknown] = NO_INFORMATION if cp.track_unknown_space else FREE_SPACE
        return out

    def set_map(self, occ: StaticMap) -> None:
        self.map = occ
        self.map_costs = self.interpret(occ)
        self.has_new = True

    @property
    def has_map(self) -> bool:
        return self.map_costs is not None

    def update_bounds(self, robot: Robot, bounds: Bounds | None) -> Bounds | None:
        return union_bounds(bounds, self._changed())

    def _changed(self) -> Bounds | None:
        if self.map_costs is None:
            return None
        if self.cm.params.rolling_window or self.has_new:
            self.has_new = False
            return 0, 0, self.cm.size_x, self.cm.size_y
        return None

    def _window_costs(self) -> np.ndarray:
        """Static costs resampled at the master cells' centres (rolling window, or other geometry)."""
        cm, occ = self.cm, self.map
        assert occ is not None and self.map_costs is not None
        gx, gy = cm.cell_centres()
        mx = world_to_cell(gx, occ.origin[0], occ.resolution)
        my = world_to_cell(gy, occ.origin[1], occ.resolution)
        inside = (mx >= 0) & (mx < occ.width) & (my >= 0) & (my < occ.height)
        out = np.full(gx.shape, NO_INFORMATION if cm.params.track_unknown_space else FREE_SPACE, dtype=np.uint8)
        out[inside] = self.map_costs[my[inside], mx[inside]]
        return out

    def update_costs(self, master: np.ndarray, b: Bounds) -> None:
        if self.map_costs is None:
            return
        x0, y0, x1, y1 = b
        same = (
            not self.cm.params.rolling_window
            and self.map_costs.shape == master.shape
            and self.map is not None
            and abs(self.map.origin[0] - self.cm.origin_x) < 1e-9
            and abs(self.map.origin[1] - self.cm.origin_y) < 1e-9
        )
        src = self.map_costs if same else self._window_costs()
        win = src[y0:y1, x0:x1]
        if self.cm.params.use_maximum:
            update_with_max(master, win, b)
        else:  # true overwrite, unknown included
            master[y0:y1, x0:x1] = win
