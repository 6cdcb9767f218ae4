"""Occupancy grids and costmaps: GridMaps in 3D under ``grids/``, and the source of the top-down image.

A topic publishing faster than ``grid_period_s`` is thinned to one grid per period; the latest grid
of a thinned run is kept and drawn at the end. Every grid is cropped to its known cells plus
``grid_margin_m`` (a mapper's 20 x 20 m canvas of unknown cells around a 6 m room is not drawn).
Costmaps (topics named ``*costmap*``) are drawn just above the map, the local one above the global.
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Any

import numpy as np

from navlog.analysis.view.context import ViewContext, entity_name
from navlog.replay.geometry import yaw_from_quat


def grid_array(msg: Any) -> np.ndarray:
    """OccupancyGrid data as an (height, width) int8 array, row 0 at the grid origin."""
    info = msg.info
    data = np.asarray(msg.data, dtype=np.int8)
    return data[: int(info.width) * int(info.height)].reshape(int(info.height), int(info.width))


def grid_gray(cells: np.ndarray) -> np.ndarray:
    """map_server colours: occupied black, free white, unknown grey, costs in between."""
    v = cells.astype(np.int16)
    out = np.full(v.shape, 205, dtype=np.uint8)
    known = v >= 0
    out[known] = (254 - np.clip(v[known], 0, 100) * 254 // 100).astype(np.uint8)
    return out


def crop_known(
    cells: np.ndarray, res: float, origin_xyz: tuple, q_xyzw: tuple, margin_m: float
) -> tuple[np.ndarray, tuple[float, float, float]]:
    """The grid cropped to its known (>= 0) cells plus ``margin_m``, and the origin of the cropped grid
    (the cell offset turned by the origin's yaw). A grid without known cells is returned whole."""
    known_rows = np.flatnonzero((cells >= 0).any(axis=1))
    known_cols = np.flatnonzero((cells >= 0).any(axis=0))
    if len(known_rows) == 0:
        return cells, tuple(float(v) for v in origin_xyz)  # type: ignore[return-value]
    m = int(math.ceil(margin_m / res)) if res > 0 else 0
    h, w = cells.shape
    r0, r1 = max(0, known_rows[0] - m), min(h, known_rows[-1] + 1 + m)
    c0, c1 = max(0, known_cols[0] - m), min(w, known_cols[-1] + 1 + m)
    yaw = yaw_from_quat(q_xyzw)
    dx, dy = c0 * res, r0 * res
    ox = origin_xyz[0] + dx * math.cos(yaw) - dy * math.sin(yaw)
    oy = origin_xyz[1] + dx * math.sin(yaw) + dy * math.cos(yaw)
    return cells[r0:r1, c0:c1], (float(ox), float(oy), float(origin_xyz[2]))


# m above the map plane: costmaps drawn over the map (not in the same plane), the local one on top.
# They keep the map's colours: Rerun's RViz costmap colours draw free cells opaque black in software
# rendering, which hides the map.
COSTMAP_LIFT_M = {"global": 0.01, "local": 0.02}


class Grids:
    """OccupancyGrid topics: (log time, frame, cells, resolution, origin xyz, origin q) per kept grid."""

    def __init__(self, ctx: ViewContext) -> None:
        self.ctx = ctx
        self.topics: dict[str, list] = defaultdict(list)
        self._pending: dict[str, tuple] = {}
        # a static map drawn in the 2D view before any topic: (name, cells, resolution, origin x, origin y)
        self.static_map: tuple[str, np.ndarray, float, float, float] | None = None

    def on_grid(self, topic: str, t: int, msg: Any) -> None:
        info = msg.info
        o = info.origin
        q = (o.orientation.x, o.orientation.y, o.orientation.z, o.orientation.w)
        res = float(info.resolution)
        cells, origin = crop_known(
            grid_array(msg), res, (o.position.x, o.position.y, o.position.z), q, self.ctx.opt.grid_margin_m
        )
        entry = (t, self.ctx.frame(msg.header.frame_id), cells.copy(), res, origin, q)
        grids = self.topics[topic]
        period_s = self.ctx.opt.grid_period_s
        if grids and t - grids[-1][0] < period_s * 1e9:
            if topic in self._pending:
                self.ctx.summary.skipped[f"grid thinned to one per {period_s:g} s on {topic}"] += 1
            self._pending[topic] = entry  # the latest of a fast run is kept for the end
            return
        if self._pending.pop(topic, None) is not None:
            self.ctx.summary.skipped[f"grid thinned to one per {period_s:g} s on {topic}"] += 1
        grids.append(entry)

    def gridmap(self, cells: np.ndarray, res: float, origin_xyz, q_xyzw):
        """A Rerun GridMap of int8 cells with RViz's map colours (costs as shades of grey)."""
        rr = self.ctx.rr
        h, w = cells.shape
        return rr.GridMap(
            data=np.ascontiguousarray(cells).view(np.uint8).tobytes(),
            format=rr.components.ImageFormat(width=w, height=h, color_model="L", channel_datatype="U8"),
            cell_size=res,
            translation=[float(v) for v in origin_xyz],
            quaternion=rr.Quaternion(xyzw=[float(v) for v in q_xyzw]),
            colormap=rr.components.Colormap.RvizMap,
        )

    def send(self) -> None:
        ctx = self.ctx
        for topic, entry in sorted(self._pending.items()):
            self.topics[topic].append(entry)
        self._pending.clear()
        for topic, grids in sorted(self.topics.items()):
            ent = ctx.entity(f"grids/{entity_name(topic)}")
            ctx.set_frame(ent, grids[0][1])
            costmap = "costmap" in topic.lower()
            lift = COSTMAP_LIFT_M.get("local" if "local" in topic.lower() else "global", 0.0) if costmap else 0.0
            for t, _, cells, res, xyz, q in grids:
                ctx.set_time(t)
                ctx.rec.log(ent, self.gridmap(cells, res, (xyz[0], xyz[1], xyz[2] + lift), q))
            ctx.summary.drawn[topic] = ent

    def top_source(self) -> tuple[str, list] | None:
        """The grid drawn in the 2D view: replay map, /map, a global costmap, any grid, in that order."""
        if self.static_map is not None:
            name, cells, res, ox, oy = self.static_map
            return name, [(0, self.ctx.summary.fixed_frame, cells, res, (ox, oy, 0.0), (0, 0, 0, 1))]
        order = sorted(self.topics, key=lambda k: (k != "replay/map", k != "/map", "global" not in k, k))
        for topic in order:
            if self.topics[topic]:
                return topic, self.topics[topic]
        return None
