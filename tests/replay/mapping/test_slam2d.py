"""2D SLAM on a known room: the scan matcher, loop closure, the map and determinism.

Scans are ray cast (Open3D, through ``tests/replay/lidar_scene``) in a 10 x 10 m room with four
boxes, at the height of a 2D laser, from known poses.
"""

from __future__ import annotations

import dataclasses
import math

import gtsam
import numpy as np
import open3d as o3d
import pytest

from navlog.replay.mapping.slam2d import LaserScan2D, ScanMatcher, SearchWindow, Slam2D, SlamParams
from navlog.replay.mapping.slam2d.scan_matcher import transform_points
from navlog.replay.mapping.slam2d.slam import CALIBRATION_WINDOW, WIDE_REFINE
from tests.replay import lidar_scene
from tests.replay.mapping.planar_logs import degraded_odometry

N_BEAMS = 720
RANGE_MAX = 8.0
ANGLES = -math.pi + 2 * math.pi * np.arange(N_BEAMS) / N_BEAMS
MOUNT = np.eye(4)


@pytest.fixture(scope="module")
def scene() -> o3d.t.geometry.RaycastingScene:
    return lidar_scene.raycasting_scene(lidar_scene.room_mesh())


def cast(scene, pose, rng: np.random.Generator | None = None, noise: float = 0.01) -> np.ndarray:
    """Ranges of a 720-beam scan at planar ``pose`` (x, y, yaw), 0.3 m above the floor; inf past RANGE_MAX."""
    x, y, yaw = pose
    dirs = np.stack([np.cos(ANGLES + yaw), np.sin(ANGLES + yaw), np.zeros(N_BEAMS)], axis=1)
    rays = np.concatenate([np.tile([x, y, 0.3], (N_BEAMS, 1)), dirs], axis=1).astype(np.float32)
    r = scene.cast_rays(o3d.core.Tensor(rays))["t_hit"].numpy().astype(np.float64)
    if rng is not None:
        r = r + rng.normal(0.0, noise, N_BEAMS)
    r[r > RANGE_MAX] = np.inf
    return r


def scan_of(ranges: np.ndarray) -> LaserScan2D:
    return LaserScan2D(ANGLES, ranges, 0.05, RANGE_MAX, MOUNT)


def test_matcher_recovers_a_known_offset_within_a_cell(scene):
    rng = np.random.default_rng(1)
    true = np.array([0.6, -0.4, 0.3])
    ref_pose = true + np.array([-0.12, 0.07, -0.05])  # where the reference scan was taken
    reference = transform_points(ref_pose, scan_of(cast(scene, ref_pose, rng)).points(RANGE_MAX))
    points = scan_of(cast(scene, true, rng)).points(RANGE_MAX)
    # the prediction is off by (0.12 m, -0.07 m, 0.05 rad): the search must find the true pose
    prediction = true + np.array([0.12, -0.07, 0.05])
    matcher = ScanMatcher(0.025, 0.1)
    res = matcher.match(reference, points, prediction, SearchWindow(0.5, 0.349, 0.0349), 0.1)
    assert res is not None
    assert np.hypot(*(res.pose[:2] - true[:2])) < 0.025
    assert abs(res.pose[2] - true[2]) < 0.005
    assert res.response > 0.8
    # far off the window, no pose reaches the response: None, not a wrong pose
    assert (
        matcher.match(reference, points, true + np.array([3.0, 3.0, 0.0]), SearchWindow(0.5, 0.1, 0.0349), 0.8) is None
    )


def test_a_second_place_that_looks_the_same_spreads_the_search(scene):
    """The room's scan from a known pose against the room alone: the places scoring within 0.05 of the match
    lie within a few cm^2 of it. Against the room and a copy of it 15 m along x (a look-alike building
    part), both copies score alike and the spread is that of two places 15 m apart, (7.5 m)^2."""
    rng = np.random.default_rng(3)
    true = np.array([0.6, -0.4, 0.3])
    room = transform_points(true, scan_of(cast(scene, true, rng)).points(RANGE_MAX))
    points = scan_of(cast(scene, true, rng)).points(RANGE_MAX)
    matcher = ScanMatcher(0.1, 0.1)  # a wide search's coarser grid
    window = SearchWindow(32.0, 0.1, 0.0349)
    spreads = []
    for reference in (room, np.concatenate([room, room + (15.0, 0.0)])):
        grid = matcher.grid_around(reference, points, true, window)
        found = matcher.match_on(grid, points, true, window, 0.5)
        assert found is not None and found.response > 0.8
        spreads.append(matcher.spread(grid, points, true, window, found.response))
    alone, twice = spreads
    assert alone < 0.05
    assert 7.5**2 * 0.9 < twice < 7.5**2 * 1.1


def test_the_spread_scores_only_blocks_that_can_come_near_and_reads_as_scoring_all_would(scene):
    """``spread`` skips 4 x 4 candidates whose bound cannot reach the bar at a yaw: on the room and its copy 15 m
    along (two places alike), for bars from the match's score down to a third of it, the variance is bit for bit
    the one of scoring every candidate at every yaw (the definition, computed here directly)."""
    rng = np.random.default_rng(3)
    true = np.array([0.6, -0.4, 0.3])
    room = transform_points(true, scan_of(cast(scene, true, rng)).points(RANGE_MAX))
    points = scan_of(cast(scene, true, rng)).points(RANGE_MAX)
    reference = np.concatenate([room, room + (15.0, 0.0)])
    matcher = ScanMatcher(0.1, 0.1)
    window = SearchWindow(32.0, 0.1, 0.0349)
    grid = matcher.grid_around(reference, points, true, window)
    found = matcher.match_on(grid, points, true, window, 0.5)
    sample = points[np.linspace(0, len(points) - 1, 512).astype(np.int64)]
    _, flat, w = matcher._placements(grid, sample, true, window, 4)  # spread's levels: 2 and 4
    oy, ox, cand = matcher._offsets(w, 4, grid.shape[1])
    scores = np.array([grid.pooled(2)[row[None, :] + cand[:, None]].mean(axis=1) for row in flat]).max(axis=0)
    for bar in (found.response, 0.6 * found.response, 0.35 * found.response):
        near = scores >= bar - 0.05
        centres = (np.stack([ox[near], oy[near]]).astype(np.float64) + 2 - w) * matcher.res
        want = float(np.linalg.eigvalsh(np.cov(centres, aweights=scores[near], bias=True))[-1])
        assert near.sum() >= 2 and matcher.spread(grid, points, true, window, bar) == want
    assert matcher.spread(grid, points, true, window, found.response) > 7.5**2 * 0.9


def test_every_pooled_level_bounds_the_finer_cells_it_covers():
    """Level l holds in each cell the maximum of level 0 over the 2^l x 2^l cells from it, up to the
    canvas's far edges: a branch-and-bound bound that fell short there (it read 0 where a wall 1.0 was,
    for the wide windows of a loop search) let the search drop the best pose. The same levels when they were
    made before any square was computed and the squares came in two rounds after (a grid computes a square
    when a read first reaches it)."""
    from navlog.replay.mapping.slam2d.scan_matcher import TOP_LEVEL, LookupGrid

    rng = np.random.default_rng(3)
    # two clusters 9 m apart: most of the squares between them hold no reference cell, and are not pooled
    clusters = np.concatenate([rng.uniform(0.0, 1.5, (200, 2)), rng.uniform(9.0, 10.5, (200, 2))])
    for reference, border in (
        (rng.uniform(0.0, 3.0, (400, 2)), 80),
        (rng.uniform(0.0, 3.0, (400, 2)), 5),
        (clusters, 70),
    ):
        # (a border narrower than a window: windows from the canvas's first cell reach the core)
        grid = LookupGrid(reference, 0.025, 0.1, border)
        grid.complete()
        rows, cols = grid.shape
        base = grid.pooled(0).reshape(rows, cols)
        for level in range(1, 7):
            k = 2**level
            padded = np.zeros((rows + k, cols + k), np.float32)
            padded[:rows, :cols] = base
            along = np.zeros((rows, cols + k), np.float32)  # the maximum over a window is over its rows, then columns
            for dy in range(k):
                along = np.maximum(along, padded[dy : dy + rows])
            want = np.zeros_like(base)
            for dx in range(k):
                want = np.maximum(want, along[:, dx : dx + cols])
            assert np.array_equal(grid.pooled(level).reshape(rows, cols), want), (border, level)
        later = LookupGrid(reference, 0.025, 0.1, border)
        assert not later.levels(TOP_LEVEL).any()
        later.ensure(np.array([0]), np.array([0]), 0)  # the square at the core's first cell
        assert 0 < later.likelihood.any(axis=1).sum() < grid.likelihood.any(axis=1).sum()
        later.complete()
        assert np.array_equal(later.levels(TOP_LEVEL), grid.levels(TOP_LEVEL)), border
    assert len(grid._spans) > 1 and sum((y1 - y0) * (x1 - x0) for y0, y1, x0, x1 in grid._spans) < base.size / 4


def test_the_compiled_mean_adds_as_numpy_adds_a_float32_row():
    """The branch and bound's scores are NumPy's float32 means to the bit, whatever the row's length (pairwise
    below and above its blocks of 128), so the compiled search visits what a NumPy one would."""
    from navlog.replay.compiled import compile_together
    from navlog.replay.mapping.slam2d import scan_matcher

    kernels = (scan_matcher._block_sum, scan_matcher._row_mean)
    mean = compile_together(vars(scan_matcher), kernels)["_row_mean"]
    rng = np.random.default_rng(5)
    values = (rng.random(5000) ** 3).astype(np.float32)
    for n in [*range(1, 300), 511, 512, 513, 1000, 1024, 1500, 4095, 8192]:
        flat = rng.integers(0, 4000, n)
        want = values[flat + 7][None, :].repeat(2, axis=0).mean(axis=1)[0]
        starts, lengths = scan_matcher._pairwise_plan(n)
        assert mean(values, flat, 7, starts, lengths, np.empty(len(starts), np.float32)) == want, n


def test_the_search_finds_the_best_full_resolution_candidate_of_its_window(scene):
    """Branch and bound drops only branches that cannot win: on a room, from predictions up to a metre off, its
    pick scores what the best of every (yaw, offset) of the window scores at full resolution."""
    rng = np.random.default_rng(8)
    true = np.array([0.4, -0.3, 0.2])
    reference = transform_points(true, scan_of(cast(scene, true, rng)).points(RANGE_MAX))
    points = scan_of(cast(scene, true, rng)).points(RANGE_MAX)[::3]
    matcher = ScanMatcher(0.05, 0.1)
    window = SearchWindow(2.0, 0.1, 0.0349)
    for offset in ([0.0, 0.0, 0.0], [0.5, -0.6, 0.05], [-0.9, 0.2, -0.08]):
        prediction = true + offset
        grid = matcher.grid_around(reference, points, prediction, window)
        yaws, flat, w = matcher._placements(grid, points, prediction, window, matcher._levels(window))
        _, _, cand = matcher._offsets(w, 1, grid.shape[1])
        every = grid.pooled(0)[flat[:, None, :] + cand[None, :, None]].mean(axis=2)
        found = matcher._search(grid, points, prediction, window, 0.2)
        a = int(np.argmin(np.abs(yaws - found[2])))
        dy, dx = (round((found[i] - prediction[i]) / matcher.res) + w for i in (1, 0))
        assert every[a, dy * (2 * w + 1) + dx] == every.max() > 0.5
        assert np.linalg.norm(found[:2] - true[:2]) < 0.1


def test_the_distance_transform_by_tiles_is_exact_within_its_reach(monkeypatch):
    """With tiles of 5 cells (many per mask, most widened boxes crossing others), on sparse random cells and on a
    lattice (every cell between two lattice points has equidistant nearest cells: ties), the tiled transform's
    distance and nearest cell are scipy's whole-mask ones wherever those lie within ``reach``; elsewhere its
    distance is more than ``reach``, and the tiles it leaves out hold no cell within it."""
    from scipy import ndimage

    from navlog.replay.mapping.slam2d import scan_matcher

    monkeypatch.setattr(scan_matcher, "TILE", 5)
    rng = np.random.default_rng(11)
    lattice = np.ones((37, 41), dtype=bool)
    lattice[::6, ::6] = False
    masks = [rng.random((37, 41)) > 0.01 for _ in range(4)] + [lattice]
    beyond = skipped = 0
    for free in masks:
        for reach in (1, 3, 7):
            want, want_feature = ndimage.distance_transform_edt(free, return_indices=True)
            got = np.full(free.shape, np.inf)
            feature = np.full((2, *free.shape), -1)
            rows, cols = np.nonzero(~free)
            near = scan_matcher._squares_near(rows, cols, reach, (-(-free.shape[0] // 5), -(-free.shape[1] // 5)))
            for y, x, d, f in scan_matcher._distance_squares(free, near, reach):
                got[y : y + d.shape[0], x : x + d.shape[1]] = d
                feature[:, y : y + d.shape[0], x : x + d.shape[1]] = f
            within = want <= reach
            assert np.array_equal(got[within], want[within])
            assert np.array_equal(feature[:, within], want_feature[:, within])
            assert (got[~within] > reach).all()
            beyond += int((~within).sum())
            skipped += int(np.isinf(got).sum())
    assert beyond > 1000 and skipped > 100  # cells beyond the reach were met, in skipped tiles and in computed ones


def test_the_lookup_grid_holds_what_one_distance_transform_over_its_whole_box_gives():
    """The distance transform runs tile by tile, skipping tiles with no reference point near: on the walls of
    a 14 x 9 m hall (three of them, the far corner empty for metres) and clutter inside, the likelihood is
    bit for bit the one scipy's transform over the whole box gives, and so is every point's distance to the
    reference and direction from it (``nearest``), near a wall, in the empty corner and off the grid."""
    from scipy import ndimage

    from navlog.replay.mapping.slam2d.scan_matcher import TILE, LookupGrid

    rng = np.random.default_rng(7)
    walls = [((0.0, 0.0), (14.0, 0.0)), ((0.0, 0.0), (0.0, 9.0)), ((0.0, 9.0), (3.0, 9.0))]
    parts = [np.linspace(a, b, int(np.hypot(*np.subtract(b, a)) / 0.01)) for a, b in walls]
    parts.append(rng.uniform((1.0, 1.0), (5.0, 4.0), (300, 2)))
    reference = np.concatenate(parts) + rng.normal(0.0, 0.005, (sum(map(len, parts)), 2))
    res, sigma = 0.025, 0.1
    grid = LookupGrid(reference, res, sigma, 10)
    grid.complete()
    ny, nx = grid.likelihood.shape
    assert ny > 2 * TILE and nx > 4 * TILE and (grid._feature[0] == 0).any()  # some tiles were skipped
    # the whole box at once
    cells = np.floor((reference - grid.core_origin) / res).astype(np.int64)
    free = np.ones((ny, nx), dtype=bool)
    free[cells[:, 1], cells[:, 0]] = False
    distance, feature = ndimage.distance_transform_edt(free, return_indices=True)
    distance *= res
    want = np.exp(-0.5 * np.square(distance / sigma)).astype(np.float32)
    want[distance > 3 * sigma] = 0.0
    assert np.array_equal(grid.likelihood, want)
    occupied, slot = np.unique(cells[:, 1] * nx + cells[:, 0], return_inverse=True)
    count = np.bincount(slot)
    mean = np.stack([np.bincount(slot, reference[:, 0]) / count, np.bincount(slot, reference[:, 1]) / count], 1)
    queries = np.concatenate(
        [
            reference[rng.integers(0, len(reference), 2000)] + rng.normal(0.0, 0.2, (2000, 2)),
            rng.uniform((-2.0, -2.0), (16.0, 11.0), (2000, 2)),
        ]
    )
    far = 3 * sigma
    xy, d, away = grid.nearest((0.0, 0.0, 0.0), queries, far)
    q = np.floor((queries - grid.core_origin) / res).astype(np.int64)
    on = (q[:, 0] >= 0) & (q[:, 0] < nx) & (q[:, 1] >= 0) & (q[:, 1] < ny)
    nearest = np.searchsorted(occupied, feature[0, q[on, 1], q[on, 0]] * nx + feature[1, q[on, 1], q[on, 0]])
    delta = queries[on] - mean[nearest]
    dist = np.hypot(delta[:, 0], delta[:, 1])
    want_d = np.full(len(queries), far)
    want_d[np.flatnonzero(on)[dist < far]] = dist[dist < far]
    assert np.array_equal(xy, queries) and np.array_equal(d, want_d)
    close = np.flatnonzero(on)[(dist < far) & (dist > 0)]
    assert np.array_equal(away[close], delta[(dist < far) & (dist > 0)] / dist[(dist < far) & (dist > 0), None])
    assert 1000 < len(close) < len(queries) - 1000 and not away[np.setdiff1d(np.arange(len(queries)), close)].any()


@pytest.mark.parametrize("tile", [128, 16])
def test_a_grid_computes_the_squares_its_reads_reach_and_reads_as_the_whole_grid(monkeypatch, tile):
    """A hall's walls and clutter all round, and a laser that sees 60 degrees ahead: a grid computes its distance
    squares as searches first read them, so the squares behind the laser are never computed for a search from
    the prediction (a third of the cells for the sequential square, fewer for a 2 m one), and every read finds
    what the whole grid holds, to the bit: the match (pose, response, Hessian), its spread, a second search from
    a pose turned twice the window's fan further and moved, and the response and the nearest reference at a
    place 3 m off. With squares of 16 cells, a read's reach decides which squares it needs."""
    from navlog.replay.mapping.slam2d import scan_matcher

    monkeypatch.setattr(scan_matcher, "TILE", tile)
    rng = np.random.default_rng(3)
    corners = [(-8.0, -8.0), (8.0, -8.0), (8.0, 8.0), (-8.0, 8.0), (-8.0, -8.0)]
    parts = [np.linspace(a, b, 800) for a, b in zip(corners[:-1], corners[1:], strict=True)]
    parts.append(rng.uniform((-7.0, -7.0), (7.0, 7.0), (600, 2)))
    reference = np.concatenate(parts) + rng.normal(0.0, 0.005, (sum(map(len, parts)), 2))
    true = np.array([0.3, -0.2, 0.1])
    reference = reference[np.hypot(*(reference - true[:2]).T) < 6.9]
    c, s = math.cos(true[2]), math.sin(true[2])
    local = (reference - true[:2]) @ np.array([[c, -s], [s, c]])  # the reference in the laser's frame
    ahead = np.abs(np.arctan2(local[:, 1], local[:, 0])) < math.pi / 6
    points = local[ahead] + rng.normal(0.0, 0.01, (int(ahead.sum()), 2))
    assert np.hypot(*points.T).max() > 6.8  # the scan reaches as far as the reference: grid_around cuts none of it
    matcher = ScanMatcher(0.02, 0.05)
    for window, prediction, share in (
        (SearchWindow(0.5, 0.349, 0.0349), true + [0.1, -0.08, 0.04], 0.7),
        (SearchWindow(2.0, 0.349, 0.0349), true + [-0.6, 0.5, -0.1], 0.9),
    ):
        part = matcher.grid_around(reference, points, prediction, window)
        whole = matcher.grid(reference, window)
        whole.complete()
        assert part.likelihood.shape == whole.likelihood.shape and not part.likelihood.any()
        found = [matcher.match_on(g, points, prediction, window, 0.3) for g in (part, whole)]
        assert (part._feature[0] > 0).sum() < share * (whole._feature[0] > 0).sum()
        assert np.linalg.norm(found[0].pose[:2] - true[:2]) < 0.03
        assert np.array_equal(found[0].pose, found[1].pose) and found[0].response == found[1].response
        assert np.array_equal(found[0].hessian, found[1].hessian)
        spreads = [matcher.spread(g, points, prediction, window, found[0].response) for g in (part, whole)]
        assert spreads[0] == spreads[1]
        turned = found[0].pose + [0.15, -0.1, 2 * window.angular]
        again = [matcher.match_on(g, points[::2], turned, window, 0.1) for g in (part, whole)]
        assert np.array_equal(again[0].pose, again[1].pose) and again[0].response == again[1].response
        assert np.array_equal(again[0].hessian, again[1].hessian)
        off = true + [-3.0, 1.0, 2.5]
        assert part.response(off, points) == whole.response(off, points) > 0.0
        fresh = matcher.grid_around(reference, points, prediction, window)
        near = [g.nearest(off, points, 0.15) for g in (fresh, whole)]
        assert all(np.array_equal(a, b) for a, b in zip(*near, strict=True)) and (near[0][1] < 0.15).sum() >= 3


def test_a_search_reaching_past_the_squares_either_side_of_its_own_computes_its_own():
    """Walls along three rows of squares with the two rows between them empty (settled: no reference near), and a
    search whose reach (72 cells) spans three squares from a scan in the middle row: the squares either side of its
    own are settled, and its own is computed still, so the match is the whole grid's."""
    from navlog.replay.mapping.slam2d.scan_matcher import TILE

    xs = np.linspace(0.0, 12.0, 2400)
    rows_y = [0.0, 2 * TILE * 0.025 + 1.275, 4 * TILE * 0.025 + 0.625]  # core rows in squares 0, 2 and 4

    def wall(y: float) -> np.ndarray:
        return np.stack([xs, np.full_like(xs, y)], 1)

    stub = np.stack([np.full(40, 3.0), rows_y[1] + np.linspace(-0.1, 0.0, 40)], 1)  # pins the scan along the wall
    reference = np.concatenate([wall(y) for y in rows_y] + [stub])
    matcher = ScanMatcher(0.025, 0.1)
    window = SearchWindow(2.0, 0.0, 0.0349)
    true = np.array([2.0, rows_y[1] - 0.1, 0.0])
    points = reference[(np.abs(reference[:, 1] - rows_y[1]) < 0.2) & (reference[:, 0] > 0.5)] - true[:2]
    prediction = true + [0.04, -0.03, 0.0]
    lazy = matcher.grid_around(reference, points, prediction, window)
    assert lazy._settled[1].all() and lazy._settled[3].all() and not lazy._settled[2].all()
    found = matcher.match_on(lazy, points, prediction, window, 0.1)
    whole = matcher.grid_around(reference, points, prediction, window)
    whole.complete()
    want = matcher.match_on(whole, points, prediction, window, 0.1)
    assert want is not None and want.response > 0.9 and np.linalg.norm(want.pose[:2] - true[:2]) < 0.03
    assert found is not None and np.array_equal(found.pose, want.pose) and found.response == want.response


def rectangle_path(step: float = 0.1) -> np.ndarray:
    """(n, 3) poses along a 6 x 6 m rectangle, driven once and a third, heading along the path."""
    corners = [(-3, -3), (3, -3), (3, 3), (-3, 3), (-3, -3), (3, -3), (3, -1)]
    out = []
    for (x0, y0), (x1, y1) in zip(corners[:-1], corners[1:], strict=True):
        n = int(round(math.hypot(x1 - x0, y1 - y0) / step))
        yaw = math.atan2(y1 - y0, x1 - x0)
        out += [(x0 + (x1 - x0) * i / n, y0 + (y1 - y0) * i / n, yaw) for i in range(n)]
    return np.array(out)


def drifting_odometry(truth: np.ndarray, yaw_error: float) -> np.ndarray:
    """Odometry integrating the true steps with every turn (and step heading) scaled by ``1 + yaw_error``."""
    odom = [truth[0].copy()]
    for a, b in zip(truth[:-1], truth[1:], strict=True):
        c, s = math.cos(a[2]), math.sin(a[2])
        dx, dy = b[0] - a[0], b[1] - a[1]
        lx, ly = c * dx + s * dy, -s * dx + c * dy  # the step in the robot frame
        dyaw = math.remainder(b[2] - a[2], 2 * math.pi) * (1 + yaw_error)
        o = odom[-1]
        co, so = math.cos(o[2]), math.sin(o[2])
        odom.append(np.array([o[0] + co * lx - so * ly, o[1] + so * lx + co * ly, o[2] + dyaw]))
    return np.array(odom)


def odometry_moved(truth: np.ndarray, at: int, offset) -> np.ndarray:
    """Odometry that is ``truth`` up to scan ``at`` and from there the truth's poses moved by ``offset`` (a
    gtsam.Pose2 composed on their left): a reset, a jump or a turn the wheels did not report."""
    import gtsam

    odom = truth.copy()
    for i in range(at, len(truth)):
        p = offset.compose(gtsam.Pose2(*truth[i]))
        odom[i] = (p.x(), p.y(), p.theta())
    return odom


def run_slam(scene, truth: np.ndarray, odom: np.ndarray, params: SlamParams) -> Slam2D:
    rng = np.random.default_rng(5)
    slam = Slam2D(params)
    for i, (t, o) in enumerate(zip(truth, odom, strict=True)):
        slam.add_scan(i * 100_000_000, o, scan_of(cast(scene, t, rng)))
    return slam


def test_a_loop_closure_removes_the_odometry_drift(scene):
    truth = rectangle_path()
    odom = drifting_odometry(truth, 0.012)
    revisit = 240  # back at the start corner: the path's first lap ends here
    drift = np.hypot(*(odom[revisit, :2] - truth[revisit, :2]))
    assert 0.25 < drift < 0.4
    # sequential matches are refused (response 1.0 is never reached): only odometry and loops place keyframes
    params = SlamParams(
        link_match_minimum_response_fine=1.0,
        loop_match_minimum_chain_size=4,
        scan_buffer_size=6,
        loop_search_maximum_distance=2.0,
    )
    slam = run_slam(scene, truth, odom, params)
    assert slam.counts.matched == 0 and slam.counts.loops >= 1
    stamps, poses = slam.trajectory()
    assert len(stamps) == len(truth)
    err = np.hypot(*(poses[:, :2] - truth[:, :2]).T)
    assert err[revisit] < 0.05 and err[-1] < 0.05
    # the pose graph holds the odometry chain and the loops
    kinds = [e.kind for e in slam.graph.edges]
    assert kinds.count("odometry") == len(slam.keyframes) - 1 and kinds.count("loop") == slam.counts.loops


def test_a_log_whose_scans_lie_far_apart_still_makes_chains_to_close_loops_on(scene):
    """The rectangle with its scans 0.5 m apart (a log recorded once per half metre), placed by odometry alone
    that turns 1.2 % too much, loops searched 1 m around each keyframe: a revisit's near keyframes, 2 m of path,
    are four or five, fewer than ``loop_match_minimum_chain_size`` (10). They span as much travel as ten
    keyframes made every ``minimum_travel_distance`` (0.1 m) would, and the loop closes; with keyframes made
    every 0.45 m (each scan still one) ten of them would span 4.05 m, no chain is ever long enough and the
    drift stays."""
    truth = rectangle_path()[::5]
    odom = drifting_odometry(truth, 0.012)
    revisit = 48  # back at the start corner
    assert 0.25 < np.hypot(*(odom[revisit, :2] - truth[revisit, :2])) < 0.4
    base = {
        "link_match_minimum_response_fine": 1.0,
        "scan_buffer_size": 6,
        "loop_search_maximum_distance": 1.0,
        "loop_search_path_sigmas": 0.0,
        "loop_search_global": False,
    }
    errors = {}
    for travel in (0.1, 0.45):
        slam = run_slam(scene, truth, odom, SlamParams(minimum_travel_distance=travel, **base))
        assert slam.counts.keyframes == len(truth)  # every scan a keyframe either way
        _, poses = slam.trajectory()
        errors[travel] = (slam.counts, np.hypot(*(poses[:, :2] - truth[:, :2]).T))
    counts, err = errors[0.1]
    assert counts.loops >= 1 and err[revisit] < 0.05 and err[-1] < 0.05
    counts, err = errors[0.45]
    assert counts.loop_attempts == 0 and err[revisit] > 0.25


def drifted_corner_run(scene, **params) -> tuple[Slam2D, np.ndarray]:
    """Keyframes placed by odometry alone (0.1 m, 0.05 rad per edge) that turns 4 % too much, loops searched
    from 0.5 m with 4-keyframe chains and ``params``: the SLAM and its position error at every scan."""
    truth = rectangle_path()
    odom = drifting_odometry(truth, 0.04)
    assert 1.0 < np.hypot(*(odom[240, :2] - truth[240, :2])) < 1.1  # back at the start corner, 1.03 m off
    base = {
        "link_match_minimum_response_fine": 1.0,
        "loop_match_minimum_chain_size": 4,
        "scan_buffer_size": 6,
        "loop_search_maximum_distance": 0.5,
    }
    slam = run_slam(scene, truth, odom, SlamParams(**{**base, **params}))
    _, poses = slam.trajectory()
    return slam, np.hypot(*(poses[:, :2] - truth[:, :2]).T)


def test_the_loop_search_reaches_as_far_as_the_path_is_uncertain(scene):
    # back at the start corner the estimate is 1.03 m off, twice the fixed search radius
    fixed, err_fixed = drifted_corner_run(scene, loop_search_path_sigmas=0.0)
    assert fixed.counts.loop_attempts == 0 and err_fixed[240] > 1.0  # the fixed radius never sees it again
    grown, err = drifted_corner_run(scene, loop_search_path_sigmas=3.0)  # three std devs of the chain reach it
    assert grown.counts.loops >= 1 and err[240] < 0.02 and err[-1] < 0.1


def test_after_a_closure_a_revisit_searches_the_square_the_closed_loop_leaves(scene):
    """The drifted corner at the default squares: the first search spans the chain's uncertainty since the
    start (12.4 m); once closed, the next searches go through that closure to the keyframes they revisit and
    span about 4 m, where the chain alone would still ask for 12 m. Every search finds the revisit; the first
    few, moving the keyframe farther than ``loop_search_maximum_distance``, wait for the running buffer's
    consent (``_confirmed``) and are counted as inconsistent until it comes."""
    squares = []  # (loops closed before, side of the square searched)
    search = Slam2D._loop_search

    def spy(self, reference, points, prediction, window):
        squares.append((self.counts.loops, window.linear))
        return search(self, reference, points, prediction, window)

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(Slam2D, "_loop_search", spy)
        slam, err = drifted_corner_run(scene)
    assert squares[0] == (0, pytest.approx(12.38, abs=0.01))
    assert len(squares) > 10 and all(side < 5.0 for closed, side in squares if closed)
    c = slam.counts
    assert c.loops + c.loops_inconsistent == len(squares) and c.loops_inconsistent <= 3
    assert err[240] < 0.02 and err[-1] < 0.1


def test_the_route_variance_goes_through_a_closure_when_that_is_shorter():
    """Six keyframes 1 m apart on a line, each sequential edge of translation variance 0.01 per axis, the last
    of yaw variance 1e-4; a closure 0 -> 4 of translation trace 0.001 and yaw variance 1e-4. From keyframe 5:
    to 0 through the closure 0.02 + 0.001 + 1e-4 (the closure's yaw swings keyframe 5, 1 m from its end 4);
    to 2 along the chain, 0.06, shorter than through the closure (0.061 + 1e-4); no closure, no route; of two
    closures between the same keyframes the tighter counts."""
    slam = Slam2D(SlamParams())
    poses = np.array([(float(i), 0.0, 0.0) for i in range(6)])
    assert slam._route_variance(poses, 5) is None
    for i in range(1, 6):
        slam._chain_cov.append(np.diag([0.01, 0.01, 1e-4 if i == 5 else 0.0]))
    slam._loop_edges.append((0, 4, 0.001, 1e-4))
    assert slam._route_variance(poses, 5)[0] == pytest.approx(0.0211, abs=1e-9)
    assert slam._route_variance(poses, 5)[2] == pytest.approx(0.06, abs=1e-9)
    assert slam._route_variance(poses, 5)[4] == pytest.approx(0.02, abs=1e-9)  # the yaw of 4 -> 5 swings nothing
    slam._loop_edges.append((0, 4, 0.5, 0.0))  # a second, looser closure between the same keyframes
    assert slam._route_variance(poses, 5)[0] == pytest.approx(0.0211, abs=1e-9)


def test_an_edge_crossed_either_way_swings_the_new_keyframe_about_its_target():
    """Keyframes at x = 0, 1, 5 m; edge 0 -> 1 of yaw variance 0.01 (and translation 0.001 per axis), edge
    1 -> 2 loose (1 m^2 per axis), a tight closure 0 -> 2. From keyframe 2 to 1 the route goes through the
    closure to 0, then forward over 0 -> 1: its yaw error swings keyframe 2 about keyframe 1, 4 m away
    (0.01 * 16), not about keyframe 0, 5 m away. Then a closure crossed from its old end to its new one: from
    keyframe 4 (at (0, 4)) to 2 (at (3, 0)) through a tight closure 1 -> 4, edge 0 -> 1 backwards (0.002) and
    a closure 0 -> 2 of yaw variance 0.01, which swings keyframe 4 about keyframe 2, 5 m away."""
    slam = Slam2D(SlamParams())
    poses = np.array([(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (5.0, 0.0, 0.0)])
    slam._chain_cov.append(np.diag([0.001, 0.001, 0.01]))
    slam._chain_cov.append(np.diag([1.0, 1.0, 0.0]))
    slam._loop_edges.append((0, 2, 1e-4, 0.0))
    assert slam._route_variance(poses, 2)[1] == pytest.approx(1e-4 + 0.002 + 0.16, abs=1e-9)
    slam = Slam2D(SlamParams())
    poses = np.array([(0.0, 0.0, 0.0), (0.0, 1.0, 0.0), (3.0, 0.0, 0.0), (3.0, 3.0, 0.0), (0.0, 4.0, 0.0)])
    slam._chain_cov.append(np.diag([0.001, 0.001, 0.0]))
    for _ in range(3):
        slam._chain_cov.append(np.diag([1.0, 1.0, 0.0]))  # the rest of the chain loose: the route takes the closures
    slam._loop_edges.append((1, 4, 1e-4, 0.0))
    slam._loop_edges.append((0, 2, 1e-4, 0.01))
    assert slam._route_variance(poses, 4)[2] == pytest.approx(1e-4 + 0.002 + 1e-4 + 0.25, abs=1e-9)


def test_a_loop_beyond_the_search_square_is_found_on_a_coarser_grid(scene):
    """The odometry ends 1.03 m off at the start corner (as above). A loop search square of 1 m
    (loop_search_space_dimension) reaches 0.5 m and never meets the corner again; allowed to grow to 4 m
    with the path's uncertainty (loop_search_maximum_dimension), the square is searched on a grid coarser in
    proportion, then at full resolution around what it found, and the loop closes."""
    square, err_square = drifted_corner_run(
        scene, loop_search_space_dimension=1.0, loop_search_maximum_dimension=1.0, loop_search_global=False
    )
    assert square.counts.loops == 0 and err_square[240] > 1.0
    refined = []  # (coarse pose, full-resolution pose) of each wide search's last step
    match = ScanMatcher.match

    def spy(self, reference, points, prediction, window, min_response):
        found = match(self, reference, points, prediction, window, min_response)
        if (window.linear, window.angular) == WIDE_REFINE and found is not None:
            refined.append((np.asarray(prediction), found.pose))
        return found

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(ScanMatcher, "match", spy)
        grown, err = drifted_corner_run(
            scene, loop_search_space_dimension=1.0, loop_search_maximum_dimension=4.0, loop_search_global=False
        )
    assert grown.counts.loops >= 1 and err[240] < 0.02 and err[-1] < 0.1
    assert len(refined) >= grown.counts.loops  # every closure came through the coarser grid, then full resolution
    # the full-resolution pose lies within a cell of the coarser grid (0.1 m for the 4 m square) of its pose
    assert all(np.hypot(*(fine[:2] - coarse[:2])) < 0.1 for coarse, fine in refined)


def test_a_loop_where_another_place_matches_as_well_is_refused(scene, monkeypatch):
    """The drifted corner closed through the 4 m square (above), but with every search's spread reading 10 m^2
    (another place in the square matching as well, as ScanMatcher.spread measures it): no loop is added,
    each refusal counted as ambiguous."""
    monkeypatch.setattr(ScanMatcher, "spread", lambda *args, **kwargs: 10.0)
    slam, err = drifted_corner_run(scene, loop_search_space_dimension=1.0, loop_search_maximum_dimension=4.0)
    assert slam.counts.loops == 0 and slam.counts.loops_ambiguous >= 1 and err[240] > 1.0


def _scan_alone_ambiguous_run(scene, buffer_spread: float | None, **params) -> tuple[Slam2D, np.ndarray]:
    """The drifted corner at the default squares, every loop search of the new scan's own points reading a spread
    of 10 m^2 (a look-alike place in the square); a search of other points (the running buffer's surfaces) reads
    ``buffer_spread`` m^2, or its spread as measured when None: the SLAM and its position error at every scan."""
    search = Slam2D._loop_search

    def spread(self, reference, points, prediction, window):
        found = search(self, reference, points, prediction, window)
        if found is None:
            return None
        match, measured = found
        alone = points is self.keyframes[-1].points
        if alone or buffer_spread is not None:
            return match, lambda: 10.0 if alone else buffer_spread
        return match, measured

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(Slam2D, "_loop_search", spread)
        slam, err = drifted_corner_run(scene, **params)
    return slam, err


def test_a_loop_the_scan_alone_leaves_ambiguous_is_closed_by_the_running_buffer_s_surfaces(scene):
    """Where the new scan's own loop match has a look-alike in its square, the running buffer's surfaces (a few
    metres of the building) are searched in the same square: their match, at the global search's bar
    (``loop_match_minimum_response_global``) and pinning one place, closes the drifted corner as an unambiguous
    scan would (counted in ``loops_buffer``; the buffer is bent by the odometry's turns here, its closures as
    far off as the scan's own, 0.07 m). Refused, and counted as ambiguous, when the buffer's search spreads
    as well or its match falls short of the bar: the map then keeps the odometry's drift."""
    closed, err = _scan_alone_ambiguous_run(scene, None)
    assert closed.counts.loops >= 1 and closed.counts.loops_buffer == closed.counts.loops
    assert {e.closed_by for e in closed.graph.edges if e.kind == "loop"} == {"buffer"}
    assert {e.closed_by for e in closed.graph.edges if e.kind != "loop"} == {""}
    assert err[240] < 0.02 and err.max() < 0.1 and _loop_errors(closed).max() < 0.1  # the scan's own: 0.07 m
    for refused, err in (
        _scan_alone_ambiguous_run(scene, 10.0),
        _scan_alone_ambiguous_run(scene, None, loop_match_minimum_response_global=1.0),
    ):
        assert refused.counts.loops == 0 and refused.counts.loops_ambiguous >= 1 and err[240] > 1.0


def _look_alike_run(
    scene, offset: tuple[float, float], spread: float | None = None, **params
) -> tuple[Slam2D, np.ndarray, list[bool]]:
    """The drifted corner at the default squares, with every square search's match moved by ``offset`` (m, map
    frame), as if the scan alone had matched a look-alike place there as well as the true one (its search's
    spread ``spread`` m^2 when given): the SLAM, its position error at every scan and what each buffer
    confirmation (``_confirmed``) said."""
    search, confirmed, said = Slam2D._loop_search, Slam2D._confirmed, []

    def moved(self, reference, points, prediction, window):
        found = search(self, reference, points, prediction, window)
        if found is None:
            return None
        match, measured = found
        moved = dataclasses.replace(match, pose=match.pose + np.array([*offset, 0.0]))
        return moved, (measured if spread is None else lambda: spread)

    def spy(self, reference, new, pose):
        said.append(confirmed(self, reference, new, pose))
        return said[-1]

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(Slam2D, "_loop_search", moved)
        patch.setattr(Slam2D, "_confirmed", spy)
        slam, err = drifted_corner_run(scene, **params)
    return slam, err, said


def test_a_closure_that_moves_the_keyframe_far_needs_the_running_buffer_s_consent(scene):
    """A square-search closure moving its keyframe more than ``loop_search_maximum_distance`` (0.5 m here) from
    its estimate is held to the global search's bar: the running buffer's surfaces must match the chain
    (``loop_match_minimum_response_global``) where the scan's match put it. The true revisit of the drifted
    corner (1.03 m off) has it and closes (its first tries, coming into the corner, wait for a buffer less bent
    by the odometry's turns: sequential matches are off here). A look-alike place 1.5 m off the true one is
    refused, each try counted as inconsistent, and the map stays as the odometry left it; with the bar at 0 it is
    taken, and the estimate is pulled well off the truth."""
    true, err_true, said_true = _look_alike_run(scene, (0.0, 0.0))
    assert any(said_true) and true.counts.loops >= 1 and err_true[240] < 0.02
    assert {e.closed_by for e in true.graph.edges if e.kind == "loop"} == {"scan"}
    alike, err, said = _look_alike_run(scene, (0.0, 1.5))
    assert len(said) >= 3 and not any(said)
    assert alike.counts.loops == 0 and alike.counts.loops_inconsistent == len(said) and err[240] > 1.0
    taken, err_taken, _ = _look_alike_run(scene, (0.0, 1.5), loop_match_minimum_response_global=0.0)
    assert taken.counts.loops >= 1 and _loop_errors(taken).max() > 1.0 and err_taken.max() > 1.0


def test_a_closure_half_as_far_with_a_look_alike_in_its_square_needs_the_running_buffer_s_consent_too(scene):
    """With ``loop_search_maximum_distance`` at 3 m, a look-alike place 1.5 m to the side of the drifted corner's
    revisit (1.03 m off) moves the keyframe 1.5-2.3 m. Where the search's square holds no other place as good
    (the spread as measured, a few hundredths of a m^2), it is taken at its first tries without the buffer
    being asked: the closures are within the loop search's reach. Where the square's places that score alike
    spread over 2 m^2 (under ``loop_match_maximum_spread``, 3, but over ``LOOK_ALIKE_SPREAD``, 1 m^2), every try
    that moves the keyframe more than 1.5 m asks the buffer, which refuses (a corridor's scan matching a
    stretch two metres along: MIT's infinite corridor had one); only the last tries, once the look-alike lies
    within 1.5 m, are taken."""
    sharp, _, asked = _look_alike_run(scene, (0.0, 1.5), loop_search_maximum_distance=3.0)
    assert sharp.counts.loops >= 4 and _loop_errors(sharp)[:4].min() > 1.0
    spread, err, said = _look_alike_run(scene, (0.0, 1.5), 2.0, loop_search_maximum_distance=3.0)
    assert len(said) >= 20 and not any(said) and spread.counts.loops_inconsistent == len(said)
    assert spread.counts.loops <= 2 and err[240] > 1.0


def _loop_errors(slam: Slam2D) -> np.ndarray:
    """Per loop edge: how far the target's position it measures, in the source's frame, lies from the true one
    (``rectangle_path``'s poses; the scans of ``run_slam`` are 0.1 s apart)."""
    truth = [gtsam.Pose2(*rectangle_path()[k.stamp // 100_000_000]) for k in slam.keyframes]
    out = []
    for e in slam.graph.edges:
        if e.kind == "loop":
            true = truth[e.source].between(truth[e.target])
            out.append(math.hypot(e.relative[0] - true.x(), e.relative[1] - true.y()))
    return np.array(out)


def test_a_revisit_beyond_the_widest_square_is_found_by_the_global_search(scene):
    """The drifted corner (1.03 m off when back at the start) with the loop search's square held to 1 m: the
    square reaches 0.5 m and never meets the corner again (above). The path's uncertainty there reaches
    past the square, so the keyframes the square cannot reach are searched by their place signature, over a
    square covering the stretch most alike, at the yaws the heading's uncertainty allows: the revisit closes
    and every closure measures its keyframes' true relative pose to a few centimetres."""
    slam, err = drifted_corner_run(scene, loop_search_space_dimension=1.0, loop_search_maximum_dimension=1.0)
    c = slam.counts
    assert c.loops_global >= 1 and c.loops == c.loops_global and c.global_searches >= c.loops_global
    assert {e.closed_by for e in slam.graph.edges if e.kind == "loop"} == {"global"}
    assert err[240] < 0.02 and err[-1] < 0.1
    assert _loop_errors(slam).max() < 0.05


def test_the_global_search_keeps_to_the_yaws_the_heading_allows(scene, monkeypatch):
    """The room looks the same turned a quarter (four boxes, one in each quadrant). Searched at every yaw, the
    global search closes the first pass down the west side onto the south side, a quarter turn off (and the
    map falls apart); kept to the heading's uncertainty along the path (0.9-1.1 rad either way here), it closes
    only true revisits."""
    monkeypatch.setattr(Slam2D, "_global_turn", lambda self, first, new: math.pi)
    every_yaw, err_every = drifted_corner_run(scene, loop_search_space_dimension=1.0, loop_search_maximum_dimension=1.0)
    assert every_yaw.counts.loops_global >= 1 and _loop_errors(every_yaw).max() > 4.0
    assert err_every.max() > 3.0
    monkeypatch.undo()
    kept, err = drifted_corner_run(scene, loop_search_space_dimension=1.0, loop_search_maximum_dimension=1.0)
    turns = [kept._global_turn(0, k) for k in (36, 47)]
    assert 0.85 < turns[0] < turns[1] < 1.1
    assert _loop_errors(kept).max() < 0.05 and err.max() < 0.15


def test_the_uncertainty_s_scale_is_the_largest_shift_the_square_search_s_closures_made():
    """Before three closures, the path's uncertainty as it stands (1); then the largest of the closures' shifts in
    its standard deviations, never above 1."""
    slam = Slam2D(SlamParams())
    slam._drift_ratios += [0.1, 0.4]
    assert slam._drift_scale() == 1.0
    slam._drift_ratios.append(0.3)
    assert slam._drift_scale() == pytest.approx(0.4)
    slam._drift_ratios.append(1.7)
    assert slam._drift_scale() == 1.0


def test_a_global_match_farther_than_the_measured_uncertainty_is_refused(scene, monkeypatch):
    """The drifted corner as above. With the closures so far having moved their keyframes by at most 0.05 of the
    path's standard deviations, the global search's reach (0.5 m + 0.15 sigma) no longer gets to the corner 1 m
    off: nothing is searched. With the reach as it stands but every match held to none of it (each
    search's shift limit 0), each match found is refused, counted as inconsistent."""
    with monkeypatch.context() as patch:
        patch.setattr(Slam2D, "_drift_scale", lambda self: 0.05)
        slam, err = drifted_corner_run(scene, loop_search_space_dimension=1.0, loop_search_maximum_dimension=1.0)
    assert slam.counts.global_searches == 0 and slam.counts.loops == 0 and err[240] > 1.0
    closure = Slam2D._try_closure

    def no_reach(self, new, chain, anchor, prediction, window, least, points=None, reach=None):
        reach = None if reach is None else np.zeros_like(reach)
        return closure(self, new, chain, anchor, prediction, window, least, points, reach)

    monkeypatch.setattr(Slam2D, "_try_closure", no_reach)
    slam, err = drifted_corner_run(scene, loop_search_space_dimension=1.0, loop_search_maximum_dimension=1.0)
    c = slam.counts
    assert c.global_searches >= 1 and c.loops == 0 and c.loops_inconsistent >= 1 and err[240] > 1.0


def test_sequential_matching_keeps_the_drifting_path_and_the_map_right(scene):
    truth = rectangle_path(0.1)[:150]
    odom = drifting_odometry(truth, 0.02)
    slam = run_slam(scene, truth, odom, SlamParams(do_loop_closing=False))
    assert slam.counts.odometry_only == 0
    _, poses = slam.trajectory()
    odom_err = np.hypot(*(odom[:, :2] - truth[:, :2]).T)
    err = np.hypot(*(poses[:, :2] - truth[:, :2]).T)
    assert odom_err.max() > 0.15 and err.max() < 0.03
    # the map: the south wall (y = -5) is occupied where the laser saw it, the room inside free
    m = slam.grid().to_map()
    i = int((-4.975 - m.origin[1]) / m.resolution)
    j = int((0.0 - m.origin[0]) / m.resolution)
    assert m.data[i, j] == 100 and m.data[i + 20, j] == 0


def test_the_same_scans_give_the_same_map_bytes(scene):
    truth = rectangle_path(0.1)[:80]
    odom = drifting_odometry(truth, 0.02)
    a = run_slam(scene, truth, odom, SlamParams()).grid()
    b = run_slam(scene, truth, odom, SlamParams()).grid()
    assert a.logodds.tobytes() == b.logodds.tobytes() and np.array_equal(a.origin, b.origin)


def test_bad_parameters_are_named():
    with pytest.raises(ValueError, match="correlation_search_space_resolution"):
        SlamParams(correlation_search_space_resolution=0.0)
    with pytest.raises(ValueError, match="loop_sigmas"):
        SlamParams(loop_sigmas=(0.1, 0.1))  # type: ignore[arg-type]
    for name in ("scan_buffer_maximum_scan_distance", "loop_search_maximum_distance"):
        for bad in (-1.0, math.nan):
            with pytest.raises(ValueError, match=name):
                SlamParams(**{name: bad})
    with pytest.raises(ValueError, match=r"loop_search_maximum_dimension \(4.0\) is below loop_search_space_dimension"):
        SlamParams(loop_search_maximum_dimension=4.0)
    with pytest.raises(ValueError, match=r"loop_search_space_dimension \(100.0 m\) spans 4000 cells"):
        SlamParams(loop_search_space_dimension=100.0, loop_search_maximum_dimension=100.0)
    with pytest.raises(ValueError, match="spans 1000 cells .* set a coarser correlation_search_space_resolution"):
        SlamParams(correlation_search_space_dimension=25.0)
    with pytest.raises(ValueError, match="loop_match_minimum_response_coarse"):
        SlamParams(loop_match_minimum_response_coarse=1.5)
    with pytest.raises(ValueError, match="odom_frame and base_frame are both 'odom'"):
        SlamParams(base_frame="odom")
    with pytest.raises(ValueError, match="odometry pose not finite"):
        Slam2D(SlamParams()).add_scan(0, (0.0, math.nan, 0.0), scan_of(np.full(N_BEAMS, 2.0)))


@pytest.mark.parametrize(
    ("values", "message"),
    [
        # values that pass as numbers but would make a search's or a grid's arrays absurd (each once a traceback)
        ({"resolution": 1e308}, r"resolution \(1e\+308 m\) is a map cell: between 0.005 and 5.0 m"),
        ({"resolution": 1e-4}, "is a map cell"),
        (
            {
                "correlation_search_space_resolution": 1e-6,
                "correlation_search_space_dimension": 1e-4,
                "loop_search_space_dimension": 1e-4,
                "loop_search_maximum_dimension": 1e-4,
            },
            r"correlation_search_space_resolution \(1e-06 m\) is below 0.005 m",
        ),
        ({"correlation_search_space_resolution": 1e300}, "less than one cell of correlation_search_space_resolution"),
        ({"correlation_search_space_smear_deviation": 1e308}, "make a lookup grid of inf cells a side"),
        (
            {"max_laser_range": 200.0, "correlation_search_space_resolution": 0.01},
            r"lookup grid of 4.01e\+04 cells a side",
        ),
        ({"coarse_angle_resolution": 1e-9}, r"makes 6.98e\+08 yaws a search: at most 3601"),
        ({"coarse_search_angle_offset": 1e308}, "more than half a turn either way"),
        ({"loop_search_maximum_distance": 1e6}, "reaches past the widest loop square"),
        ({"odometry_sigmas": (1e-300, 1e-300, 1e-300)}, "odometry_sigmas .* between 0.0001 and 1000.0"),
        ({"match_sigmas": (1e300, 0.1, 0.1)}, "match_sigmas"),
        ({"loop_sigmas": (0.05, 0.05, 1e-300)}, "loop_sigmas"),
    ],
)
def test_absurd_extents_are_refused_with_their_keys(values, message):
    with pytest.raises(ValueError, match=message):
        SlamParams(**values)
    # the limits themselves are values a run takes
    SlamParams(loop_search_maximum_dimension=4.0, loop_search_space_dimension=4.0, loop_search_maximum_distance=2.0)
    SlamParams(resolution=5.0, correlation_search_space_resolution=0.01)  # slam_toolbox's own
    SlamParams(resolution=0.005, correlation_search_space_resolution=0.005, loop_search_space_dimension=4.0)
    SlamParams(loop_search_maximum_distance=10.0, odometry_sigmas=(1e-4, 1e-4, 1e3))


def test_the_map_is_drawn_to_the_laser_range_and_a_keyframe_no_grid_can_hold_is_left_out(scene):
    from navlog.replay.mapping.occupancy import OccupancyParams

    poses = [(-2.0 + 0.6 * k, -3.0, 0.0) for k in range(5)]
    scans = [cast(scene, p) for p in poses]
    scans[3][0] = 25.0  # a reading past max_laser_range (20 m): clears up to 20 m, marks nothing
    slam = Slam2D(SlamParams(do_loop_closing=False))
    for k, (p, r) in enumerate(zip(poses, scans, strict=True)):
        slam.add_scan(k * 1_000_000_000, p, LaserScan2D(ANGLES, r, 0.05, 100.0, MOUNT))
    grid = slam.grid()
    assert grid.stats.scans == 5 and grid.stats.clipped == 1 and slam.counts.off_map == set()

    # beam 0 points along -x (the angles start at -pi) from x = -0.2: cleared to x = -20.2, nothing marked
    # at -25.2 (which lies outside the grid or unseen)
    def cell(x: float) -> tuple[int, int]:
        ix, iy = np.floor((np.array([x, -3.0]) - grid.origin) / grid.res).astype(int)
        return iy, ix

    assert grid.seen[cell(-20.0)] and grid.logodds[cell(-20.0)] < 0
    assert cell(-25.2)[1] < 0 or not grid.seen[cell(-25.2)]
    # with the map's own range unbounded, a 2,000 km reading is more than any grid: that keyframe is left
    # out (counted once), the others are drawn once each, however often the map is asked for
    scans[3][0] = 2e6
    slam = Slam2D(SlamParams(do_loop_closing=False), OccupancyParams(resolution=0.05, max_laser_range=1e7))
    for k, (p, r) in enumerate(zip(poses, scans, strict=True)):
        slam.add_scan(k * 1_000_000_000, p, LaserScan2D(ANGLES, r, 0.05, 1e7, MOUNT))
        slam.grid(final=False)
    for final in (False, True, True):
        grid = slam.grid(final)
        assert slam.counts.off_map == {3} and grid.stats.scans == 4


def test_scans_without_a_valid_reading_are_counted_not_placed(scene):
    slam = Slam2D(SlamParams())
    blind = scan_of(np.full(N_BEAMS, np.inf))
    assert slam.add_scan(0, (0.0, 0.0, 0.0), blind) is None  # nothing to start the map from
    pose = slam.add_scan(100_000_000, (0.0, 0.0, 0.0), scan_of(cast(scene, (0.0, 0.0, 0.0))))
    assert pose is not None and np.allclose(pose, 0.0)
    slam.add_scan(200_000_000, (0.6, 0.0, 0.0), blind)  # travelled, but nothing to match: odometry
    assert slam.counts.empty_scans == 2 and slam.counts.keyframes == 1
    stamps, poses = slam.trajectory()
    assert stamps == [100_000_000, 200_000_000] and np.allclose(poses[1], (0.6, 0.0, 0.0))
    # every blind scan is counted, whether or not it was due for a match (standing still, 0.1 s apart)
    for on in (True, False):
        slam = Slam2D(SlamParams(match_between_keyframes=on))
        slam.add_scan(0, (0.0, 0.0, 0.0), scan_of(cast(scene, (0.0, 0.0, 0.0))))
        for k in range(1, 11):
            slam.add_scan(k * 100_000_000, (0.0, 0.0, 0.0), blind)
        assert slam.counts.empty_scans == 10


def test_a_scan_between_keyframes_matches_a_keyframe_whose_laser_sits_far_from_the_base():
    # the laser sits 15 m ahead of the base and sees a wall across its path 10 m further on (25 m from the
    # base, beyond max_laser_range + the window); the next scan, due for a match, reads the odometry 5 cm
    # long: the lookup grid reaches the wall and the match takes the 5 cm back
    ahead = np.eye(4)
    ahead[0, 3] = 15.0

    def wall(base_x: float) -> LaserScan2D:
        r = np.full(N_BEAMS, np.inf)
        front = np.abs(ANGLES) < 0.3
        r[front] = (25.0 - 15.0 - base_x) / np.cos(ANGLES[front])
        return LaserScan2D(ANGLES, r, 0.05, 100.0, ahead)

    slam = Slam2D(SlamParams())
    slam.add_scan(0, (0.0, 0.0, 0.0), wall(0.0))
    assert slam.counts.keyframes == 1
    pose = slam.add_scan(600_000_000, (0.15, 0.0, 0.0), wall(0.1))
    grid = slam._between[1]
    assert grid.core_origin[0] + grid.likelihood.shape[1] * grid.res > 25.0  # the wall is on the grid
    assert slam.counts.matched_between == 1
    assert abs(pose[0] - 0.1) < 0.01 and abs(pose[1]) < 0.05 and abs(pose[2]) < 0.01


def corridor_scan(pose) -> LaserScan2D:
    """A scan in an endless featureless corridor between the walls y = -1 and y = 1 (no end in range)."""
    x, y, yaw = pose
    s = np.sin(ANGLES + yaw)
    with np.errstate(divide="ignore"):
        r = np.where(s > 0, (1.0 - y) / s, np.where(s < 0, (-1.0 - y) / s, np.inf))
    r[(r > RANGE_MAX) | (r <= 0)] = np.inf
    return scan_of(r)


def corridor_run(params: SlamParams) -> tuple[Slam2D, np.ndarray, np.ndarray]:
    """Down the corridor 16 m at y = 0.2, a turn on the spot, and back: the odometry reads every step
    8 % long and turns 2 % too much (it ends 1.3 m off along the corridor)."""
    out = [(0.1 * i, 0.2, 0.0) for i in range(160)]
    out += [(16.0, 0.2, math.pi * k / 20) for k in range(1, 21)]
    out += [(16.0 - 0.1 * i, 0.2, math.pi) for i in range(1, 150)]
    truth = np.array(out)
    odom = drifting_odometry(truth, 0.02)
    odom[:, 0] = odom[0, 0] + (odom[:, 0] - odom[0, 0]) * 1.08
    slam = Slam2D(params)
    for i, o in enumerate(odom):
        slam.add_scan(i * 100_000_000, o, corridor_scan(truth[i]))
    return slam, truth, odom


def test_a_corridor_match_falls_back_to_odometry_along_its_axis():
    slam, truth, odom = corridor_run(SlamParams(do_loop_closing=False))
    _, poses = slam.trajectory()
    out = slice(0, 160)  # the way down: odometry is 8 % long along x, the walls say nothing about x
    along = np.abs(poses[out, 0] - truth[out, 0])
    assert along[-1] <= np.abs(odom[159, 0] - truth[159, 0]) + 0.02  # never worse than the odometry
    assert np.allclose(poses[out, 0], odom[out, 0], atol=0.05)
    # across the corridor and in yaw the walls pin the pose: the odometry's turn error is gone
    assert np.abs(poses[:, 1] - truth[:, 1]).max() < 0.03
    assert np.abs(np.remainder(poses[:, 2] - truth[:, 2] + np.pi, 2 * np.pi) - np.pi).max() < 0.01


def test_the_matches_measure_the_odometry_s_scale_in_length_and_in_turn(scene):
    """Two laps of a 2 m circle driven in the room (0.1 m steps, heading along it) on odometry whose steps are
    8 % long and whose turns are 5 % too large (every match pins the pose there): the calibration finds
    both, 1 / 1.08 and 1 / 1.05, within 1 %."""
    a = np.arange(252) * 0.05
    truth = np.column_stack([2.0 * np.cos(a), 2.0 * np.sin(a), a + math.pi / 2])
    odom = degraded_odometry(degraded_odometry(truth, "length", 0.08), "turn", 0.05)
    slam = run_slam(scene, truth, odom, SlamParams(do_loop_closing=False))
    scaled = slam._calibrated(gtsam.Pose2(1.0, 0.0, 1.0))
    assert scaled.x() == pytest.approx(1 / 1.08, rel=0.01) and scaled.theta() == pytest.approx(1 / 1.05, rel=0.01)
    assert len(slam._lengths) >= CALIBRATION_WINDOW // 2 and len(slam._turns) >= CALIBRATION_WINDOW // 2


def test_calibration_waits_for_its_samples_and_keeps_to_its_bounds():
    slam = Slam2D(SlamParams())
    step = gtsam.Pose2(1.0, 0.0, 0.5)
    for _ in range(CALIBRATION_WINDOW // 2 - 1):
        slam._calibration_sample(gtsam.Pose2(0.5, 0.0, 0.6), step)  # half the length, a fifth more turn
    assert slam._calibrated(step).equals(step, 1e-12)  # not enough samples yet: the odometry as it is
    slam._calibration_sample(gtsam.Pose2(0.5, 0.0, 0.6), step)
    scaled = slam._calibrated(step)
    assert scaled.x() == pytest.approx(0.8) and scaled.theta() == pytest.approx(0.6)  # 0.5 held to the bound 0.8
    slam._calibration_sample(gtsam.Pose2(0.02, 0.0, -0.15), gtsam.Pose2(0.05, 0.0, -0.15))  # too short, turn kept
    assert len(slam._lengths) == CALIBRATION_WINDOW // 2 and len(slam._turns) == CALIBRATION_WINDOW // 2 + 1
    slam._calibration_sample(gtsam.Pose2(-0.4, 0.0, 0.2), gtsam.Pose2(-0.5, 0.0, 0.2))  # driven backwards: no sample
    assert len(slam._lengths) == CALIBRATION_WINDOW // 2 and len(slam._turns) == CALIBRATION_WINDOW // 2 + 1
    off = Slam2D(SlamParams(calibrate_odometry=False))
    off._lengths, off._turns, off._scales = slam._lengths, slam._turns, slam._scales  # scales of 0.8 and 1.2
    assert off._calibrated(step).equals(step, 1e-12)


def _toward(pose, bearing_deg: float, distance: float) -> list[float]:
    a = pose[2] + math.radians(bearing_deg)
    return [pose[0] + distance * math.cos(a), pose[1] + distance * math.sin(a)]


def test_a_scan_has_in_sight_what_its_beams_reached():
    # a 180-degree fan at 1 degree, every reading 2 m but no return (+inf) at 10-20 degrees and none at all at
    # 0 degrees; its robot at (1, 1) facing +y; a margin of 0.2 m
    angles = np.radians(np.arange(-90.0, 90.5, 1.0))
    ranges = np.full(len(angles), 2.0)
    ranges[100:111] = np.inf
    ranges[90] = np.nan
    scan = LaserScan2D(angles, ranges, 0.1, 5.0, np.eye(4))
    pose = (1.0, 1.0, math.pi / 2)
    points = [
        (0, 1.5),
        (45, 2.15),
        (45, 2.3),
        (180, 1.0),
        (15, 4.5),
        (15, 5.3),
        (75, 1.0),
        (85, 1.0),
        (-75, 1),
        (-85, 1),
    ]
    xy = np.array([_toward(pose, b, d) for b, d in points])
    # ahead on an invalid beam: its neighbours reached 2 m; within / beyond the margin past 2 m; behind the fan;
    # no return: free to range_max (5 m) and the margin; 1 m away, 15 degrees (0.26 m) inside either edge of the
    # fan and 5 degrees (0.09 m) inside it
    expected = [True, True, False, False, True, False, True, False, True, False]
    assert scan.sees(pose, xy, 0.2, 20.0).tolist() == expected
    # the same fan listed the other way round (a negative angle_increment) has the same in sight
    reverse = LaserScan2D(angles[::-1], ranges[::-1], 0.1, 5.0, np.eye(4))
    assert reverse.sees(pose, xy, 0.2, 20.0).tolist() == expected
    # no return is free only to the map's range; an invalid reading has nothing in sight, not even near the laser
    assert scan.sees(pose, xy[4:6], 0.2, 3.0).tolist() == [False, False]
    blind = LaserScan2D(angles, np.full(len(angles), np.nan), 0.1, 5.0, np.eye(4))
    assert not blind.sees(pose, np.array([_toward(pose, 0, 0.5)]), 0.2, 20.0).any()
    # a laser 0.3 m ahead of the base facing backwards sees behind the robot, not ahead; its 2.5 m reach
    # (2 m and the margin) is measured from the laser
    mount = np.eye(4)
    mount[0, 3], mount[:2, :2] = 0.3, [[-1.0, 0.0], [0.0, -1.0]]
    back = LaserScan2D(angles, np.full(len(angles), 2.0), 0.1, 5.0, mount)
    xy = np.array([_toward(pose, 180, 1.0), _toward(pose, 0, 1.0), _toward(pose, 180, 2.1), _toward(pose, 180, 2.35)])
    assert back.sees(pose, xy, 0.5, 20.0).tolist() == [True, False, True, False]
    # a laser turned a quarter to the left reading 1 m on its right half and 3 m on its left: its right half
    # looks ahead of the robot, its left half behind it; one upside down (rolled half a turn) sees its right
    # half on the robot's left
    mount = np.eye(4)
    mount[:2, :2] = [[0.0, -1.0], [1.0, 0.0]]
    halves = np.where(angles < 0, 1.0, 3.0)
    left = LaserScan2D(angles, halves, 0.1, 5.0, mount)
    origin = (0.0, 0.0, 0.0)
    xy = np.array(
        [_toward(origin, 30, 0.9), _toward(origin, 30, 1.5), _toward(origin, 170, 2.5), _toward(origin, -45, 1)]
    )
    assert left.sees(origin, xy, 0.2, 20.0).tolist() == [True, False, True, False]
    rolled = LaserScan2D(angles, halves, 0.1, 5.0, np.diag([1.0, -1.0, -1.0, 1.0]))
    xy = np.array([_toward(origin, 45, 0.9), _toward(origin, 45, 1.5), _toward(origin, -45, 2.5)])
    assert rolled.sees(origin, xy, 0.2, 20.0).tolist() == [True, False, True]
    # a full circle from 0 to 359 degrees, its first two readings invalid: just below 0 is its first beam, whose
    # neighbours are the second and the last
    ring = np.full(360, 2.0)
    ring[:2] = np.nan
    full = LaserScan2D(np.radians(np.arange(0.0, 360.0, 1.0)), ring, 0.1, 5.0, np.eye(4))
    xy = np.array([_toward(origin, -0.4, 1.0), _toward(origin, 359.8, 2.5), _toward(origin, 200, 3.1)])
    assert full.sees(origin, xy, 1.0, 20.0).tolist() == [True, True, False]
    # a fan of one beam, or of beams all at one angle, has nothing in sight
    assert not LaserScan2D(np.zeros(3), np.ones(3), 0.1, 5.0, np.eye(4)).sees(origin, xy, 1.0, 20.0).any()
    # where each looks: ahead, behind the robot, to its left, all round
    assert np.allclose(scan.facing(), [1.0, 0.0]) and np.allclose(back.facing(), [-1.0, 0.0])
    assert np.allclose(left.facing(), [0.0, 1.0]) and full.facing() is None


def test_a_scan_is_matched_on_its_points_in_sight_only_when_many_are_out_of_it():
    # one keyframe at the origin, its laser reading 2 m over the 180 degrees ahead: of ten points, those ahead
    # within reach are in its sight, those behind are not
    angles = np.radians(np.arange(-90.0, 90.5, 1.0))
    slam = Slam2D(SlamParams(do_loop_closing=False))
    slam.add_scan(0, (0.0, 0.0, 0.0), LaserScan2D(angles, np.full(len(angles), 2.0), 0.1, 5.0, np.eye(4)))
    origin = np.zeros(3)
    ahead, behind = np.array([[1.0, 0.1 * k] for k in range(10)]), np.array([[-1.0, 0.1 * k] for k in range(10)])
    centre = gtsam.Pose2()
    # a tenth out of sight: all of them; half: the half in sight; none in sight: all of them
    one_out = np.concatenate([ahead[:9], behind[:1]])
    assert slam._in_sight(one_out, origin, centre) is one_out
    half = np.concatenate([ahead[:5], behind[:5]])
    assert np.array_equal(slam._in_sight(half, origin, centre), ahead[:5])
    assert slam._in_sight(behind, origin, centre) is behind


def driven(scene, path: np.ndarray, in_sight: bool, laser_yaw: float = 0.0) -> tuple[float, float]:
    """A robot driving ``path`` (backwards, where it heads against its steps) with a 180-degree laser (the front
    half of the 720 beams) turned ``laser_yaw`` from its heading, exact odometry: (the keyframes' matched travel
    over the true, the largest position error)."""
    rng = np.random.default_rng(3)
    front = slice(N_BEAMS // 4, 3 * N_BEAMS // 4)
    mount = np.eye(4)
    mount[:2, :2] = [[math.cos(laser_yaw), -math.sin(laser_yaw)], [math.sin(laser_yaw), math.cos(laser_yaw)]]
    slam = Slam2D(SlamParams(do_loop_closing=False, match_in_sight=in_sight))
    for i, t in enumerate(path):
        ranges = cast(scene, t + np.array([0.0, 0.0, laser_yaw]), rng)[front]
        slam.add_scan(i * 100_000_000, t, LaserScan2D(ANGLES[front], ranges, 0.05, RANGE_MAX, mount))
    _, poses = slam.trajectory()
    placed = np.array([slam.graph.pose(k.index)[:2] for k in slam.keyframes])
    true = path[[k.stamp // 100_000_000 for k in slam.keyframes], :2]
    travel = np.linalg.norm(np.diff(placed, axis=0), axis=1).sum() / np.linalg.norm(np.diff(true, axis=0), axis=1).sum()
    return float(travel), float(np.hypot(*(poses[:, :2] - path[:, :2]).T).max())


def test_driving_away_from_where_the_laser_looks_is_matched_on_what_the_buffer_saw(scene):
    # driving back, a scan sees beside the robot what the keyframes ahead of it never had in sight: matched with
    # those points it is pulled forward, onto the surfaces they saw (each step measured short); matched again on
    # the points in sight it is not
    along_x = np.array([(3.5 - 0.1 * i, -1.0, 0.0) for i in range(71)])
    along_y = np.array([(1.0, 3.5 - 0.1 * i, math.pi / 2) for i in range(71)])
    for path in (along_x, along_y):
        travel, error = driven(scene, path, in_sight=True)
        assert abs(travel - 1.0) < 0.01 and error < 0.04
        short, worse = driven(scene, path, in_sight=False)
        assert short < travel and error < worse - 0.015
    # a laser facing backwards on a robot driving on is the same case; a forward-facing one driving on is not
    ahead = along_x[::-1]
    (travel, error), (short, worse) = driven(scene, ahead, True, math.pi), driven(scene, ahead, False, math.pi)
    assert short < travel < 1.0 and error < worse - 0.01
    assert driven(scene, ahead, True) == driven(scene, ahead, False)


def test_an_ambiguous_corridor_loop_is_refused():
    # on the way back every old keyframe of the corridor matches the scan equally well at any x: a
    # closure would pin the along-axis drift to whatever the search returned
    slam, truth, odom = corridor_run(SlamParams())
    assert slam.counts.loop_attempts >= 1
    assert slam.counts.loops == 0 and slam.counts.loops_ambiguous >= 1
    assert [e.kind for e in slam.graph.edges].count("loop") == 0


def test_a_loop_the_graph_disagrees_with_is_measured_and_taken_back():
    from navlog.replay.mapping.slam2d import PoseGraph

    graph = PoseGraph()
    for i in range(6):  # a straight chain, 1 m steps, well known (2 cm, 0.01 rad)
        graph.add_node((float(i), 0.0, 0.0))
        if i:
            graph.add_edge(i - 1, i, (1.0, 0.0, 0.0), (0.02, 0.02, 0.01), "match")
    graph.add_edge(0, 5, (5.03, 0.0, 0.0), (0.05, 0.05, 0.02), "loop", kernel="huber")  # agrees within 3 cm
    graph.optimize()
    assert graph.edge_chi2() < 1.0
    graph.remove_last_edge()
    graph.add_edge(0, 5, (4.0, 1.0, 0.0), (0.05, 0.05, 0.02), "loop", kernel="huber")  # 1.4 m off: false
    graph.optimize()
    assert graph.edge_chi2() > 16.3  # SlamParams.loop_match_maximum_chi2
    graph.remove_last_edge()
    assert [e.kind for e in graph.edges] == ["match"] * 5
    assert np.allclose(graph.pose(5), (5.0, 0.0, 0.0), atol=1e-6)  # back where the chain alone puts it
    graph.optimize()
    assert np.allclose(graph.pose(5), (5.0, 0.0, 0.0), atol=1e-6)


class _GraphAndBatch:
    """A PoseGraph and, beside it, the same prior, nodes and edges as a gtsam batch problem (the oracle)."""

    def __init__(self) -> None:
        import gtsam

        from navlog.replay.mapping.slam2d import PoseGraph

        self.graph = PoseGraph()
        self.batch = gtsam.NonlinearFactorGraph()
        self.batch.add(gtsam.PriorFactorPose2(0, gtsam.Pose2(), gtsam.noiseModel.Diagonal.Sigmas(np.full(3, 1e-6))))
        self.start = gtsam.Values()

    def add_node(self, pose) -> None:
        import gtsam

        self.start.insert(len(self.graph), gtsam.Pose2(*pose))
        self.graph.add_node(pose)

    def add_edge(self, source: int, target: int, relative, noise, kind: str, kernel: str = "none") -> None:
        import gtsam

        self.graph.add_edge(source, target, relative, noise, kind, kernel=kernel)  # type: ignore[arg-type]
        arr = np.asarray(noise, dtype=np.float64)
        model: gtsam.noiseModel.Base = (
            gtsam.noiseModel.Gaussian.Covariance(arr) if arr.ndim == 2 else gtsam.noiseModel.Diagonal.Sigmas(arr)
        )
        if kernel == "huber":
            model = gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Huber.Create(1.345), model)
        self.batch.add(gtsam.BetweenFactorPose2(source, target, gtsam.Pose2(*relative), model))

    def batch_optimum(self, params=None):
        """gtsam's batch Levenberg-Marquardt on the same problem, from the poses the nodes were added at."""
        import gtsam

        args = (self.batch, self.start) if params is None else (self.batch, self.start, params)
        return gtsam.LevenbergMarquardtOptimizer(*args).optimize()


def test_the_incremental_optimisation_finds_the_batch_optimum():
    """A square driven three times with odometry that turns 3 % too much, closed at each corner after the
    first lap (Huber loop edges), optimised after each closure as the SLAM does: iSAM2's poses are those
    of gtsam's batch Levenberg-Marquardt on the same graph, run to convergence, within 0.1 mm."""
    import gtsam

    truth = [(0.0, 0.0, 0.0)]
    for _ in range(3 * 4):
        for step in range(10):
            x, y, yaw = truth[-1]
            turn = math.pi / 2 if step == 9 else 0.0
            truth.append((x + 0.5 * math.cos(yaw), y + 0.5 * math.sin(yaw), yaw + turn))
    both = _GraphAndBatch()
    graph = both.graph
    estimate = gtsam.Pose2()
    both.add_node((0.0, 0.0, 0.0))
    sigmas = np.array([0.02, 0.02, 0.01])
    loop_sigmas = np.array([0.05, 0.05, 0.02])
    for i in range(1, len(truth)):
        step = gtsam.Pose2(*truth[i - 1]).between(gtsam.Pose2(*truth[i]))
        odom = gtsam.Pose2(step.x(), step.y(), step.theta() * 1.03)
        estimate = estimate.compose(odom)
        both.add_node((estimate.x(), estimate.y(), estimate.theta()))
        both.add_edge(i - 1, i, (odom.x(), odom.y(), odom.theta()), sigmas, "match")
        if i >= 40 and i % 10 == 0:  # a corner seen a lap before
            rel = gtsam.Pose2(*truth[i - 40]).between(gtsam.Pose2(*truth[i]))
            both.add_edge(i - 40, i, (rel.x(), rel.y(), rel.theta()), loop_sigmas, "loop", kernel="huber")
            graph.optimize()
    tight = gtsam.LevenbergMarquardtParams()
    tight.setRelativeErrorTol(1e-10)
    tight.setAbsoluteErrorTol(1e-12)
    lm = both.batch_optimum(tight)
    want = np.array([[lm.atPose2(i).x(), lm.atPose2(i).y()] for i in range(len(truth))])
    assert np.abs(graph.poses()[:, :2] - want).max() < 1e-4
    # the loops hold the square: within 10 cm where the odometry alone ends metres off
    assert np.abs(graph.poses()[:, :2] - np.array(truth)[:, :2]).max() < 0.1
    assert np.hypot(estimate.x() - truth[-1][0], estimate.y() - truth[-1][1]) > 1.0
    assert graph.optimizations == 9


def _circle_laps(laps: int, n: int = 200) -> _GraphAndBatch:
    """A 10 m circle of ``n`` nodes driven ``laps`` times with odometry that turns 2 % too little, a closure
    with the lap before every 10 nodes after the first lap, optimised after each as the SLAM does."""
    import gtsam

    step = gtsam.Pose2(2 * 10.0 * math.sin(math.pi / n), 0.0, 2 * math.pi / n)  # a chord and its turn
    odom = gtsam.Pose2(step.x(), step.y(), step.theta() * 0.98)
    both = _GraphAndBatch()
    estimate = gtsam.Pose2()
    both.add_node((0.0, 0.0, 0.0))
    for i in range(1, laps * n + 1):
        estimate = estimate.compose(odom)
        both.add_node((estimate.x(), estimate.y(), estimate.theta()))
        both.add_edge(i - 1, i, (odom.x(), odom.y(), odom.theta()), (0.02, 0.02, 0.01), "match")
        if i >= n and i % 10 == 0:  # the same place a lap before
            before = both.graph.poses().copy()
            both.add_edge(i - n, i, (0.0, 0.0, 0.0), (0.05, 0.05, 0.02), "loop", kernel="huber")
            both.graph.optimize()
            if i == n:  # the first closure swings the whole lap by metres
                assert np.hypot(*(both.graph.poses()[:, :2] - before[:, :2]).T).max() > 1.0
    return both


def test_closures_on_an_optimised_graph_reach_the_batch_optimum_with_the_partial_check(monkeypatch):
    """Four laps of a circle closed every 10 nodes after the first (61 closures on a graph already optimised,
    where iSAM2's partial relinearisation check leaves variables below an unchanged one as they are): the
    poses are those of gtsam's batch Levenberg-Marquardt on the same graph within 0.1 mm; a full check
    reaches the same optimum by another path (not the same bits: the partial check ran)."""
    import gtsam

    from navlog.replay.mapping.slam2d import pose_graph

    tight = gtsam.LevenbergMarquardtParams()
    tight.setRelativeErrorTol(1e-10)
    tight.setAbsoluteErrorTol(1e-12)
    partial = _circle_laps(4)
    want = np.asarray(gtsam.utilities.extractPose2(partial.batch_optimum(tight))).reshape(-1, 3)
    assert np.abs(partial.graph.poses()[:, :2] - want[:, :2]).max() < 1e-4

    made = pose_graph._isam

    def full_check(factorization: str):
        isam = made(factorization)
        params = isam.params()
        params.enablePartialRelinearizationCheck = False
        return gtsam.ISAM2(params)

    monkeypatch.setattr(pose_graph, "_isam", full_check)
    full = _circle_laps(4)
    assert np.abs(full.graph.poses()[:, :2] - want[:, :2]).max() < 1e-4
    assert not np.array_equal(full.graph.poses(), partial.graph.poses())


def test_a_graph_cholesky_finds_indeterminate_is_solved_by_qr():
    """A chain whose edge 2 -> 3 pins no yaw (a match in a round room: yaw sigma ~450 rad) and a loop
    10 -> 29 that does not span it: iSAM2's Cholesky finds the system indeterminate; the graph moves
    to QR and ends where gtsam's batch Levenberg-Marquardt puts it."""
    import gtsam

    free_yaw = 0.5 * 0.02**2 * np.linalg.inv(np.diag([1e4, 1e4, 0.0]) + 1e-9 * np.eye(3))
    free_yaw += np.diag(np.square([0.01, 0.01, 0.005]))
    usual = np.diag(np.square([0.02, 0.02, 0.01]))
    both = _GraphAndBatch()
    graph = both.graph
    for i in range(30):
        both.add_node((float(i), 0.0, 0.0))
        if i:
            both.add_edge(i - 1, i, (1.0, 0.0, 0.0), free_yaw if i == 3 else usual, "match")
    both.add_edge(10, 29, (18.8, 0.1, 0.02), (0.05, 0.05, 0.02), "loop", kernel="huber")
    graph.optimize()
    assert graph._qr
    lm = both.batch_optimum()
    # the free yaw turns the chain after node 2 as it likes; what the graph decides is 29 seen from 10
    got = gtsam.Pose2(*graph.pose(10)).between(gtsam.Pose2(*graph.pose(29)))
    want = lm.atPose2(10).between(lm.atPose2(29))
    assert np.allclose([got.x(), got.y(), got.theta()], [want.x(), want.y(), want.theta()], atol=1e-4)
    # it goes on on QR: another closure, one taken back
    graph.add_node((30.0, 0.0, 0.0))
    graph.add_edge(29, 30, (1.0, 0.0, 0.0), usual, "match")
    graph.add_edge(12, 30, (4.0, 1.0, 0.0), (0.05, 0.05, 0.02), "loop", kernel="huber")  # 18 m short: false
    graph.optimize()
    graph.remove_last_edge()
    assert [e.kind for e in graph.edges].count("loop") == 1 and graph.poses().shape == (31, 3)
    step = gtsam.Pose2(*graph.pose(29)).between(gtsam.Pose2(*graph.pose(30)))
    assert np.allclose([step.x(), step.y(), step.theta()], (1.0, 0.0, 0.0), atol=1e-6)


def test_rows_grow_past_their_capacity_and_read_as_a_view():
    """Rows appended one at a time past the first buffer read back in order, as a view of the filled part."""
    from navlog.replay.mapping.slam2d.rows import Rows

    rows = Rows((3, 3), capacity=2)
    for k in range(5):
        rows.append(np.full((3, 3), float(k)))
    assert len(rows) == 5 and rows.view().shape == (5, 3, 3)
    assert rows.view()[:, 0, 0].tolist() == [0.0, 1.0, 2.0, 3.0, 4.0]
    rows.view()[1] = 7.0  # a view: writes land in the rows
    assert rows.view()[1, 2, 2] == 7.0
    assert Rows((2,)).view().shape == (0, 2)
    with pytest.raises(ValueError, match=r"a row of shape \(3, 3\) expected, got \(3,\)"):
        rows.append((0.1, 0.1, 0.05))  # sigmas where a covariance belongs: not broadcast
    assert len(rows) == 5


def test_an_edge_weighs_its_error_in_the_frame_of_its_target():
    """A match loose along the map's x axis (a corridor along x) between keyframes a quarter turn apart:
    moving the target 0.1 m along the corridor costs 0.01 (in sigmas squared), 1 cm across it costs 1 --
    gtsam's BetweenFactorPose2 measures its error in the target's frame, so the noise is rotated there."""
    import gtsam

    from navlog.replay.mapping.slam2d import PoseGraph
    from navlog.replay.mapping.slam2d.slam import _edge_covariance

    loose_along_x = np.diag([1.0, 1e-4, 1e-4])  # map frame: 1 m along x, 1 cm across, 0.01 rad
    for moved, chi2 in [((0.1, 1.0), 0.01), ((0.0, 1.01), 1.0)]:
        graph = PoseGraph()
        graph.add_node((0.0, 0.0, 0.0))
        graph.add_node((0.0, 1.0, math.pi / 2))
        graph.add_edge(0, 1, (0.0, 1.0, math.pi / 2), _edge_covariance(loose_along_x, math.pi / 2), "match")
        graph._values.update(1, gtsam.Pose2(*moved, math.pi / 2))
        assert graph.edge_chi2() == pytest.approx(chi2, rel=1e-3)


def test_the_loop_kernel_bounds_how_far_a_false_closure_bends_the_chain():
    from navlog.replay.mapping.slam2d import PoseGraph

    def bent(kernel: str) -> float:
        graph = PoseGraph()
        for i in range(6):  # a straight chain, 1 m steps (2 cm, 0.01 rad)
            graph.add_node((float(i), 0.0, 0.0))
            if i:
                graph.add_edge(i - 1, i, (1.0, 0.0, 0.0), (0.02, 0.02, 0.01), "match")
        graph.add_edge(0, 5, (4.0, 1.0, 0.0), (0.05, 0.05, 0.02), "loop", kernel=kernel)  # 1.4 m off: false
        graph.optimize()
        return float(np.hypot(*(graph.pose(5)[:2] - (5.0, 0.0))))

    plain, huber, cauchy = bent("none"), bent("huber"), bent("cauchy")
    # least squares meets the false closure a good part of the way; Huber's linear tail pulls far less,
    # Cauchy's (redescending) hardly at all
    assert plain > 0.3 and huber < 0.5 * plain and cauchy < 0.5 * huber
    with pytest.raises(ValueError, match="loop_kernel"):
        SlamParams(loop_kernel="tukey")  # type: ignore[arg-type]


def test_odometry_that_jumps_is_found_by_the_wider_search_and_counted(scene):
    # the wheels report a 2.5 m jump sideways at scan 40 while the robot drives on: the sequential match in
    # its 0.5 m window fails, the loop-sized search around the prediction and the previous keyframe places it
    truth = rectangle_path(0.1)[:80]
    odom = truth.copy()
    odom[40:, 1] += 2.5
    slam = run_slam(scene, truth, odom, SlamParams(do_loop_closing=False))
    assert len(slam.counts.odometry_jumps) == 1 and slam.counts.unplaced == []
    stamp, distance, turn, response = slam.counts.odometry_jumps[0]
    assert stamp == 40 * 100_000_000 and abs(distance - 2.5) < 0.05 and response > 0.45
    _, poses = slam.trajectory()
    assert np.hypot(*(poses[:, :2] - truth[:, :2]).T).max() < 0.03


def test_odometry_reset_to_zero_is_found_whatever_the_heading(scene):
    # at scan 70 the robot heads along +y (a quarter turn) and its odometry restarts at (0, 0, 0): the
    # prediction is 4 m off and a quarter turn off, beyond the search's fan; the search around the previous
    # keyframe with its own heading places the scan
    import gtsam

    truth = rectangle_path(0.1)[:100]
    odom = odometry_moved(truth, 70, gtsam.Pose2(*truth[70]).inverse())
    slam = run_slam(scene, truth, odom, SlamParams(do_loop_closing=False))
    assert len(slam.counts.odometry_jumps) == 1 and slam.counts.unplaced == []
    assert slam.counts.odometry_jumps[0][0] == 70 * 100_000_000
    _, poses = slam.trajectory()
    assert np.hypot(*(poses[:, :2] - truth[:, :2]).T).max() < 0.03
    assert np.abs(np.remainder(poses[:, 2] - truth[:, 2] + math.pi, 2 * math.pi) - math.pi).max() < 0.01


def missed_turn(truth: np.ndarray, at: int, turn: float) -> np.ndarray:
    """Odometry that follows ``truth`` but for a turn of ``turn`` rad at scan ``at`` it did not see (a gyro that
    lost its heading): from there on its poses are the truth's turned by ``-turn`` about the scan before."""
    import gtsam

    pivot = gtsam.Pose2(truth[at - 1, 0], truth[at - 1, 1], 0.0)
    return odometry_moved(truth, at, pivot.compose(gtsam.Pose2(0.0, 0.0, -turn)).compose(pivot.inverse()))


def test_a_turn_the_odometry_missed_is_found_by_the_search_over_every_heading(scene, monkeypatch):
    # at scan 70 (keyframe 14: the usual step is known) the odometry misses a 1.2 rad turn while its steps stay
    # usual (its step there swings 0.11 m with the turn it missed): the sequential match in its
    # 20-degree fan fails, the search at every heading around the prediction finds the turn (one jump, counted
    # with its turn) and the path stays on the truth; without that search the rest of the path swings away
    truth = rectangle_path(0.1)[:100]
    odom = missed_turn(truth, 70, 1.2)
    slam = run_slam(scene, truth, odom, SlamParams(do_loop_closing=False))
    assert slam.counts.unplaced == [] and len(slam.counts.odometry_jumps) == 1
    stamp, distance, turn, response = slam.counts.odometry_jumps[0]
    assert stamp == 70 * 100_000_000 and abs(turn - 1.2) < 0.02 and distance < 0.15 and response > 0.9
    _, poses = slam.trajectory()
    assert np.hypot(*(poses[:, :2] - truth[:, :2]).T).max() < 0.03
    assert np.abs(np.remainder(poses[:, 2] - truth[:, 2] + math.pi, 2 * math.pi) - math.pi).max() < 0.01
    monkeypatch.setattr(Slam2D, "_recover_turn", lambda *args: None)
    _, blind = run_slam(scene, truth, odom, SlamParams(do_loop_closing=False)).trajectory()
    assert np.hypot(*(blind[:, :2] - truth[:, :2]).T).max() > 1.0


def test_a_turn_that_fits_as_well_half_a_turn_on_is_no_turn():
    # the buffer holds a 6 x 4 m room's walls; the scan is taken from its centre turned 1 rad from the prediction
    # (after a weak match at 0.6: the bar is 0.8). A closed room looks the same half a turn on: refused. Open at
    # one end, half a turn on leaves a quarter of the scan off the walls: found.
    edge = np.linspace(-1.0, 1.0, 301)[:-1]
    long_walls = [np.stack([3 * edge, np.full_like(edge, y)], 1) for y in (-2.0, 2.0)]
    end_walls = [np.stack([np.full_like(edge, x), 2 * edge], 1) for x in (-3.0, 3.0)]
    truth = np.array([0.0, 0.0, 1.0])
    c, s = math.cos(truth[2]), math.sin(truth[2])

    def recovered(walls: np.ndarray):
        points = walls @ np.array([[c, -s], [s, c]])  # the walls in the frame of the robot at truth
        return Slam2D(SlamParams())._recover_turn(walls, points, np.zeros(3), 0.8, 0.5)

    assert recovered(np.concatenate(long_walls + end_walls)) is None
    found = recovered(np.concatenate(long_walls + end_walls[:1]))
    assert found is not None and abs(found.pose[2] - 1.0) < 0.02 and np.hypot(*found.pose[:2]) < 0.03


def test_a_look_alike_place_far_off_is_no_jump_when_the_odometry_moved_as_usual(scene):
    # at scan 102 (keyframe 20: the odometry's usual step between keyframes is known by then) the scan fits
    # 2 m to the side much better than where the robot is (it is the scan taken there: a look-alike place),
    # while the odometry moved as it always does: no jump is taken
    truth = rectangle_path(0.1)[:130]
    rng = np.random.default_rng(5)
    slam = Slam2D(SlamParams(do_loop_closing=False))
    elsewhere = truth[102] + np.array([0.0, 2.0, 0.0])
    for i, t in enumerate(truth):
        slam.add_scan(i * 100_000_000, t, scan_of(cast(scene, elsewhere if i == 102 else t, rng)))
    assert slam.counts.odometry_jumps == []
    _, poses = slam.trajectory()
    assert np.hypot(*(poses[:, :2] - truth[:, :2]).T).max() < 0.3
    # the odometry jumping 2 m there, the scan where the robot is: an unusual step, searched for and found
    odom = truth.copy()
    odom[102:, 1] += 2.0
    jumped = Slam2D(SlamParams(do_loop_closing=False))
    for i, (t, o) in enumerate(zip(truth, odom, strict=True)):
        jumped.add_scan(i * 100_000_000, o, scan_of(cast(scene, t, rng)))
    assert [stamp for stamp, _, _, _ in jumped.counts.odometry_jumps] == [102 * 100_000_000]
    _, poses = jumped.trajectory()
    assert np.hypot(*(poses[:, :2] - truth[:, :2]).T).max() < 0.05


def test_scans_that_overlap_nothing_before_them_are_a_named_stretch(scene):
    # the robot is carried out of the room: its scans there see nothing of it; the keyframe where the
    # chain breaks is placed by odometry alone and reported as a stretch with its stamps
    truth = rectangle_path(0.1)[:40]
    slam = Slam2D(SlamParams(do_loop_closing=False))
    for i, t in enumerate(truth):
        slam.add_scan(i * 100_000_000, t, scan_of(cast(scene, t)))
    far = scan_of(np.where(np.arange(N_BEAMS) % 2 == 0, 7.0, np.inf))  # an arc of points 7 m away, nothing else
    for k in range(4):
        slam.add_scan((40 + k) * 100_000_000, (truth[-1, 0] + 0.6 * (k + 1), truth[-1, 1], 0.0), far)
    # the first scan out there matches nothing: the break; the next ones match it (the stretch hangs on it)
    assert slam.counts.odometry_only == 1
    first = len(slam.keyframes) - 4
    assert slam.counts.unplaced == [(first, first, 40 * 100_000_000, 40 * 100_000_000)]


def turn_on_the_spot(scene, spacing_ns: int, params: SlamParams) -> tuple[Slam2D, np.ndarray]:
    """A full turn on the spot at (0.5, -0.5) in 0.05 rad steps (ten scans between keyframes) whose
    odometry turns 20 % too much: by the time it reports a keyframe's 0.5 rad, the robot turned 0.42."""
    truth = np.array([(0.5, -0.5, 0.05 * k) for k in range(126)])
    odom = drifting_odometry(truth, 0.2)
    rng = np.random.default_rng(2)
    slam = Slam2D(params)
    for i, (t, o) in enumerate(zip(truth, odom, strict=True)):
        slam.add_scan(i * spacing_ns, o, scan_of(cast(scene, t, rng)))
    return slam, truth


def yaw_errors(slam: Slam2D, truth: np.ndarray) -> np.ndarray:
    _, poses = slam.trajectory()
    return np.abs(np.remainder(poses[:, 2] - truth[:, 2] + np.pi, 2 * np.pi) - np.pi)


def test_scans_between_keyframes_are_matched_not_left_to_the_odometry(scene):
    slam, truth = turn_on_the_spot(scene, 1_000_000_000, SlamParams(do_loop_closing=False))
    assert slam.counts.keyframes < 20 and slam.counts.matched_between == 126 - slam.counts.keyframes
    assert yaw_errors(slam, truth).max() < 0.01  # the match, weighted against the odometry's 0.05 rad
    # without it the scans between keyframes carry the odometry's extra turn since their keyframe
    plain, _ = turn_on_the_spot(scene, 1_000_000_000, SlamParams(do_loop_closing=False, match_between_keyframes=False))
    assert plain.counts.matched_between == 0
    assert 0.06 < yaw_errors(plain, truth).max() < 0.12
    # the keyframes themselves are matched either way
    assert np.allclose(slam.graph.poses()[:, 2], plain.graph.poses()[:, 2], atol=0.005)


def test_scans_between_keyframes_are_matched_at_most_once_per_minimum_time_interval(scene):
    # scans 0.1 s apart, minimum_time_interval 0.5 s: every fifth scan between keyframes is matched; those
    # after it follow the odometry from it
    slam, truth = turn_on_the_spot(scene, 100_000_000, SlamParams(do_loop_closing=False))
    between = 126 - slam.counts.keyframes
    assert between / 5 - slam.counts.keyframes <= slam.counts.matched_between <= between / 5 + 1
    err = yaw_errors(slam, truth)
    assert 0.005 < err.max() < 0.06  # five steps of 0.01 rad extra turn, and the match's own error


def test_throttle_scans_processes_every_nth_scan_and_the_rest_follow_the_odometry(scene):
    # slam_toolbox's throttle_scans 3: of 126 scans the 1st and every 3rd (1-based) may be keyframes or be matched
    slam, truth = turn_on_the_spot(scene, 1_000_000_000, SlamParams(do_loop_closing=False, throttle_scans=3))
    counts = [k.stamp // 1_000_000_000 + 1 for k in slam.keyframes]
    assert counts[0] == 1 and all(c % 3 == 0 for c in counts[1:]) and len(counts) == 14
    assert slam.counts.matched_between == 126 // 3 - (len(counts) - 1)
    # a scan passed over carries the odometry's 0.01 rad extra turn a step since the last processed one
    err = yaw_errors(slam, truth)
    assert err[2::3].max() < 0.01 < err.max() < 0.03
    with pytest.raises(ValueError, match="throttle_scans must be at least 1, got 0"):
        SlamParams(throttle_scans=0)


def test_a_scan_of_more_beams_than_the_match_takes_is_thinned_and_still_placed(scene, monkeypatch):
    from navlog.replay.mapping.slam2d import slam as slam_module

    monkeypatch.setattr(slam_module, "MAX_MATCH_POINTS", 360)  # the 720-beam scans: 360 valid beams, evenly spread
    truth = [(-2.0 + 0.1 * k, -2.0, 0.0) for k in range(30)]
    odom = [(x + 0.004 * k, y, yaw) for k, (x, y, yaw) in enumerate(truth)]  # 4 % long
    slam = run_slam(scene, np.array(truth), np.array(odom), SlamParams(do_loop_closing=False))
    assert all(len(k.points) == 360 for k in slam.keyframes) and len(slam.keyframes) >= 5
    _, poses = slam.trajectory()
    # the odometry ends 0.12 m off; a scan between matched ones (0.5 s apart) follows it for up to 2 cm
    assert np.hypot(*(poses[:, :2] - np.array(truth)[:, :2]).T).max() < 0.04


@pytest.mark.parametrize(
    ("start", "heading", "keyframes_only"),
    [((-1.5, -0.5), 0.0, False), ((1.0, -1.5), 2.3, False), ((-1.5, -0.5), 0.0, True)],
)
def test_steps_back_the_odometry_measured_forward_are_counted(scene, start, heading, keyframes_only):
    # wheels that lose the sign of their speed: the robot drives 1 m ahead, 0.4 m back and on again, 2 cm a scan;
    # the odometry adds every step forward. The matches between keyframes (one each 0.5 s: 10 cm) pin the
    # room and measure the steps back: the four of the stretch driven back are counted (the next keyframe, 0.8 m
    # from its prediction, is an odometry jump the wider search places), where exact odometry counts none. The
    # same with keyframes every 10 cm and no matches between them, and along any heading
    along = np.concatenate([np.arange(50) * 0.02, 1.0 - np.arange(20) * 0.02, 0.6 + np.arange(40) * 0.02])
    direction = np.array([math.cos(heading), math.sin(heading)])
    truth = np.column_stack([start + along[:, None] * direction, np.full(len(along), heading)])
    odometer = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(along)))])
    odom = np.column_stack([start + odometer[:, None] * direction, truth[:, 2]])
    if keyframes_only:
        params = SlamParams(do_loop_closing=False, match_between_keyframes=False, minimum_travel_distance=0.1)
    else:
        params = SlamParams(do_loop_closing=False)
    params = dataclasses.replace(params, infer_reversing=False)  # (counted with it too; see the next test)
    lost = run_slam(scene, truth, odom, params).counts.reversals_missed
    assert run_slam(scene, truth, truth, params).counts.reversals_missed == []
    # each 10 cm (the keyframes: the first scan the odometer puts 10 cm on, by its float sums 55 or 56)
    first = lost[0][0] // 100_000_000
    assert first in (55, 56) and [stamp // 100_000_000 for stamp, _, _ in lost] == [first + 5 * k for k in range(4)]
    for _, forward, back in lost:  # (a keyframe's step is from the last one's pose weighed against the odometry)
        assert 0.1 - 1e-6 < forward < 0.125 and -0.125 < back < -0.05


def assert_calibrated_on_steps_read_one_way(slam: Slam2D) -> None:
    """The odometry's length calibration took no keyframe step whose reading turned since the keyframe before (at
    it or at a scan between): such a step is read partly the other way. One sample may be off: the keyframe step
    over the turn back at 4 m, which has 0.1 m driven back in it (the match measures it 0.2 m shorter than the
    odometry, and nothing has doubted the reading yet)."""
    off = [(matched, odometry) for matched, odometry in slam._lengths if abs(matched - odometry) > 0.05]
    assert len(off) <= 1 and all(abs(odometry - matched - 0.2) < 0.01 for matched, odometry in off), off


@pytest.mark.parametrize(("start", "heading"), [((-4.0, -0.5), 0.0), ((2.5, -3.0), 2.3)])
@pytest.mark.parametrize("stop", [0, 4])
def test_odometry_that_lost_the_sign_of_its_speed_is_read_backwards_where_the_scans_say_so(scene, start, heading, stop):
    # the robot drives 4 m ahead, 1.5 m back, stops for ``stop`` scans and drives 3 m on, 10 cm a scan; the
    # odometry adds every step forward. A match every 0.5 s lies 1 m from the odometry's prediction once the robot
    # drives back, beyond the search's square: it fits less than the matches before, the step read backwards fits,
    # and the odometry is read backwards from then on, until the robot stops or a match finds it driving forward
    along = np.concatenate(
        [np.arange(41) * 0.1, 4.0 - np.arange(1, 16) * 0.1, np.full(stop, 2.5), 2.5 + np.arange(1, 31) * 0.1]
    )
    direction = np.array([math.cos(heading), math.sin(heading)])
    truth = np.column_stack([start + along[:, None] * direction, np.full(len(along), heading)])
    odometer = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(along)))])
    odom = np.column_stack([start + odometer[:, None] * direction, truth[:, 2]])
    params = SlamParams(do_loop_closing=False)
    errors = {}
    for infer in (True, False):
        slam = run_slam(scene, truth, odom, dataclasses.replace(params, infer_reversing=infer))
        _, poses = slam.trajectory()
        errors[infer] = float(np.hypot(*(poses[:, :2] - truth[:, :2]).T).mean())
        if not infer:
            assert slam.counts.reversals_inferred == []
            continue
        (back, minus), (forward, plus) = slam.counts.reversals_inferred
        assert (minus, plus) == (-1, 1)
        assert 4_100_000_000 <= back <= 5_500_000_000  # (scans 41-55 are driven back)
        if stop:  # the first scan the odometry stood still at
            assert forward == 5_600_000_000
        else:  # the next match or two
            assert 5_600_000_000 <= forward <= 6_500_000_000
        assert_calibrated_on_steps_read_one_way(slam)
    assert errors[True] < 0.09 and errors[True] < 0.7 * errors[False]
    # odometry that reports driving back is never read the other way
    assert run_slam(scene, truth, truth, params).counts.reversals_inferred == []


@pytest.mark.parametrize(("start", "heading"), [((-4.0, -0.5), 0.0), ((2.5, -3.0), 2.3)])
def test_a_reading_turned_backwards_turns_forward_where_a_match_finds_the_robot_driving_on(scene, start, heading):
    # 4 m ahead and 1.5 m back at 10 cm a scan, then on without a stop, creeping 3 cm a scan for 0.9 m before
    # 10 cm a scan again; the odometry adds every step forward. Creeping, the odometry read backwards strays 6 cm
    # a scan: the matches still find the robot and fit as well as ever, so nothing doubts them, but they measure it
    # driving on where the reading says back, and the reading turns forward at the first of them
    along = np.concatenate(
        [np.arange(41) * 0.1, 4.0 - np.arange(1, 16) * 0.1, 2.5 + np.arange(1, 31) * 0.03, 3.4 + np.arange(1, 21) * 0.1]
    )
    direction = np.array([math.cos(heading), math.sin(heading)])
    truth = np.column_stack([start + along[:, None] * direction, np.full(len(along), heading)])
    odometer = np.concatenate([[0.0], np.cumsum(np.abs(np.diff(along)))])
    odom = np.column_stack([start + odometer[:, None] * direction, truth[:, 2]])
    slam = run_slam(scene, truth, odom, SlamParams(do_loop_closing=False))
    (back, minus), (forward, plus) = slam.counts.reversals_inferred
    assert (minus, plus) == (-1, 1)
    assert 4_100_000_000 <= back <= 5_500_000_000  # (scans 41-55 are driven back)
    # scan 56 is the first on, and a match is due every 0.5 s (the doubted fits alone turned it at 6.6 and 8.6 s)
    assert 5_600_000_000 <= forward <= 6_200_000_000
    assert_calibrated_on_steps_read_one_way(slam)
    _, poses = slam.trajectory()
    err = np.hypot(*(poses[:, :2] - truth[:, :2]).T)
    # each match pulls the creeping robot back to where it is; from the turn on the odometry holds it
    assert float(err[56:].max()) < 0.3 and float(err[int(forward // 100_000_000) + 1 :].max()) < 0.1


def test_a_reading_turned_backwards_turns_forward_once_the_odometry_reports_driving_back():
    # the odometry read backwards from 0.1 s on; at 0.3 s the log's odometry reports 1.5 cm back: it knows the sign
    # after all, and its steps are read as given from that one on
    slam = Slam2D(SlamParams())
    slam._read_odometry(0, gtsam.Pose2(0.0, 0.0, 0.0))
    slam._read_odometry(100_000_000, gtsam.Pose2(0.1, 0.0, 0.0))
    slam._turn_reading(100_000_000)
    assert slam._read_odometry(200_000_000, gtsam.Pose2(0.2, 0.0, 0.1)).x() == pytest.approx(0.0)
    read = slam._read_odometry(300_000_000, gtsam.Pose2(0.2 - 0.015 * math.cos(0.1), -0.015 * math.sin(0.1), 0.1))
    assert (read.x(), read.y(), read.theta()) == pytest.approx((-0.015 * math.cos(0.1), -0.015 * math.sin(0.1), 0.1))
    assert slam.counts.reversals_inferred == [(100_000_000, -1), (300_000_000, 1)]
    assert slam._read_odometry(400_000_000, gtsam.Pose2(0.3, 0.0, 0.1)).x() == pytest.approx(0.3 - 0.2)
