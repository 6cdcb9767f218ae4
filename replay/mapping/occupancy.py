"""A log-odds occupancy grid updated from 2D laser scans (the slam_toolbox role, for known poses).

Per scan, each cell is updated at most once: cells crossed by a beam become more likely free, the
cell holding a beam's end point more likely occupied (occupied wins within one scan).

Invalid readings are treated as Karto and slam_toolbox treat them: a reading that is NaN, ``inf``,
``-inf``, ``>= range_max`` or ``<= range_min`` marks nothing and clears nothing (counted in
``ScanStats``). A real laser reports ``inf`` for glass, black surfaces and open doors as well as for
open space, so clearing along it would carve free space through walls. Clearing along no-return
rays is an explicit option with its own length, ``no_return_ray_length`` (Cartographer's
``missing_data_ray_length``), off by default. ``max_laser_range`` (slam_toolbox's parameter) clips
longer valid readings: the beam clears up to it and marks no end point. The grid grows as the robot
explores, in whole blocks, so results do not depend on where the log starts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields

import numpy as np

from navlog.replay.config import param
from navlog.replay.geometry import world_to_cell
from navlog.replay.limits import MAX_GRID_CELLS, MIN_GRID_RESOLUTION_M
from navlog.replay.occupancy_map import OccupancyMap

NUMPY_BEAM_GROUPS = 4  # beams of similar length updated together (``_update``)
GROUP_SAMPLES = 1 << 22  # at most this many (beam, sample) pairs in one group's work arrays (about 90 MB)
MAX_CELLS = MAX_GRID_CELLS  # a grid larger than this comes from a pose or range far off, or a resolution too fine
MAX_COORDINATE = 1e6  # m; a grid reaching farther from the map origin comes from a pose or range far off


class GridTooLarge(ValueError):
    """A scan would grow the grid beyond ``MAX_CELLS`` or ``MAX_COORDINATE``: its pose or its ranges are far off."""


def logit(p: float) -> float:
    return math.log(p / (1.0 - p))


@dataclass(frozen=True)
class OccupancyParams:
    resolution: float = param(0.05, ge=MIN_GRID_RESOLUTION_M)  # m per cell
    hit_probability: float = 0.7  # per observation of an end point
    miss_probability: float = 0.4  # per beam crossing a cell
    clamp: tuple[float, float] = (0.12, 0.97)  # probability limits of a cell
    occupied_threshold: float = 0.65  # map_server's occupied_thresh
    free_threshold: float = 0.196  # map_server's free_thresh
    max_laser_range: float = 0.0  # longer readings clear up to here and mark nothing (0: no clipping)
    no_return_ray_length: float = 0.0  # clear this far along beams with no return (0: they clear nothing)
    grow_block: float = 5.0  # the grid grows in blocks of this many metres (whole cells: rounded up to them)

    def __post_init__(self) -> None:
        if self.resolution <= 0:
            raise ValueError("resolution must be positive")
        if not (0.5 < self.hit_probability < 1.0 and 0.0 < self.miss_probability < 0.5):
            raise ValueError("hit_probability must be in (0.5, 1) and miss_probability in (0, 0.5)")
        if not (0.0 < self.free_threshold < self.occupied_threshold < 1.0):
            raise ValueError("need 0 < free_threshold < occupied_threshold < 1")
        if not (math.isfinite(self.grow_block) and self.grow_block >= self.resolution):
            raise ValueError(f"grow_block must be a finite length of one cell ({self.resolution} m) or more")
        if (self.block / self.resolution) ** 2 > MAX_CELLS:
            raise ValueError(
                f"grow_block ({self.grow_block} m) is a block of {(self.block / self.resolution) ** 2:.3g} cells "
                f"at resolution {self.resolution} m: at most {MAX_CELLS:.0e} (the grid grows by blocks)"
            )
        low, high = self.clamp
        if not (math.isfinite(low) and math.isfinite(high) and 0.0 < low < 0.5 < high < 1.0):
            raise ValueError(f"clamp ({low}, {high}) must hold 0 < low < 0.5 < high < 1 (a cell's probability limits)")
        for name in ("max_laser_range", "no_return_ray_length"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite length >= 0 (0 turns it off), got {value}")

    @property
    def block(self) -> float:
        """The side of the blocks the grid grows by, in metres: ``grow_block``, or the whole cells just over it where
        it is not a whole number of cells."""
        cells = self.grow_block / self.resolution
        return self.grow_block if abs(cells - round(cells)) <= 1e-9 * cells else math.ceil(cells) * self.resolution


@dataclass
class ScanStats:
    scans: int = 0
    beams: int = 0
    hits: int = 0
    no_return: int = 0  # inf or >= range_max: cleared only along no_return_ray_length
    too_close: int = 0  # -inf or <= range_min: not used
    nan: int = 0  # not used
    clipped: int = 0  # beyond max_laser_range: cleared up to it, end not marked

    def add(self, other: ScanStats) -> None:
        for f in fields(self):
            setattr(self, f.name, getattr(self, f.name) + getattr(other, f.name))


class OccupancyGrid2D:
    """The log-odds grid. Cell (ix, iy) covers [origin + i*res, origin + (i+1)*res)."""

    def __init__(self, params: OccupancyParams) -> None:
        self.p = params
        self.res = params.resolution
        self.l_hit = logit(params.hit_probability)
        self.l_miss = logit(params.miss_probability)
        self.l_min, self.l_max = logit(params.clamp[0]), logit(params.clamp[1])
        self.origin = np.zeros(2)  # world position of cell (0, 0)'s corner
        self.logodds = np.zeros((0, 0), dtype=np.float32)  # (ny, nx)
        self.seen = np.zeros((0, 0), dtype=bool)
        self.stats = ScanStats()
        self._buffers: dict[str, np.ndarray] = {}  # work arrays of insert_scan, reused between scans
        # to_map's last trinary grid, with the log-odds and seen arrays it was made from (another array there: made
        # again whole), and the box (rows, columns: first, end) of the cells scans changed since, None for none
        self._trinary: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        self._changed: tuple[int, int, int, int] | None = None

    # ------------------------------------------------------------ growth
    def _ensure(self, xmin: float, ymin: float, xmax: float, ymax: float) -> None:
        block = self.p.block
        lo = np.floor(np.array([xmin, ymin]) / block) * block
        hi = (np.floor(np.array([xmax, ymax]) / block) + 1) * block  # strictly beyond the max, never empty
        if self.logodds.size:  # the grid after growing spans both what it has and the new bounds
            cur_hi = self.origin + np.array(self.logodds.shape[::-1]) * self.res
            span = np.maximum(hi, cur_hi) - np.minimum(lo, self.origin)
        else:
            span = hi - lo
        far = max(abs(xmin), abs(ymin), abs(xmax), abs(ymax)) > MAX_COORDINATE  # (and blocks lose precision)
        if far or not np.all(np.isfinite(span)) or float(np.prod(span / self.res)) > MAX_CELLS:
            raise GridTooLarge(f"the grid would span {span[0]:.4g} x {span[1]:.4g} m to reach ({xmax:.4g}, {ymax:.4g})")
        if self.logodds.size == 0:
            self.origin = lo
            nx, ny = (np.round((hi - lo) / self.res)).astype(int)
            self.logodds = np.zeros((ny, nx), dtype=np.float32)
            self.seen = np.zeros((ny, nx), dtype=bool)
            return
        ny, nx = self.logodds.shape
        cur_hi = self.origin + np.array([nx, ny]) * self.res
        new_lo = np.minimum(self.origin, lo)
        new_hi = np.maximum(cur_hi, hi)
        if np.all(new_lo == self.origin) and np.all(new_hi == cur_hi):
            return
        off = np.round((self.origin - new_lo) / self.res).astype(int)
        nnx, nny = np.round((new_hi - new_lo) / self.res).astype(int)
        lg = np.zeros((nny, nnx), dtype=np.float32)
        sn = np.zeros((nny, nnx), dtype=bool)
        lg[off[1] : off[1] + ny, off[0] : off[0] + nx] = self.logodds
        sn[off[1] : off[1] + ny, off[0] : off[0] + nx] = self.seen
        self.origin, self.logodds, self.seen = new_lo, lg, sn
        self._trinary = None  # (the old arrays' map: made again whole, the old arrays not held)

    # ------------------------------------------------------------ update
    def insert_scan(
        self,
        sensor_pose: np.ndarray,
        angles: np.ndarray,
        ranges: np.ndarray,
        range_min: float,
        range_max: float,
    ) -> None:
        """Fuse one scan taken at ``sensor_pose`` (4x4 in the map frame); beams lie in the sensor's xy plane."""
        r = np.asarray(ranges, dtype=np.float64)
        a = np.asarray(angles, dtype=np.float64)
        nan = np.isnan(r)
        close = ~nan & (r <= range_min)  # includes -inf
        far = ~nan & ~close & (r >= range_max)  # includes +inf: no return
        clip = self.p.max_laser_range
        clipped = ~nan & ~close & ~far & (r > clip) if clip > 0 else np.zeros_like(far)
        hit = ~nan & ~close & ~far & ~clipped
        counts = ScanStats(
            scans=1,
            beams=len(r),
            hits=int(hit.sum()),
            no_return=int(far.sum()),
            too_close=int(close.sum()),
            nan=int(nan.sum()),
            clipped=int(clipped.sum()),
        )
        use = hit | clipped
        if self.p.no_return_ray_length > 0:
            use |= far
        if not use.any():
            self.stats.add(counts)
            return
        length = np.where(hit, r, np.where(clipped, clip, self.p.no_return_ray_length))[use]
        a = a[use]
        ishit = hit[use]
        rot, pos = sensor_pose[:3, :3], sensor_pose[:3, 3]
        dirs = np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], axis=1) @ rot.T
        d2 = dirs[:, :2]
        norm = np.linalg.norm(d2, axis=1)
        d2 = d2 / np.where(norm > 0, norm, 1.0)[:, None]
        length = length * norm  # projected onto the map plane
        ends = pos[:2] + d2 * length[:, None]
        self._ensure(  # GridTooLarge: neither the grid nor its counts hold the scan
            min(pos[0], ends[:, 0].min()),
            min(pos[1], ends[:, 1].min()),
            max(pos[0], ends[:, 0].max()),
            max(pos[1], ends[:, 1].max()),
        )
        self.stats.add(counts)
        nx = self.logodds.shape[1]
        # free space: sample every half cell along each beam, stopping short of the end cell
        step = self.res * 0.5
        t = np.arange(int(np.ceil(length.max() / step)) + 1, dtype=np.float32) * np.float32(step / self.res)
        last = ((length - step) / self.res).astype(np.float32)  # a beam's samples end at this t
        d2c = d2.astype(np.float32)
        g0 = ((pos[:2] - self.origin) / self.res).astype(np.float32)
        end_cells = self._cells(ends[ishit], nx)
        # the cells the scan can touch: its beams' box, a cell wider on every side (float32 samples)
        corners = (np.vstack([pos[:2], ends]) - self.origin) / self.res
        ny = self.logodds.shape[0]
        x0, y0 = np.maximum(np.floor(corners.min(axis=0)).astype(int) - 1, 0).tolist()
        x1, y1 = np.minimum(np.floor(corners.max(axis=0)).astype(int) + 2, (nx, ny)).tolist()
        self._update(t, last, d2c, g0, end_cells, (slice(y0, y1), slice(x0, x1)))

    def _update(
        self, t: np.ndarray, last: np.ndarray, d2c: np.ndarray, g0: np.ndarray, end_cells: np.ndarray, box: tuple
    ) -> None:
        """Each cell crossed by a beam updated once with the miss log-odds (clamped below), each end cell
        once with the hit log-odds (clamped above), an end cell never counting as crossed; all of them
        marked seen. Sample j of a beam lies at ``g0 + direction * t[j]`` (cells, float32 arithmetic, the
        cell by truncation); samples past ``last`` (the beam's free part) are not used, the sensor's own
        sample always is.

        The beams are taken in ``NUMPY_BEAM_GROUPS`` groups of similar length (sorted by their number
        of free samples), each group's arrays as long as its longest beam: a room's beams are mostly
        short, so this computes about half the samples one array as long as the longest beam would. A
        group with more than ``GROUP_SAMPLES`` (beam, sample) pairs is taken in parts (the same cells:
        the work arrays stay bounded for a scan of a million beams).

        Every cell the scan marks lies in ``box`` (row and column slices of the grid): the marks are read and
        cleared there, not over the whole grid (a campus's grid is tens of millions of cells)."""
        ny, nx = self.logodds.shape
        ncell = ny * nx
        # the scan's mark per cell (1 crossed, 2 end), zero between scans (each clears its box)
        mask = self._buffers.get("mask")
        if mask is None or mask.size != ncell + 1:
            mask = self._buffers["mask"] = np.zeros(ncell + 1, dtype=np.int8)
        samples = np.maximum(np.searchsorted(t, last, side="right"), 1)  # the sensor's own sample at least
        order = np.argsort(samples, kind="stable")
        bounds = np.linspace(0, len(order), NUMPY_BEAM_GROUPS + 1).astype(int)
        for lo, hi in zip(bounds[:-1], bounds[1:]):
            if hi > lo:
                longest = int(samples[order[hi - 1]])
                part = max(1, GROUP_SAMPLES // longest)
                for start in range(lo, hi, part):
                    beams = order[start : min(hi, start + part)]
                    cells = self._crossed(t[:longest], last[beams], d2c[beams], g0, nx, ncell)
                    mask[cells.reshape(-1)] = 1
        # a beam's own end cell is not cleared by it (nor by grazing neighbours in this scan)
        mask[end_cells] = 2
        mask[ncell] = 0  # the spare cell of the samples past a beam's free part
        marks = mask[:ncell].reshape(ny, nx)[box]
        # the box's marks as one row-major run (a copy where the box is narrower than the grid), read by position
        run = marks.ravel()
        at = run.nonzero()[0]  # increasing: the flat cells in increasing order
        mark = run[at]
        width = box[1].stop - box[1].start
        rows = at // width
        cells = (rows + box[0].start) * nx + (at - rows * width) + box[1].start
        marks.fill(0)
        flat = self.logodds.reshape(-1)
        seen = self.seen.reshape(-1)
        f = cells[mark == 1]
        o = cells[mark == 2]
        y0, y1, x0, x1 = box[0].start, box[0].stop, box[1].start, box[1].stop
        if self._changed is not None:
            y0, y1 = min(y0, self._changed[0]), max(y1, self._changed[1])
            x0, x1 = min(x0, self._changed[2]), max(x1, self._changed[3])
        self._changed = (y0, y1, x0, x1)
        flat[f] = np.maximum(flat[f] + self.l_miss, self.l_min)
        flat[o] = np.minimum(flat[o] + self.l_hit, self.l_max)
        seen[f] = True
        seen[o] = True

    def _crossed(
        self, t: np.ndarray, last: np.ndarray, d2c: np.ndarray, g0: np.ndarray, nx: int, ncell: int
    ) -> np.ndarray:
        """(beams x samples) flat cells of the beams' samples at ``t``; ``ncell`` (a spare cell) for
        samples past a beam's free part."""
        # the arrays live in reused work buffers: allocating them afresh for every scan costs more
        # (page faults) than the arithmetic
        shape = (len(last), len(t))
        x = self._work("x", np.float32, shape)
        gx = self._work("gx", np.intp, shape)
        cell = self._work("cell", np.intp, shape)
        past = self._work("past", bool, shape)
        np.multiply(d2c[:, 0:1], t[None, :], out=x)
        np.add(g0[0], x, out=x)
        np.copyto(gx, x, casting="unsafe")  # non-negative inside the beam: truncation = floor
        np.multiply(d2c[:, 1:2], t[None, :], out=x)
        np.add(g0[1], x, out=x)
        np.copyto(cell, x, casting="unsafe")
        np.multiply(cell, nx, out=cell)
        np.add(cell, gx, out=cell)
        np.greater(t[None, :], last[:, None], out=past)
        past[:, 0] = False  # the sensor's own cell is always crossed
        np.copyto(cell, ncell, where=past)  # samples past a beam's free part go to a spare cell
        return cell

    def _work(self, name: str, dtype, shape: tuple[int, ...]) -> np.ndarray:
        """A reusable work array of ``shape`` (contents undefined), grown when a scan needs more."""
        n = math.prod(shape)
        buf = self._buffers.get(name)
        if buf is None or buf.size < n:
            buf = np.empty(max(n, 0 if buf is None else buf.size + buf.size // 4), dtype=dtype)
            self._buffers[name] = buf
        return buf[:n].reshape(shape)

    def _cells(self, xy: np.ndarray, nx: int) -> np.ndarray:
        ij = world_to_cell(xy, self.origin, self.res)
        return ij[:, 1] * nx + ij[:, 0]

    # ------------------------------------------------------------ output
    def to_map(self, frame_id: str = "map") -> OccupancyMap:
        """Trinary grid: 100 occupied, 0 free, -1 unknown (never seen or undecided). Made again only in the box of
        the cells scans changed since the last call (whole when the grid grew or its arrays were replaced)."""
        last = self._trinary
        if last is None or last[0] is not self.logodds or last[1] is not self.seen:
            data = self._trinary_of(self.logodds, self.seen)
        else:
            data = last[2]
            if self._changed is not None:
                y0, y1, x0, x1 = self._changed
                data[y0:y1, x0:x1] = self._trinary_of(self.logodds[y0:y1, x0:x1], self.seen[y0:y1, x0:x1])
        self._trinary, self._changed = (self.logodds, self.seen, data), None
        return OccupancyMap(
            data=data.copy(),
            resolution=self.res,
            origin=(float(self.origin[0]), float(self.origin[1]), 0.0),
            frame_id=frame_id,
        )

    def _trinary_of(self, logodds: np.ndarray, seen: np.ndarray) -> np.ndarray:
        data = np.full(logodds.shape, -1, dtype=np.int8)
        data[seen & (logodds > logit(self.p.occupied_threshold))] = 100
        data[seen & (logodds < logit(self.p.free_threshold))] = 0
        return data


def project_points(
    points: np.ndarray,
    z_min: float,
    z_max: float,
    resolution: float = 0.05,
    min_points: int = 1,
    floor_below: float | None = None,
) -> OccupancyMap:
    """A 3D point map projected to a 2D grid between two heights (as users hand FAST-LIO maps to Nav2).

    Cells with at least ``min_points`` points in [z_min, z_max] are occupied (100). Cells with points
    below ``z_min`` only (the floor seen there) are free (0) — or every non-occupied cell inside the
    cloud's extent when ``floor_below`` is None; cells with no points are unknown (-1).
    """
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    p = p[np.isfinite(p).all(axis=1)]
    if len(p) == 0:
        raise ValueError("the point cloud is empty")
    if z_min > z_max:
        raise ValueError(f"z_min ({z_min}) must not exceed z_max ({z_max})")
    lo = np.floor(p[:, :2].min(axis=0) / resolution) * resolution - resolution
    ij = world_to_cell(p[:, :2], lo, resolution)
    nx, ny = ij.max(axis=0) + 2
    band = (p[:, 2] >= z_min) & (p[:, 2] <= z_max)
    counts = np.zeros((ny, nx), dtype=np.int64)
    np.add.at(counts, (ij[band, 1], ij[band, 0]), 1)
    data = np.full((ny, nx), -1, dtype=np.int8)
    if floor_below is None:
        data[:] = 0
    else:
        below = p[:, 2] < floor_below
        data[ij[below, 1], ij[below, 0]] = 0
    data[counts >= max(1, min_points)] = 100
    return OccupancyMap(data=data, resolution=resolution, origin=(float(lo[0]), float(lo[1]), 0.0))
