"""The occupancy map: a 2-D grid in nav_msgs/OccupancyGrid layout, and its message conversion.

``OccupancyMap.data`` is an int8 array of shape (height, width) laid out as nav_msgs/OccupancyGrid:
row 0 is the lowest y, column 0 the lowest x; values -1 (unknown) or 0..100 (occupancy percent).
World <-> cell conversions follow Nav2's costmap convention: world -> cell truncates towards the
lower cell, cell -> world gives the cell centre. Only the origin position is used for them; the
origin yaw is carried through (map_server YAML and messages) but, as in Nav2, ignored.

Pure data shared by the mappers, the costmap, the metrics and the world rasteriser; reading and
writing map_server files is ``navlog.replay.io.map_server``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from navlog.errors import NavlogError
from navlog.replay import messages as m

__all__ = ["FREE", "OCCUPIED", "UNKNOWN", "OccupancyMap"]

UNKNOWN = -1
FREE = 0
OCCUPIED = 100


@dataclass
class OccupancyMap:
    """A 2-D occupancy grid in nav_msgs/OccupancyGrid layout (row 0 = lowest y)."""

    data: np.ndarray  # int8, shape (height, width), -1 unknown, 0..100
    resolution: float  # metres per cell
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)  # x, y, yaw of cell (0, 0)'s outer corner
    frame_id: str = "map"

    def __post_init__(self) -> None:
        data = np.asarray(self.data)
        if data.ndim != 2:
            raise NavlogError(f"occupancy map: data must be 2-D (height, width), got shape {data.shape}")
        if not (self.resolution > 0.0 and math.isfinite(self.resolution)):
            raise NavlogError(f"occupancy map: resolution must be > 0, got {self.resolution}")
        self.data = data.astype(np.int8, copy=False)
        self.resolution = float(self.resolution)
        self.origin = tuple(float(v) for v in self.origin)  # type: ignore[assignment]

    # ------------------------------------------------------------ geometry

    @property
    def width(self) -> int:
        return int(self.data.shape[1])

    @property
    def height(self) -> int:
        return int(self.data.shape[0])

    @property
    def size_m(self) -> tuple[float, float]:
        return self.width * self.resolution, self.height * self.resolution

    def world_to_cell(self, x, y):
        """(mx, my) of the cell containing world point (x, y); floor, no bounds check.

        Scalars give ints, arrays give int arrays. Use ``contains`` to test the result.
        """
        mx = np.floor((np.asarray(x, dtype=np.float64) - self.origin[0]) / self.resolution).astype(np.int64)
        my = np.floor((np.asarray(y, dtype=np.float64) - self.origin[1]) / self.resolution).astype(np.int64)
        if mx.ndim == 0:
            return int(mx), int(my)
        return mx, my

    def cell_to_world(self, mx, my):
        """World (x, y) of the centre of cell (mx, my)."""
        x = self.origin[0] + (np.asarray(mx, dtype=np.float64) + 0.5) * self.resolution
        y = self.origin[1] + (np.asarray(my, dtype=np.float64) + 0.5) * self.resolution
        if np.ndim(x) == 0:
            return float(x), float(y)
        return x, y

    def contains(self, mx, my):
        """True where (mx, my) is a cell of the map."""
        mx = np.asarray(mx)
        my = np.asarray(my)
        inside = (mx >= 0) & (mx < self.width) & (my >= 0) & (my < self.height)
        return bool(inside) if inside.ndim == 0 else inside

    def value_at(self, x: float, y: float) -> int | None:
        """Occupancy value at a world point, or None outside the map."""
        mx, my = self.world_to_cell(x, y)
        if not self.contains(mx, my):
            return None
        return int(self.data[my, mx])

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, OccupancyMap):
            return NotImplemented
        return (
            self.data.shape == other.data.shape
            and bool(np.array_equal(self.data, other.data))
            and self.resolution == other.resolution
            and self.origin == other.origin
            and self.frame_id == other.frame_id
        )

    # ------------------------------------------------------------ messages

    def to_msg(self, ns: int) -> Any:
        """nav_msgs/OccupancyGrid stamped at ``ns`` (map_load_time too)."""
        MapMetaData = m.msg_class("nav_msgs/msg/MapMetaData")
        info = MapMetaData(
            map_load_time=m.stamp(ns),
            resolution=m.f32(self.resolution),
            width=self.width,
            height=self.height,
            origin=m.pose((self.origin[0], self.origin[1], 0.0), m.quat_from_yaw(self.origin[2])),
        )
        return m.msg_class(m.OCCUPANCY_GRID)(
            header=m.header(ns, self.frame_id),
            info=info,
            data=np.ascontiguousarray(self.data, dtype=np.int8).reshape(-1).copy(),
        )

    @classmethod
    def from_msg(cls, msg: Any) -> OccupancyMap:
        """An OccupancyMap from a nav_msgs/OccupancyGrid (origin yaw from its quaternion)."""
        info = msg.info
        width, height = int(info.width), int(info.height)
        data = np.asarray(msg.data, dtype=np.int8)
        if data.size != width * height:
            raise NavlogError(
                f"OccupancyGrid in frame '{msg.header.frame_id}': {data.size} cells but "
                f"width x height = {width} x {height}"
            )
        o = info.origin
        yaw = m.yaw_from_quat((o.orientation.x, o.orientation.y, o.orientation.z, o.orientation.w))
        return cls(
            data=data.reshape(height, width).copy(),
            # the message holds float32: take the shortest decimal of that float32 (0.05, not 0.0500000007)
            resolution=float(str(np.float32(info.resolution))),
            origin=(float(o.position.x), float(o.position.y), yaw),
            frame_id=str(msg.header.frame_id) or "map",
        )
