"""Nav2's obstacle layer: sensor observations marked as obstacles and cleared along their rays."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np

from navlog.replay.config import suggest
from navlog.replay.nav2.costmap.cost_values import FREE_SPACE, LETHAL, NO_INFORMATION
from navlog.replay.nav2.costmap.footprint import transform_footprint
from navlog.replay.nav2.costmap.grid import CostmapGrid
from navlog.replay.nav2.costmap.kernels import kernels
from navlog.replay.nav2.costmap.layer import Bounds, Layer, Robot, shift_grid, union_bounds, update_with_max
from navlog.replay.nav2.costmap.observation import Observation, ObservationSourceParams
from navlog.replay.nav2.costmap.raytrace import polygon_cells, ray_steps
from navlog.replay.nav2.plugins import PluginParams
from navlog.replay.nav2.schema import ERROR, NOTE, WARNING, SectionReader, param


@dataclass(frozen=True)
class ObstacleLayerParams(PluginParams):
    """``nav2_costmap_2d::ObstacleLayer`` (and ``VoxelLayer``) parameters with their observation sources."""

    plugin: str = "nav2_costmap_2d::ObstacleLayer"
    enabled: bool = True
    footprint_clearing_enabled: bool = True
    min_obstacle_height: float = 0.0
    max_obstacle_height: float = 2.0
    combination_method: int = param(1, ge=0, le=2)
    observation_sources: tuple[str, ...] = ()
    sources: dict[str, ObservationSourceParams] = field(default_factory=dict)
    # VoxelLayer parameters: read; the voxel layer runs as a 2-D obstacle layer whose height range
    # is capped at origin_z + z_resolution * z_voxels.
    publish_voxel_map: bool = False
    origin_z: float = 0.0
    z_resolution: float = param(0.2, gt=0.0)
    z_voxels: int = param(10, ge=1, le=16)
    unknown_threshold: int = param(15, ge=0)
    mark_threshold: int = param(0, ge=0)
    READ_ONLY: ClassVar[tuple[str, ...]] = ("publish_voxel_map", "unknown_threshold", "mark_threshold")
    VOXEL_ONLY: ClassVar[tuple[str, ...]] = (
        "publish_voxel_map",
        "origin_z",
        "z_resolution",
        "z_voxels",
        "unknown_threshold",
        "mark_threshold",
    )

    @property
    def is_voxel(self) -> bool:
        return self.plugin == "nav2_costmap_2d::VoxelLayer"

    @classmethod
    def read_section(cls, r: SectionReader, section: Any, path: tuple, plugin: str) -> ObstacleLayerParams:
        """The layer's parameters and each listed observation source's, with the traps Nav2 sets."""
        voxel = plugin == "nav2_costmap_2d::VoxelLayer"
        raw_sources = section.get("observation_sources", "")
        names: tuple[str, ...] = ()
        if isinstance(raw_sources, str):
            names = tuple(raw_sources.split())
        elif isinstance(raw_sources, list) and all(isinstance(s, str) for s in raw_sources):
            names = tuple(raw_sources)
        sections = tuple(k for k, v in section.items() if isinstance(v, dict))
        sources: dict[str, ObservationSourceParams] = {}
        for name in names:
            spath = path + (name,)
            sec = section.get(name)
            if not isinstance(sec, dict):
                r.add(
                    ERROR,
                    path + ("observation_sources",),
                    f"observation source '{name}' has no '{name}:' section{suggest(name, sections)}",
                )
                continue
            src = r.read(ObservationSourceParams, sec, spath)
            if not src.topic:
                r.add(WARNING, spath, f"no 'topic': Nav2 subscribes to '{name}'")
                src = dataclasses.replace(src, topic=name)
            if src.marking and "max_obstacle_height" not in sec:
                r.add(
                    WARNING,
                    spath + ("max_obstacle_height",),
                    "not set: the per-source default is 0.0, so every point above z = 0 in the global frame is dropped",
                )
            if src.raytrace_max_range < src.obstacle_max_range and src.clearing:
                r.add(
                    WARNING,
                    spath + ("raytrace_max_range",),
                    f"raytrace_max_range {src.raytrace_max_range} < obstacle_max_range {src.obstacle_max_range}: "
                    "marked obstacles beyond the raytrace range are never cleared",
                )
            if src.obstacle_min_range > src.obstacle_max_range:
                r.add(ERROR, spath + ("obstacle_min_range",), "obstacle_min_range is above obstacle_max_range")
            if src.raytrace_min_range > src.raytrace_max_range:
                r.add(ERROR, spath + ("raytrace_min_range",), "raytrace_min_range is above raytrace_max_range")
            if src.data_type == "PointCloud":
                r.add(
                    ERROR,
                    spath + ("data_type",),
                    ("is 'PointCloud'" if "data_type" in sec else "not set, so it is 'PointCloud'")
                    + ": Nav2 accepts only 'LaserScan' or 'PointCloud2' and fails at launch",
                )
            sources[name] = src
        for name in sections:
            if name not in names:
                r.add(WARNING, path + (name,), f"section '{name}' is not in observation_sources: Nav2 ignores it")
        layer = r.read(
            cls,
            section,
            path,
            sections=sections,
            extra={"plugin": plugin, "sources": sources, "observation_sources": names},
        )
        if not voxel:
            for key in cls.VOXEL_ONLY:
                if key in section:
                    r.add(WARNING, path + (key,), f"'{key}' is a VoxelLayer parameter; the ObstacleLayer ignores it")
        else:
            r.add(
                NOTE,
                path + ("plugin",),
                "VoxelLayer runs as a 2-D obstacle layer (height capped at "
                "origin_z + z_resolution * z_voxels); the voxel grid itself is not implemented",
            )
        return layer


class ObstacleLayer(Layer[ObstacleLayerParams]):
    """Obstacles marked from, and cleared along the rays of, the latest observation of each source.

    Each source's points are first filtered by its own height range (its observation buffer), then
    rays clear the cells from the sensor to each point (raytrace ranges), then the points within the
    layer's height range and the source's obstacle ranges are marked LETHAL; the robot's footprint
    is cleared (``footprint_clearing_enabled``). A VoxelLayer runs as this layer with its height
    capped at origin_z + z_resolution * z_voxels.
    """

    takes_observations = True

    def __init__(self, name: str, params: ObstacleLayerParams, costmap: CostmapGrid) -> None:
        super().__init__(name, params, costmap)
        self.default = NO_INFORMATION if costmap.params.track_unknown_space else FREE_SPACE
        self.grid = np.full((costmap.size_y, costmap.size_x), self.default, dtype=np.uint8)
        self.latest: dict[str, Observation] = {}
        self.footprint_bounds: Bounds | None = None
        self.footprint_poly: np.ndarray | None = None
        if params.is_voxel:
            top = params.origin_z + params.z_resolution * params.z_voxels
            self.max_height = min(params.max_obstacle_height, top)
        else:
            self.max_height = params.max_obstacle_height

    def match_size(self) -> None:
        self.grid = np.full((self.cm.size_y, self.cm.size_x), self.default, dtype=np.uint8)

    def update_origin(self, sx: int, sy: int) -> None:
        self.grid = shift_grid(self.grid, sx, sy, self.default)

    def observation_sources(self) -> dict[str, ObservationSourceParams]:
        return self.p.sources

    def add_observation(self, obs: Observation) -> bool:
        """Keep the latest observation of a listed source (observation_persistence 0)."""
        if obs.source not in self.p.sources:
            return False
        self.latest[obs.source] = obs
        return True

    def update_bounds(self, robot: Robot, bounds: Bounds | None) -> Bounds | None:
        return union_bounds(bounds, self._changed(robot))

    def _changed(self, robot: Robot) -> Bounds | None:
        cm = self.cm
        bounds: Bounds | None = None
        observations = [self.latest[k] for k in sorted(self.latest)]
        self.latest = {}
        filtered = []
        for obs in observations:
            sp = self.p.sources[obs.source]
            pts = obs.points
            z = pts[:, 2]
            keep = (z >= sp.min_obstacle_height) & (z <= sp.max_obstacle_height)  # the observation buffer's filter
            filtered.append((obs, sp, pts[keep]))
        # clearing first
        for obs, sp, pts in filtered:
            if sp.clearing:
                bounds = union_bounds(bounds, self._raytrace(obs.origin, pts, sp))
        # then marking
        for obs, sp, pts in filtered:
            if not sp.marking or len(pts) == 0:
                continue
            z = pts[:, 2]
            ok = (z <= self.max_height) & (z >= self.p.min_obstacle_height)
            d2 = ((pts - obs.origin[None, :]) ** 2).sum(axis=1)
            ok &= (d2 < sp.obstacle_max_range**2) & (d2 >= sp.obstacle_min_range**2)
            mx, my = cm.world_to_cell(pts[ok, 0], pts[ok, 1])
            inside = (mx >= 0) & (mx < cm.size_x) & (my >= 0) & (my < cm.size_y)
            mx, my = mx[inside], my[inside]
            if len(mx):
                self.grid[my, mx] = LETHAL
                bounds = union_bounds(bounds, (int(mx.min()), int(my.min()), int(mx.max()) + 1, int(my.max()) + 1))
        # footprint
        if self.p.footprint_clearing_enabled:
            poly = transform_footprint(cm.footprint, *robot)
            fx, fy = cm.world_to_cell(poly[:, 0], poly[:, 1])
            fb = (int(fx.min()), int(fy.min()), int(fx.max()) + 1, int(fy.max()) + 1)
            self.footprint_poly = poly
            bounds = union_bounds(bounds, union_bounds(fb, self.footprint_bounds))
            self.footprint_bounds = fb
        return bounds

    def _raytrace(self, origin: np.ndarray, pts: np.ndarray, sp: ObservationSourceParams) -> Bounds | None:
        cm = self.cm
        ox, oy = float(origin[0]), float(origin[1])
        x0, y0 = cm.world_to_cell(ox, oy)
        if not (0 <= x0 < cm.size_x and 0 <= y0 < cm.size_y):
            cm.skipped["sensor origin outside the costmap"] = cm.skipped.get("sensor origin outside the costmap", 0) + 1
            return None
        if len(pts) == 0:
            return x0, y0, x0 + 1, y0 + 1
        wx, wy = pts[:, 0].copy(), pts[:, 1].copy()
        a, b = wx - ox, wy - oy
        end_x, end_y = cm.origin_x + cm.size_x * cm.resolution, cm.origin_y + cm.size_y * cm.resolution
        with np.errstate(divide="ignore", invalid="ignore"):
            c = wx < cm.origin_x
            t = (cm.origin_x - ox) / a
            wy = np.where(c, oy + b * t, wy)
            wx = np.where(c, cm.origin_x, wx)
            c = wy < cm.origin_y
            t = (cm.origin_y - oy) / b
            wx = np.where(c, ox + a * t, wx)
            wy = np.where(c, cm.origin_y, wy)
            c = wx > end_x
            t = (end_x - ox) / a
            wy = np.where(c, oy + b * t, wy)
            wx = np.where(c, end_x - 0.001, wx)
            c = wy > end_y
            t = (end_y - oy) / b
            wx = np.where(c, ox + a * t, wx)
            wy = np.where(c, end_y - 0.001, wy)
        x1, y1 = cm.world_to_cell(wx, wy)
        ok = (x1 >= 0) & (x1 < cm.size_x) & (y1 >= 0) & (y1 < cm.size_y)
        max_cells = math.ceil(sp.raytrace_max_range / cm.resolution)
        min_cells = math.ceil(sp.raytrace_min_range / cm.resolution)
        steps = ray_steps(x0, y0, x1[ok], y1[ok], max_cells, min_cells)
        n, xmin, ymin, xmax, ymax = kernels().clear_rays(self.grid, *steps, FREE_SPACE)
        if n == 0:
            return x0, y0, x0 + 1, y0 + 1
        return min(xmin, x0), min(ymin, y0), max(xmax, x0) + 1, max(ymax, y0) + 1

    def update_costs(self, master: np.ndarray, b: Bounds) -> None:
        cm = self.cm
        if self.p.footprint_clearing_enabled and self.footprint_poly is not None:
            fx, fy = polygon_cells(self.footprint_poly, cm.origin_x, cm.origin_y, cm.resolution, cm.size_x, cm.size_y)
            self.grid[fy, fx] = FREE_SPACE
        x0, y0, x1, y1 = b
        win = self.grid[y0:y1, x0:x1]
        method = self.p.combination_method
        if method == 0:  # overwrite where the layer knows something
            np.copyto(master[y0:y1, x0:x1], win, where=win != NO_INFORMATION)
        elif method == 1:
            update_with_max(master, win, b)
        else:  # max, never overwriting unknown
            mw = master[y0:y1, x0:x1]
            np.copyto(mw, np.maximum(mw, win), where=(win != NO_INFORMATION) & (mw != NO_INFORMATION))
