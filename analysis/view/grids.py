"""Occupancy grids and costmaps: GridMaps in 3D under ``grids/``, and the source of the top-down image.

A topic publishing faster than ``grid_period_s`` is thinned to one grid per period; the latest grid
of a thinned run is kept and drawn at the end.
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any

import numpy as np

from navlog.analysis.view.context import ViewContext, entity_name


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
        entry = (
            t,
            self.ctx.frame(msg.header.frame_id),
            grid_array(msg).copy(),
            float(info.resolution),
            (o.position.x, o.position.y, o.position.z),
            (o.orientation.x, o.orientation.y, o.orientation.z, o.orientation.w),
        )
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
        """A Rerun GridMap of int8 cells with RViz's map colours."""
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
            for t, _, cells, res, xyz, q in grids:
                ctx.set_time(t)
                ctx.rec.log(ent, self.gridmap(cells, res, xyz, q))
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
