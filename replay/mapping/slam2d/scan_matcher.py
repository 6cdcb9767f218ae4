"""Correlative scan matching on a multi-resolution lookup grid, as Karto and Cartographer match scans.

The reference (a submap's points in the map frame) becomes a likelihood grid: every cell holds
``exp(-d^2 / 2 sigma^2)`` of its distance ``d`` to the nearest reference point (scipy's Euclidean
distance transform). A pose's *response* is the mean likelihood at the scan's points placed by it,
in [0, 1]; points off the reference count as zero.

The search covers a square of translations and a fan of yaws around a predicted pose. It is a branch
and bound over translations (Cartographer's): level ``l`` of the grid holds, in every cell, the
maximum likelihood over the ``2^l x 2^l`` cells starting there (each level the maximum of four cells
of the level below), so a candidate's score at that level bounds the score of every finer candidate
inside it. Candidates are expanded best first and a branch is dropped once its bound cannot beat the
best full-resolution score found. The winner is then refined below the cell by least squares on the
distances of the scan's points to the reference, with scipy's ``least_squares`` and a soft-L1 loss,
so points off the reference do not pull. A distance is measured to the mean of the reference points
in the nearest occupied cell (the distance transform's feature transform finds that cell), not to
the cell's centre, which would pull every point of a wall onto the centre line of its cells.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from scipy import ndimage, optimize

from navlog.replay.compiled import compile_together

# ScanMatcher.spread scores its candidates with at most this many of the scan's points
SPREAD_POINTS = 512


# the distance transform runs over tiles of this many cells a side (each widened by the reach it must be exact
# within), skipping those with no reference cell that near: most of a building's box is rooms' insides
TILE = 128

# the coarsest pooled level a search reads (cells 2^6 = 64 a side)
TOP_LEVEL = 6

# a grid finds the squares a search's reads reach by blocks of this many cells a side
READ_BLOCK = 16


def _squares_near(rows: np.ndarray, cols: np.ndarray, reach: int, squares: tuple[int, int]) -> np.ndarray:
    """(``squares``) whether each ``TILE`` square holds a cell within ``reach`` cells (along each axis) of one
    of the cells at ``rows``, ``cols``."""
    near = np.zeros(squares, dtype=bool)
    # the cell at r reaches the squares of rows (r - reach) // TILE to (r + reach) // TILE (and the same of columns)
    spans = -(-2 * reach // TILE) + 1
    for ty in range(spans):
        for tx in range(spans):
            y = np.minimum((rows - reach) // TILE + ty, (rows + reach) // TILE).clip(0, squares[0] - 1)
            x = np.minimum((cols - reach) // TILE + tx, (cols + reach) // TILE).clip(0, squares[1] - 1)
            near[y, x] = True
    return near


def _free_cells(occupied: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """(rows, columns) True but at the ``occupied`` cells (flat indices)."""
    flat_free = np.ones(shape[0] * shape[1], dtype=bool)
    flat_free[occupied] = False
    return flat_free.reshape(shape)


def _distance_squares(
    free: np.ndarray, squares: np.ndarray, reach: int
) -> Iterator[tuple[int, int, np.ndarray, np.ndarray]]:
    """scipy's Euclidean distance transform of the ``TILE`` squares marked in ``squares`` (one flag per square) from
    the cells not ``free``, and its feature transform, each square computed over itself widened by ``reach`` on
    every side. Yields per square, in row-major order, its first row and column, its distances (cells) and its
    cells' nearest occupied cells (2, rows, columns), exact wherever an occupied cell lies within ``reach``
    (elsewhere the distance is more than ``reach``). A square's figures do not depend on which others are
    computed."""
    for ty, tx in zip(*np.nonzero(squares), strict=True):
        y, x = int(ty) * TILE, int(tx) * TILE
        y0, x0 = max(0, y - reach), max(0, x - reach)
        d, f = ndimage.distance_transform_edt(free[y0 : y + TILE + reach, x0 : x + TILE + reach], return_indices=True)
        crop = (slice(y - y0, y - y0 + TILE), slice(x - x0, x - x0 + TILE))
        f = f[:, crop[0], crop[1]]
        f[0] += y0
        f[1] += x0
        yield y, x, d[crop], f


@dataclass(frozen=True)
class MatchResult:
    pose: np.ndarray  # (x, y, yaw) of the scan's frame in the reference's frame
    response: float  # mean likelihood of the scan's points at ``pose``, in [0, 1]
    # (3, 3) mean over the scan's points near the reference of J^T J, J = d(point-to-line distance)/d(x, y,
    # yaw): how strongly the match pins each direction (a corridor leaves its axis near zero)
    hessian: np.ndarray


def transform_points(pose, points: np.ndarray) -> np.ndarray:
    """(N, 2) points in a frame at planar ``pose`` (x, y, yaw), expressed in the parent frame."""
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    out = np.empty_like(points, dtype=np.float64)
    out[:, 0] = x + c * points[:, 0] - s * points[:, 1]
    out[:, 1] = y + s * points[:, 0] + c * points[:, 1]
    return out


class LookupGrid:
    """The likelihood field of reference points (map frame), its max-pooled levels, and per cell the nearest
    occupied cell (the distance transform's feature) with the mean of the points in it.

    The fields cover the reference's box widened by ``3 sigma`` (the *core*): the likelihood is cut to
    zero beyond that distance. The search reads the pooled levels on a *canvas*: the core inside a
    zero border of ``border`` cells, so that a point placed outside it reads zeros.

    The fields are computed by ``TILE`` squares when a read first reaches them (``ensure``: the searches,
    ``response`` and ``nearest`` ask for what they read), and the pooled levels with them: a search reads what
    the whole grid holds, and a grid costs only the squares its searches reach (the buffer behind a
    laser that looks ahead is never computed). ``complete`` computes every square.
    """

    def __init__(self, reference: np.ndarray, resolution: float, smear_deviation: float, border: int) -> None:
        self.res = resolution
        self._sigma = smear_deviation
        self._cut = 3.0 * smear_deviation
        self.core_origin = reference.min(axis=0) - self._cut - resolution
        nx, ny = (
            np.ceil((reference.max(axis=0) + self._cut + resolution - self.core_origin) / resolution).astype(int) + 1
        ).tolist()
        cells = np.floor((reference - self.core_origin) / resolution).astype(np.int64)
        # the occupied cells (flat indices, sorted) and each point's among them
        self._occupied, slot = np.unique(cells[:, 1] * nx + cells[:, 0], return_inverse=True)
        # the mean of the reference points in each occupied cell
        count = np.bincount(slot)
        self._mean = np.stack(
            [np.bincount(slot, reference[:, 0]) / count, np.bincount(slot, reference[:, 1]) / count], 1
        )
        # exp(-0.5 (d / sigma)^2) with d in metres, within cut of the reference (zero beyond), and per cell 1 + the
        # row and column of its nearest occupied cell (0 where no square was computed: none within reach, or not
        # read yet), both NumPy's zeros where no square is written (pages never touched)
        self.likelihood = np.zeros((ny, nx), dtype=np.float32)
        self._feature = np.zeros((2, ny, nx), dtype=np.int32)
        # the fields are read only within 3 sigma of the reference (two cells more: a point and a cell's mean
        # both lie anywhere in their cells)
        self._reach = math.ceil(self._cut / resolution) + 2
        self._free: np.ndarray | None = None  # _free_cells, once a square is computed
        rows, cols = np.divmod(self._occupied, nx)
        self._squares = (-(-ny // TILE), -(-nx // TILE))
        # per square: whether it is settled (computed, or with no occupied cell within reach: all zeros)
        self._settled = ~_squares_near(rows, cols, self._reach, self._squares)
        self._spans: list[list[int]] = []  # the computed squares, runs along their rows: (row, row end, column, end)
        self.border = border
        self.origin = self.core_origin - border * resolution  # the canvas's
        self.shape = (ny + 2 * border, nx + 2 * border)
        # the pooled levels, one flat canvas a row, written where they can be non-zero when first asked for
        # (NumPy's zeros: the pages not written stay unmapped memory)
        self._pooled = np.zeros((TOP_LEVEL + 1, self.shape[0] * self.shape[1]), dtype=np.float32)
        self._pooled_count = 0

    def complete(self) -> None:
        """Compute every square (the whole grid's fields)."""
        self._compute(~self._settled)

    def ensure(self, rows: np.ndarray, cols: np.ndarray, margin: int) -> None:
        """Compute the squares within ``margin`` cells (along each axis) of the core's cells at ``rows``, ``cols``
        (any integers: cells off the core reach the squares at its edge) that are not yet."""
        ny, nx = self.likelihood.shape
        settled = self._settled
        if 2 * margin <= TILE:  # a cell's reach spans two squares at most along each axis: its corners' squares
            sy, sx = self._squares
            lo_y, hi_y = np.clip((rows - margin) // TILE, 0, sy - 1), np.clip((rows + margin) // TILE, 0, sy - 1)
            lo_x, hi_x = np.clip((cols - margin) // TILE, 0, sx - 1), np.clip((cols + margin) // TILE, 0, sx - 1)
            corners = [(lo_y, lo_x)] if margin == 0 else [(lo_y, lo_x), (lo_y, hi_x), (hi_y, lo_x), (hi_y, hi_x)]
            if all(settled[y, x].all() for y, x in corners):
                return
        # the reads' blocks of READ_BLOCK cells (those off the core: the blocks just off it), each once, by its
        # middle cell: a read lies within half a block of it along each axis
        bx, by = -(-nx // READ_BLOCK), -(-ny // READ_BLOCK)
        block_y = np.clip(rows // READ_BLOCK, -1, by)
        block_x = np.clip(cols // READ_BLOCK, -1, bx)
        at_y, at_x = np.divmod(np.unique((block_y + 1) * (bx + 2) + block_x + 1), bx + 2)
        half = READ_BLOCK // 2
        middle_y, middle_x = (at_y - 1) * READ_BLOCK + half, (at_x - 1) * READ_BLOCK + half
        self._compute(_squares_near(middle_y, middle_x, margin + half, self._squares) & ~settled)

    def _compute(self, squares: np.ndarray) -> None:
        """Compute the squares marked in ``squares`` (none settled): their fields, and the pooled levels made so far
        where their windows reach them."""
        if not squares.any():
            return
        self._settled |= squares
        if self._free is None:
            self._free = _free_cells(self._occupied, self.likelihood.shape)
        res, cut = self.res, self._cut
        spans: list[list[int]] = []  # the new squares' runs along their rows
        for y, x, distance, feature in _distance_squares(self._free, squares, self._reach):
            distance *= res
            near = distance <= cut
            z = distance[near] / self._sigma
            np.square(z, out=z)
            z *= -0.5
            np.exp(z, out=z)
            if spans and spans[-1][0] == y and spans[-1][3] == x:  # the run of squares along the row goes on
                spans[-1][3] = x + distance.shape[1]
            else:
                spans.append([y, y + distance.shape[0], x, x + distance.shape[1]])
            square = self.likelihood[y : y + distance.shape[0], x : x + distance.shape[1]]
            square[near] = z.astype(np.float32)
            feature += 1
            self._feature[:, y : y + distance.shape[0], x : x + distance.shape[1]] = feature
        self._spans += spans
        for level in range(self._pooled_count):  # a level's new cells read the level below's, made first
            self._pool(level, spans)

    def pooled(self, level: int) -> np.ndarray:
        """Flat canvas whose cell (i, j) is the maximum likelihood over cells [i, i + 2^l) x [j, j + 2^l)
        (zero beyond the canvas), ``level`` at most ``TOP_LEVEL``: level l is level l - 1's maximum over its
        cell and the cells half a window (2^(l-1)) further along each axis. Exact where the squares its windows
        reach are computed (``ensure``)."""
        return self.levels(level)[level]

    def levels(self, top: int) -> np.ndarray:
        """(top + 1, cells) the pooled levels 0..``top`` (``pooled``), a row each. A level is computed only
        where its windows reach a run of computed squares (where every non-zero likelihood lies): its other
        cells are the zeros of the rows' allocation."""
        while self._pooled_count <= top:
            self._pool(self._pooled_count, self._spans)
            self._pooled_count += 1
        return self._pooled[: top + 1]

    def _pool(self, level: int, spans: list[list[int]]) -> None:
        """Pooled level ``level`` made where its windows reach the runs of squares ``spans``."""
        b = self.border
        rows_total, cols_total = self.shape
        canvas = self._pooled[level].reshape(self.shape)
        for y0, y1, x0, x1 in spans:
            if level == 0:
                canvas[b + y0 : b + y1, b + x0 : b + x1] = self.likelihood[y0:y1, x0:x1]
                continue
            # the cells whose window [i, i + 2^l) meets the run, and the cells h further on they read
            h = 2 ** (level - 1)
            r0, c0 = max(0, b + y0 - 2**level + 1), max(0, b + x0 - 2**level + 1)
            r1, c1 = min(rows_total, b + y1), min(cols_total, b + x1)
            half = self._pooled[level - 1].reshape(self.shape)[
                r0 : min(rows_total, r1 + h), c0 : min(cols_total, c1 + h)
            ]
            rows = np.empty_like(half)
            np.maximum(half[:-h], half[h:], out=rows[:-h])
            rows[-h:] = half[-h:]  # (the last h rows of the canvas have no cells h further on: their own)
            pooled = np.empty_like(rows)
            np.maximum(rows[:, :-h], rows[:, h:], out=pooled[:, :-h])
            pooled[:, -h:] = rows[:, -h:]
            canvas[r0:r1, c0:c1] = pooled[: r1 - r0, : c1 - c0]

    def _coordinates(self, xy: np.ndarray) -> np.ndarray:
        """(2, N) fractional (row, column) coordinates of points on the core, cell centres at integers."""
        g = (xy - self.core_origin) / self.res - 0.5
        return np.stack([g[:, 1], g[:, 0]])

    def response(self, pose, points: np.ndarray) -> float:
        """Mean interpolated likelihood of ``points`` (scan frame) placed at ``pose``."""
        if len(points) == 0:
            return 0.0
        xy = transform_points(pose, points)
        cells = np.floor((xy - self.core_origin) / self.res).astype(np.int64)
        self.ensure(cells[:, 1], cells[:, 0], 1)  # the interpolation reads the cells either side
        values = ndimage.map_coordinates(self.likelihood, self._coordinates(xy), order=1, mode="constant", cval=0.0)
        return float(values.mean())

    def nearest(self, pose, points: np.ndarray, far: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Points placed at ``pose``, their distance to the reference (``far`` at most, itself at most the
        likelihood's cut, 3 sigma; see the module docstring) and the unit vector from the reference to them
        (zero at ``far``)."""
        xy = transform_points(pose, points)
        ny, nx = self.likelihood.shape
        cells = np.floor((xy - self.core_origin) / self.res).astype(np.int64)
        self.ensure(cells[:, 1], cells[:, 0], 0)
        inside = (cells[:, 0] >= 0) & (cells[:, 0] < nx) & (cells[:, 1] >= 0) & (cells[:, 1] < ny)
        d = np.full(len(xy), far)
        away = np.zeros_like(xy)
        feature = self._feature[:, cells[inside, 1], cells[inside, 0]].astype(np.int64) - 1
        known = feature[0] >= 0  # else no reference cell within the transform's reach: farther than ``far``
        inside[inside] = known
        nearest_cell = feature[0, known] * nx + feature[1, known]
        delta = xy[inside] - self._mean[np.searchsorted(self._occupied, nearest_cell)]
        dist = np.hypot(delta[:, 0], delta[:, 1])
        use = (dist < far) & (dist > 0)
        rows = np.flatnonzero(inside)[use]
        d[rows] = dist[use]
        d[np.flatnonzero(inside)[dist == 0]] = 0.0
        away[rows] = delta[use] / dist[use, None]
        return xy, d, away


@dataclass(frozen=True)
class SearchWindow:
    linear: float  # side of the square of translations searched (m)
    angular: float  # yaw searched either side of the prediction (rad)
    angle_step: float  # yaw step (rad)


class ScanMatcher:
    """Matches scans (points in their own frame) against reference points; see the module docstring."""

    def __init__(self, resolution: float, smear_deviation: float) -> None:
        self.res = resolution
        self.sigma = smear_deviation

    def grid(self, reference: np.ndarray, window: SearchWindow) -> LookupGrid:
        """The reference's lookup grid, with a zero border wide enough for ``window``'s search."""
        w = math.ceil(window.linear / 2 / self.res)
        return LookupGrid(reference, self.res, self.sigma, 2 * w + 2 ** self._levels(window) + 1)

    def _levels(self, window: SearchWindow) -> int:
        cells = 2 * math.ceil(window.linear / 2 / self.res) + 1
        return max(0, min(TOP_LEVEL, int(math.floor(math.log2(cells))) - 1))

    def match(
        self, reference: np.ndarray, scan_points: np.ndarray, prediction, window: SearchWindow, min_response: float
    ) -> MatchResult | None:
        """The best pose of the scan within ``window`` around ``prediction`` (x, y, yaw), refined; None when
        no pose reaches ``min_response`` (or either point set is empty)."""
        grid = self.grid_around(reference, scan_points, prediction, window)
        return None if grid is None else self.match_on(grid, scan_points, prediction, window, min_response)

    def grid_around(
        self, reference: np.ndarray, scan_points: np.ndarray, prediction, window: SearchWindow
    ) -> LookupGrid | None:
        """``grid`` of the reference points a scan placed in ``window`` around ``prediction`` can reach (the
        others change no score); None when there are none (or no scan points)."""
        if len(reference) == 0 or len(scan_points) == 0:
            return None
        reach = float(np.hypot(scan_points[:, 0], scan_points[:, 1]).max()) + window.linear * 0.75 + 4 * self.sigma
        reference = reference[np.hypot(reference[:, 0] - prediction[0], reference[:, 1] - prediction[1]) <= reach]
        return self.grid(reference, window) if len(reference) else None

    def match_on(
        self, grid: LookupGrid, scan_points: np.ndarray, prediction, window: SearchWindow, min_response: float
    ) -> MatchResult | None:
        """``match`` against a lookup grid made by ``grid`` for a window at least as large (several scans
        matched against the same reference share its grid)."""
        if len(scan_points) == 0:
            return None
        best = self._search(grid, scan_points, prediction, window, min_response)
        if best is None:
            return None
        pose = self._refine(grid, scan_points, best)
        response = grid.response(pose, scan_points)
        if response < min_response:
            return None
        return MatchResult(pose, response, self._hessian(grid, scan_points, pose))

    def spread(
        self, grid: LookupGrid, points: np.ndarray, prediction, window: SearchWindow, score: float, drop: float = 0.05
    ) -> float:
        """How far apart the places within ``window`` that score like the match are: over the square's
        translations in 4 x 4-cell blocks (their pooled level-2 scores, the best over the window's yaws), the
        variance in its worst direction (m^2) of the blocks' centres scoring at least ``score - drop``, weighted
        by their scores, about their weighted mean. A single well-placed match keeps it to a few cm^2; a second
        place that looks the same metres away spreads it to metres squared (Karto's coarse covariance test)."""
        if len(points) == 0:
            return 0.0
        if len(points) > SPREAD_POINTS:  # evenly spread beams: the blocks' scores need no more
            points = points[np.linspace(0, len(points) - 1, SPREAD_POINTS).astype(np.int64)]
        level = min(2, self._levels(window))
        _, flat, w = self._placements(grid, points, prediction, window, level + 2)
        step = 2**level
        oy, ox, cand = self._offsets(w, step, grid.shape[1])
        pooled = grid.pooled(level)
        # 4 x 4 candidates at a time bounded by the level that covers their cells (a mean of maxima): only those of a
        # bound reaching score - drop at a yaw are scored at it; a block's candidates below it there are not near
        # at that yaw, and a near one is scored at every yaw it could be near at: the same blocks come out near,
        # their scores their best over the yaws
        coarse = grid.pooled(level + 2)
        _, _, corner = self._offsets(w, 4 * step, grid.shape[1])  # the blocks' first candidates, row-major
        block = (oy // (4 * step)) * math.isqrt(len(corner)) + ox // (4 * step)  # each candidate's block
        best = np.zeros(len(cand))
        bar = np.float32(score - drop)  # (a float32 mean is compared in float32, as NumPy compares it with a float)
        plan = _pairwise_plan(len(points))
        _compiled_kernels()["_best_over_yaws"](pooled, coarse, flat, plan, cand, corner, block, bar, best)
        near = best >= score - drop
        if near.sum() < 2:
            return 0.0
        centres = np.stack([ox[near], oy[near]]).astype(np.float64)
        centres = (centres + step / 2 - w) * self.res
        cov = np.cov(centres, aweights=best[near], bias=True)
        return float(np.linalg.eigvalsh(cov)[-1])

    @staticmethod
    def _offsets(w: int, step: int, nx: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The square's offsets 0..2w cells every ``step`` cells, row-major: their rows, their columns and
        their flat canvas offsets (``nx`` columns)."""
        offs = np.arange(0, 2 * w + 1, step)
        oy, ox = (o.ravel() for o in np.meshgrid(offs, offs, indexing="ij"))
        return oy, ox, oy * nx + ox

    def _placements(
        self, grid: LookupGrid, points: np.ndarray, prediction, window: SearchWindow, top: int
    ) -> tuple[np.ndarray, np.ndarray, int]:
        """The window's yaws, per yaw the flat canvas index of each point's cell at offset (0, 0) (the square's
        corner; the search reads offsets 0..2w cells from there), and w; the grid's squares that a search reading
        pooled levels up to ``top`` reaches are computed."""
        px, py, pyaw = (float(v) for v in prediction)
        w = math.ceil(window.linear / 2 / self.res)  # offsets 0..2w cells cover the square
        n_ang = int(math.floor(window.angular / window.angle_step + 1e-9))
        yaws = pyaw + window.angle_step * np.arange(-n_ang, n_ang + 1)
        ny, nx = grid.shape
        flat = np.empty((len(yaws), len(points)), dtype=np.int64)
        # the points' core cells at every yaw: a search reads from w cells before each to w + 2^top after it
        reads = np.empty((len(yaws), len(points), 2), dtype=np.int64)
        for a, yaw in enumerate(yaws.tolist()):
            xy = transform_points((px, py, yaw), points)
            cells = np.floor((xy - grid.origin) / self.res).astype(np.int64)
            reads[a] = cells - grid.border
            cells -= w
            # a point off the canvas reads its zero border
            np.clip(cells[:, 0], 0, nx - 1 - 2 * w, out=cells[:, 0])
            np.clip(cells[:, 1], 0, ny - 1 - 2 * w, out=cells[:, 1])
            flat[a] = cells[:, 1] * nx + cells[:, 0]
        grid.ensure(reads[..., 1].ravel(), reads[..., 0].ravel(), w + 2**top)
        return yaws, flat, w

    def _search(self, grid: LookupGrid, points: np.ndarray, prediction, window: SearchWindow, min_response: float):
        """Branch and bound over (yaw, x, y): the best full-resolution candidate's pose, or None."""
        px, py, _ = (float(v) for v in prediction)
        top = self._levels(window)
        yaws, flat, w = self._placements(grid, points, prediction, window, top)
        nx = grid.shape[1]
        oy, ox, cand = self._offsets(w, 2**top, nx)
        pooled = grid.pooled(top)
        scores = pooled[flat[:, None, :] + cand[None, :, None]].mean(axis=2)  # (yaws, offsets)
        order = np.argsort(-scores, axis=None, kind="stable")
        best_score, best = min_response, None
        if top == 0:  # the window is a few cells: the top level is the full resolution
            a, c = divmod(int(order[0]), len(cand))
            if scores[a, c] > best_score:
                best = (a, int(oy[c]), int(ox[c]))
            order = order[:0]
        if len(order):
            found_score, a, dy, dx = _compiled_kernels()["_branch_and_bound"](
                grid.levels(top),
                flat,
                _pairwise_plan(flat.shape[1]),
                scores.ravel(),
                order,
                len(cand),
                oy,
                ox,
                top,
                2 * w,
                nx,
                best_score,
            )
            if a >= 0:
                best = (a, dy, dx)
        if best is None:
            return None
        a, dy, dx = best
        return np.array([px + (dx - w) * self.res, py + (dy - w) * self.res, float(yaws[a])])

    def _hessian(self, grid: LookupGrid, points: np.ndarray, pose: np.ndarray) -> np.ndarray:
        """Mean J^T J of point-to-line distances over the scan's points within ``3 sigma`` of the reference:
        J's rows are d(n . p)/d(x, y, yaw) with n the scan's own surface normal at the point (from its
        neighbours in beam order), so a point on a wall pins only the direction across the wall."""
        if len(points) < 3:
            return np.zeros((3, 3))
        tangent = points[2:] - points[:-2]
        length = np.hypot(tangent[:, 0], tangent[:, 1])
        ok = (length > 0) & (length < 6 * self.sigma)  # both neighbours on the same surface
        xy, d, _ = grid.nearest(pose, points[1:-1], 3 * self.sigma)
        ok &= d < 3 * self.sigma
        if not ok.any():
            return np.zeros((3, 3))
        c, s = math.cos(pose[2]), math.sin(pose[2])
        t = tangent[ok] / length[ok, None]
        normal = np.stack([-(s * t[:, 0] + c * t[:, 1]), c * t[:, 0] - s * t[:, 1]], axis=1)  # map frame
        jac = _distance_jacobian(xy[ok], normal, pose)
        return (jac.T @ jac) / len(jac)

    @staticmethod
    def covariance(match: MatchResult, point_sigma: float, floor) -> np.ndarray:
        """(3, 3) covariance of a match's pose: ``point_sigma^2 / 2`` over its Hessian (in a room whose
        surfaces face both axes equally a translation's variance is then ``point_sigma^2``), plus the
        ``floor`` standard deviations (x, y, yaw) squared on the diagonal. A direction the scan does not
        pin (a corridor's axis) gets a variance far above the floor."""
        h = match.hessian + np.eye(3) * 1e-9
        return 0.5 * point_sigma**2 * np.linalg.inv(h) + np.diag(np.square(np.asarray(floor, dtype=np.float64)))

    def _refine(self, grid: LookupGrid, points: np.ndarray, start: np.ndarray) -> np.ndarray:
        """Least squares on the distances to the reference from ``start`` (analytic Jacobian: a distance
        changes along the unit vector away from the nearest reference point), kept within two cells."""
        far = 3 * self.sigma
        last: dict[str, tuple] = {}

        def evaluate(p: np.ndarray) -> tuple:
            key = p.tobytes()
            if last.get("key", (None,))[0] != key:
                last["key"] = (key, grid.nearest(p, points, far))
            return last["key"][1]

        def residuals(p: np.ndarray) -> np.ndarray:
            return evaluate(p)[1]

        def jacobian(p: np.ndarray) -> np.ndarray:
            xy, _, away = evaluate(p)
            return _distance_jacobian(xy, away, p)

        sol = optimize.least_squares(
            residuals,
            start,
            jac=jacobian,
            loss="soft_l1",
            f_scale=self.sigma / 2,
            x_scale=np.array([self.res, self.res, self.res]),
            xtol=1e-5,
            ftol=1e-5,
            max_nfev=20,
        )
        pose = np.asarray(sol.x, dtype=np.float64)
        if np.any(np.abs(pose[:2] - start[:2]) > 2 * self.res) or not np.all(np.isfinite(pose)):
            return np.asarray(start, dtype=np.float64)
        return pose


def _pairwise_plan(n: int) -> tuple[np.ndarray, np.ndarray]:
    """How NumPy adds a float32 row of ``n`` values (pairwise: a part longer than 128 split in two at half its
    length rounded down to a multiple of 8), as a postfix program: (start, length) of each block of at most
    128 to add in place of a start of -1, the sum of the two partial sums last made."""
    starts: list[int] = []
    lengths: list[int] = []
    parts = [(0, n, False)]
    while parts:
        lo, m, split = parts.pop()
        if m <= 128 or split:
            starts.append(lo if m <= 128 else -1)
            lengths.append(m)
            continue
        half = m // 2 - (m // 2) % 8
        parts += [(lo, m, True), (lo + half, m - half, False), (lo, half, False)]
    return np.array(starts, dtype=np.int64), np.array(lengths, dtype=np.int64)


def _block_sum(values, flat, offset, lo, n):
    """The float32 sum of ``values[flat[lo:lo + n] + offset]``, ``n`` at most 128, added as NumPy adds such a
    block (one by one below 8, else eight running sums); to be compiled."""
    if n < 8:
        total = np.float32(0.0)
        for i in range(lo, lo + n):
            total += values[flat[i] + offset]
        return total
    r0, r1, r2, r3 = (
        values[flat[lo] + offset],
        values[flat[lo + 1] + offset],
        values[flat[lo + 2] + offset],
        values[flat[lo + 3] + offset],
    )
    r4, r5, r6, r7 = (
        values[flat[lo + 4] + offset],
        values[flat[lo + 5] + offset],
        values[flat[lo + 6] + offset],
        values[flat[lo + 7] + offset],
    )
    i = lo + 8
    end = lo + n - n % 8
    while i < end:
        r0 += values[flat[i] + offset]
        r1 += values[flat[i + 1] + offset]
        r2 += values[flat[i + 2] + offset]
        r3 += values[flat[i + 3] + offset]
        r4 += values[flat[i + 4] + offset]
        r5 += values[flat[i + 5] + offset]
        r6 += values[flat[i + 6] + offset]
        r7 += values[flat[i + 7] + offset]
        i += 8
    total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < lo + n:
        total += values[flat[i] + offset]
        i += 1
    return total


def _row_mean(values, flat, offset, plan_start, plan_length, partial):
    """The float32 mean of ``values[flat + offset]`` to the bit of NumPy's (``_pairwise_plan`` of
    ``len(flat)``; ``partial`` room for its partial sums); to be compiled."""
    depth = 0
    for k in range(plan_start.shape[0]):
        if plan_start[k] >= 0:
            partial[depth] = _block_sum(values, flat, offset, plan_start[k], plan_length[k])
            depth += 1
        else:
            depth -= 1
            partial[depth - 1] = partial[depth - 1] + partial[depth]
    return partial[0] / np.float32(flat.shape[0])


def _branch_and_bound(levels, flat, plan, scores, order, n_offsets, oy, ox, top, limit, nx, best_score):
    """The branch and bound of ``ScanMatcher._search`` below its top level, to be compiled: the top level's
    candidates (``scores``, flat (yaw, offset), and their ``order``, best first) expanded depth first, each
    candidate's four children (offsets ``2^(l-1)`` apart, none beyond ``limit``) scored on the level below
    (``levels``: the pooled canvases, a row each; a score is the float32 mean of the scan's cells ``flat``
    read there, as ``plan``, their ``_pairwise_plan``, adds them) and visited best first (ties in row-major order), a branch dropped once its score is no
    more than ``best_score``. Returns (best score, yaw index, row offset, column offset) of the best
    full-resolution candidate above ``best_score``, the index -1 when there is none."""
    plan_start, plan_length = plan
    partial = np.empty(plan_start.shape[0], dtype=np.float32)
    kid_y = np.empty((top + 1, 4), dtype=np.int64)
    kid_x = np.empty((top + 1, 4), dtype=np.int64)
    kid_score = np.empty((top + 1, 4), dtype=np.float32)
    kid_order = np.empty((top + 1, 4), dtype=np.int64)
    kid_count = np.zeros(top + 1, dtype=np.int64)
    visited = np.zeros(top + 1, dtype=np.int64)
    best_a, best_y, best_x = -1, 0, 0
    for k in order:
        if scores[k] <= np.float32(best_score):  # (compared in float32, as NumPy compares a float32 and a float)
            break
        a = k // n_offsets
        c = k % n_offsets
        level = top
        y, x = oy[c], ox[c]
        while True:
            if y >= 0:  # expand (y, x) of ``level``: its children, scored on level - 1 and sorted
                h = 1 << (level - 1)
                m = 0
                for i in (0, h):
                    for j in (0, h):
                        if y + i <= limit and x + j <= limit:
                            kid_y[level, m] = y + i
                            kid_x[level, m] = x + j
                            offset = (y + i) * nx + x + j
                            kid_score[level, m] = _row_mean(
                                levels[level - 1], flat[a], offset, plan_start, plan_length, partial
                            )
                            kid_order[level, m] = m
                            q = m
                            while q > 0 and kid_score[level, kid_order[level, q - 1]] < kid_score[level, m]:
                                kid_order[level, q] = kid_order[level, q - 1]
                                q -= 1
                            kid_order[level, q] = m
                            m += 1
                kid_count[level] = m
                visited[level] = 0
                y = -1
            if visited[level] == kid_count[level]:
                if level == top:
                    break
                level += 1
                continue
            i = kid_order[level, visited[level]]
            visited[level] += 1
            s = float(kid_score[level, i])
            if s <= best_score:
                visited[level] = kid_count[level]
            elif level == 1:
                best_score, best_a, best_y, best_x = s, a, kid_y[level, i], kid_x[level, i]
            else:
                y, x = kid_y[level, i], kid_x[level, i]
                level -= 1
    return best_score, best_a, best_y, best_x


def _best_over_yaws(pooled, coarse, flat, plan, cand, corner, block, bar, best):
    """``ScanMatcher.spread``'s scores, to be compiled: per yaw (the scan's cells ``flat``, a row each) each
    group of blocks bounded by its float32 mean on ``coarse`` from its ``corner``, and each candidate ``cand``
    of a group (``block``) whose bound reaches ``bar`` scored by its mean on ``pooled``; ``best`` (float64)
    raised to the best score of each candidate over the yaws. The means are NumPy's to the bit (``plan``, the
    ``_pairwise_plan`` of the scan's points)."""
    plan_start, plan_length = plan
    partial = np.empty(plan_start.shape[0], dtype=np.float32)
    bound = np.empty(corner.shape[0], dtype=np.float32)
    for a in range(flat.shape[0]):
        for g in range(corner.shape[0]):
            bound[g] = _row_mean(coarse, flat[a], corner[g], plan_start, plan_length, partial)
        for c in range(cand.shape[0]):
            if bound[block[c]] >= bar:
                score = _row_mean(pooled, flat[a], cand[c], plan_start, plan_length, partial)
                if score > best[c]:
                    best[c] = score


@functools.cache
def _compiled_kernels() -> dict:
    """``_branch_and_bound`` and ``_best_over_yaws`` compiled by numba (on first use; cached on disk), by name."""
    return compile_together(globals(), (_block_sum, _row_mean, _branch_and_bound, _best_over_yaws))


def _distance_jacobian(xy: np.ndarray, away: np.ndarray, pose: np.ndarray) -> np.ndarray:
    """(N, 3) d(distance)/d(x, y, yaw) of points placed at ``xy`` by ``pose``: a distance changes along the
    unit vector ``away`` from the nearest reference point; d(xy)/d(yaw) = (-arm_y, arm_x)."""
    arm = xy - pose[:2]
    return np.stack([away[:, 0], away[:, 1], away[:, 1] * arm[:, 0] - away[:, 0] * arm[:, 1]], axis=1)
