"""The layered costmap (Nav2's ``LayeredCostmap`` inside ``Costmap2DROS``): layers updating one master grid.

The layers are built from the costmap's ``plugins`` list by their plugin type (``costmap.registry``).
An update works like ``LayeredCostmap::updateMap``: for a rolling window the origin follows the
robot (snapped to whole cells, overlapping data kept); each layer reports the cells it changed (the
update bounds), the master grid is reset to its default there, then the layers write into it in
list order.

Pure computation: observations come in as points already transformed into the costmap's global
frame; the node (``replay.nodes.planner``) does the TF lookups. ``read_costmap`` reads a costmap's
parameters from a Nav2 file, each layer as its plugin type.
"""

from __future__ import annotations

import dataclasses
import math
from typing import cast

import numpy as np

from navlog.replay.config import suggest
from navlog.replay.limits import MAX_FOOTPRINT_RADIUS_M
from navlog.replay.nav2.costmap.footprint import footprint_radii, parse_footprint, robot_footprint
from navlog.replay.nav2.costmap.grid import DEFAULT_LAYER_PLUGINS, CostmapGrid, CostmapParams, LayerParams, StaticMap
from navlog.replay.nav2.costmap.inflation_layer import InflationLayerParams
from navlog.replay.nav2.costmap.layer import Bounds, Layer, shift_grid
from navlog.replay.nav2.costmap.observation import Observation
from navlog.replay.nav2.costmap.registry import LAYERS
from navlog.replay.nav2.plugins import read_plugin_type
from navlog.replay.nav2.schema import ERROR, NOTE, WARNING, SectionReader


def default_costmap_params() -> CostmapParams:
    """Nav2's default costmap: its default plugins (static, obstacle, inflation) with default parameters."""
    layers: dict[str, LayerParams] = {}
    for name, plugin in DEFAULT_LAYER_PLUGINS.items():
        entry = LAYERS[plugin]
        assert entry is not None
        layers[name] = cast(LayerParams, entry.params())
    return CostmapParams(layers=layers)


def read_costmap(r: SectionReader, params: dict, path: tuple) -> CostmapParams:
    """A costmap node's parameters with each listed layer's, read as its plugin type, and the checks across them."""
    plugins_value = params.get("plugins")
    plugin_names = tuple(CostmapParams.plugins)
    if isinstance(plugins_value, list) and all(isinstance(p, str) for p in plugins_value):
        plugin_names = tuple(plugins_value)
    filter_names = tuple(params.get("filters") or ()) if isinstance(params.get("filters"), list) else ()
    sections = tuple(k for k, v in params.items() if isinstance(v, dict))
    layers: dict[str, LayerParams] = {}
    for name in plugin_names:
        lpath = path + (name,)
        section = params.get(name)
        if section is None:
            default = DEFAULT_LAYER_PLUGINS.get(name) if "plugins" not in params else None
            if default is None:
                r.add(
                    ERROR,
                    path + ("plugins",),
                    f"plugin '{name}' is listed but there is no '{name}:' section "
                    f"with a 'plugin' type{suggest(name, sections)}",
                )
                continue
            section = {}
        else:
            default = None
        norm, cls = read_plugin_type(r, section, lpath, LAYERS, default)
        if cls is None or norm is None:
            continue
        layers[name] = cls.read_loaded(r, section, lpath, norm)
    for name in sections:
        if name in plugin_names or name in filter_names:
            continue
        r.add(WARNING, path + (name,), f"section '{name}' is not in plugins {list(plugin_names)}: Nav2 ignores it")
    cm = r.read(CostmapParams, params, path, sections=sections, extra={"layers": layers})
    try:
        fp = parse_footprint(cm.footprint)
    except ValueError as exc:
        r.add(ERROR, path + ("footprint",), str(exc))
        cm = dataclasses.replace(cm, footprint="[]")
        fp = []
    if fp and "robot_radius" in params:
        r.add(NOTE, path + ("robot_radius",), "footprint is set, so robot_radius is not used")
    # the padded footprint's farthest reach from the centre (padding moves a vertex by up to its value along x and
    # y), bounded before anything is computed from it: its outline's cells are rasterised
    reaches = [math.hypot(x, y) for x, y in fp] or [cm.robot_radius]
    reach = math.nan if any(math.isnan(v) for v in reaches) else max(reaches)  # (max() passes a NaN not first)
    reach += math.sqrt(2) * cm.footprint_padding
    if not reach <= MAX_FOOTPRINT_RADIUS_M:  # (also NaN)
        key = "footprint" if fp else "robot_radius"
        r.add(
            ERROR,
            path + (key,),
            f"the padded footprint reaches {reach:.6g} m from the robot's centre; navlog's bound is "
            f"{MAX_FOOTPRINT_RADIUS_M:g} m (check {key} and footprint_padding: metres, not millimetres)",
        )
        cm = dataclasses.replace(cm, footprint="[]", robot_radius=0.1, footprint_padding=0.01)
    # the inflation radius must reach past the inscribed radius
    inscribed, _ = footprint_radii(robot_footprint(cm))
    for name, layer in layers.items():
        if isinstance(layer, InflationLayerParams) and layer.inflation_radius < inscribed:
            r.add(
                ERROR,
                path + (name, "inflation_radius"),
                f"inflation_radius {layer.inflation_radius} is below the inscribed radius {inscribed:.3f} of the "
                "padded footprint: Nav2 logs an error and the robot may plan into walls",
            )
    inflation = [isinstance(layers[n], InflationLayerParams) for n in plugin_names if n in layers]
    if any(inflation) and inflation.index(True) != len(inflation) - 1:
        r.add(WARNING, path + ("plugins",), "the inflation layer is not last: layers after it are not inflated")
    return cm


class Costmap2D(CostmapGrid):
    """A layered costmap built from a CostmapParams (one of a Nav2 file's costmaps)."""

    def __init__(self, params: CostmapParams, name: str = "global_costmap") -> None:
        super().__init__(params, name)
        self.initialized = False
        self.layers: list[Layer] = []
        for lname in params.plugins:
            lp = params.layers.get(lname)
            if lp is None or not lp.enabled:
                continue
            self.layers.append(LAYERS.create(lp.plugin, lname, lp, self))

    @property
    def static_layers(self) -> list[Layer]:
        """The layers that take the static map."""
        return [layer for layer in self.layers if layer.takes_map]

    @property
    def obstacle_layers(self) -> list[Layer]:
        """The layers that take sensor observations."""
        return [layer for layer in self.layers if layer.takes_observations]

    def resize(self, size_x: int, size_y: int, resolution: float, origin_x: float, origin_y: float) -> None:
        self.size_x, self.size_y, self.resolution = int(size_x), int(size_y), float(resolution)
        self.origin_x, self.origin_y = float(origin_x), float(origin_y)
        self.costs = np.full((self.size_y, self.size_x), self.default, dtype=np.uint8)
        for layer in self.layers:
            layer.match_size()

    # ---------------------------------------------------------- inputs
    def set_static_map(self, occ: StaticMap) -> None:
        """A new map for the static layer(s); a non-rolling costmap takes the map's size and origin."""
        if not self.static_layers:
            return
        if not self.params.rolling_window:
            self.resize(occ.width, occ.height, occ.resolution, occ.origin[0], occ.origin[1])
        for layer in self.static_layers:
            layer.set_map(occ)

    def add_observation(self, obs: Observation) -> bool:
        """Give an observation to the layers that list its source; False if none does."""
        used = False
        for layer in self.layers:
            used |= layer.add_observation(obs)
        return used

    def update_origin(self, new_x: float, new_y: float) -> None:
        sx = int((new_x - self.origin_x) / self.resolution)
        sy = int((new_y - self.origin_y) / self.resolution)
        if sx == 0 and sy == 0:
            return
        self.origin_x += sx * self.resolution
        self.origin_y += sy * self.resolution
        self.costs = shift_grid(self.costs, sx, sy, self.default)
        for layer in self.layers:
            layer.update_origin(sx, sy)

    # ---------------------------------------------------------- update
    def update(self, robot_x: float, robot_y: float, robot_yaw: float = 0.0) -> Bounds | None:
        """One update cycle at the robot pose (global frame). Returns the cells that were recomputed."""
        if self.params.rolling_window:
            self.update_origin(
                robot_x - self.size_x * self.resolution / 2.0, robot_y - self.size_y * self.resolution / 2.0
            )
        robot = (robot_x, robot_y, robot_yaw)
        bounds: Bounds | None = None
        for layer in self.layers:
            bounds = layer.update_bounds(robot, bounds)
        if self.params.rolling_window:
            bounds = (0, 0, self.size_x, self.size_y)
        if not self.initialized:
            bounds = (0, 0, self.size_x, self.size_y)
            self.initialized = True
        if bounds is None:
            return None
        x0, y0, x1, y1 = bounds
        x0, y0 = max(x0, 0), max(y0, 0)
        x1, y1 = min(x1, self.size_x), min(y1, self.size_y)
        if x1 <= x0 or y1 <= y0:
            return None
        b = (x0, y0, x1, y1)
        self.costs[y0:y1, x0:x1] = self.default
        for layer in self.layers:
            layer.update_costs(self.costs, b)
        return b
