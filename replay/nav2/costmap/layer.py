"""The costmap layer interface (Nav2's ``nav2_costmap_2d::Layer``) and the grid operations layers share.

The layered costmap calls its layers in list order. Each update, ``update_bounds`` gets the bounds
so far (the cells changed by the layers before it) and returns them grown by the cells this layer
changed; then, within the final bounds, ``update_costs`` writes the layer into the master grid.
A layer that holds its own grid follows the master's size (``match_size``) and, in a rolling
window, its origin (``update_origin``). Which inputs a layer takes is declared, not guessed from its
class: ``takes_map`` (the static map) and ``takes_observations`` (sensor observations).

Bounds are (x0, y0, x1, y1) in cells, half-open.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import ClassVar, Generic, TypeVar

import numpy as np

from navlog.replay.nav2.costmap.cost_values import NO_INFORMATION
from navlog.replay.nav2.costmap.grid import CostmapGrid, LayerParams, StaticMap
from navlog.replay.nav2.costmap.observation import Observation, ObservationSourceParams

Bounds = tuple[int, int, int, int]  # x0, y0, x1, y1 in cells, half-open
Robot = tuple[float, float, float]  # x, y, yaw of the robot in the costmap's global frame

P = TypeVar("P", bound=LayerParams)


def union_bounds(a: Bounds | None, b: Bounds | None) -> Bounds | None:
    """The smallest bounds holding both (None: no cells)."""
    if a is None:
        return b
    if b is None:
        return a
    return min(a[0], b[0]), min(a[1], b[1]), max(a[2], b[2]), max(a[3], b[3])


def shift_grid(grid: np.ndarray, sx: int, sy: int, fill: int) -> np.ndarray:
    """Content of ``grid`` seen from an origin moved by (sx, sy) cells; uncovered cells get ``fill``."""
    out = np.full_like(grid, fill)
    h, w = grid.shape
    if abs(sx) >= w or abs(sy) >= h:
        return out
    src_x = slice(max(sx, 0), w + min(sx, 0))
    dst_x = slice(max(-sx, 0), w + min(-sx, 0))
    src_y = slice(max(sy, 0), h + min(sy, 0))
    dst_y = slice(max(-sy, 0), h + min(-sy, 0))
    out[dst_y, dst_x] = grid[src_y, src_x]
    return out


def update_with_max(master: np.ndarray, layer_win: np.ndarray, b: Bounds) -> None:
    """Where the layer knows the cell: the layer's cost if the master's is unknown, else the higher one."""
    x0, y0, x1, y1 = b
    mw = master[y0:y1, x0:x1]
    known = layer_win != NO_INFORMATION
    out = np.maximum(mw, layer_win)
    np.copyto(out, layer_win, where=known & (mw == NO_INFORMATION))
    np.copyto(mw, out, where=known)


class Layer(Generic[P]):
    """One layer of a layered costmap, built from its parameters by the layer registry."""

    takes_map: ClassVar[bool] = False  # the costmap gives it the static map (``set_map``)
    takes_observations: ClassVar[bool] = False  # the costmap gives it sensor observations (``add_observation``)

    def __init__(self, name: str, params: P, costmap: CostmapGrid) -> None:
        self.name, self.p, self.cm = name, params, costmap

    def update_bounds(self, robot: Robot, bounds: Bounds | None) -> Bounds | None:
        """``bounds`` grown by the cells this layer changed since the last update."""
        raise NotImplementedError

    def update_costs(self, master: np.ndarray, b: Bounds) -> None:
        """Write this layer into ``master`` within ``b``."""
        raise NotImplementedError

    def match_size(self) -> None:
        """The master grid was resized (a static map of another size): a layer with a grid follows."""

    def update_origin(self, sx: int, sy: int) -> None:
        """The rolling window moved by (sx, sy) whole cells: a layer with a grid keeps the overlap."""

    def set_map(self, occ: StaticMap) -> None:
        """A new static map (layers with ``takes_map``)."""
        raise NotImplementedError(f"the {type(self).__name__} '{self.name}' takes no map")

    @property
    def has_map(self) -> bool:
        """True once the layer has a map (layers with ``takes_map``)."""
        return False

    def observation_sources(self) -> Mapping[str, ObservationSourceParams]:
        """The sources whose observations this layer takes, by name (layers with ``takes_observations``)."""
        return {}

    def add_observation(self, obs: Observation) -> bool:
        """Keep ``obs`` if this layer lists its source; False if it does not."""
        return False
