"""The log-odds grid's ray update on hand-computed beams (cell size 0.05 m, sensor at a cell centre).

Samples every half cell along a beam from the sensor at cell (20, 20) (centre 1.025, 1.025): a
beam of length L crosses the cells up to the one holding its end; the end cell of a return is
marked occupied, a no-return beam clears ``no_return_ray_length`` (set here to range_max) without
marking. Each cell changes at
most once per scan. Consecutive scans of different sizes exercise the reused work buffers.
"""

from __future__ import annotations

import math

import numpy as np

from navlog.replay.mapping.occupancy import OccupancyGrid2D, OccupancyParams, logit

POSE = np.eye(4)
POSE[:2, 3] = (1.025, 1.025)
MISS, HIT = logit(0.4), logit(0.7)


def expected_cells() -> dict[tuple[int, int], float]:
    """(row, col) -> log-odds after scan A then scan B of the test below."""
    cells: dict[tuple[int, int], float] = {}

    def add(rc, v):
        cells[rc] = cells.get(rc, 0.0) + v

    # scan A, beam east, 1.0 m return: free cols 20..39 of row 20, occupied col 40
    # scan A, beam north, no return (range_max 2.0): free rows 20..60 of col 20 (the sensor cell once)
    for col in range(21, 40):
        add((20, col), MISS)
    add((20, 40), HIT)
    for row in range(21, 61):
        add((row, 20), MISS)
    add((20, 20), MISS)
    # scan B, beam west, 0.5 m return: free cols 11..20 of row 20, occupied col 10
    for col in range(11, 21):
        add((20, col), MISS)
    add((20, 10), HIT)
    return cells


def test_known_beams_mark_the_expected_cells_across_scans_of_different_sizes():
    grid = OccupancyGrid2D(OccupancyParams(resolution=0.05, no_return_ray_length=2.0))
    grid.insert_scan(POSE, np.array([0.0, math.pi / 2]), np.array([1.0, math.inf]), 0.1, 2.0)
    grid.insert_scan(POSE, np.array([math.pi, 0.3]), np.array([0.5, math.nan]), 0.1, 2.0)
    assert grid.logodds.shape == (100, 100) and tuple(grid.origin) == (0.0, 0.0)
    want = expected_cells()
    seen = {(int(r), int(c)) for r, c in zip(*np.nonzero(grid.seen))}
    assert seen == set(want)
    for rc, v in want.items():
        assert grid.logodds[rc] == np.float32(v), rc
    assert np.count_nonzero(grid.logodds) == len(want)
    st = grid.stats
    assert (st.scans, st.beams, st.hits, st.no_return, st.nan) == (2, 4, 2, 1, 1)


def test_a_large_scan_after_small_ones_matches_a_fresh_grid():
    """Growing the work buffers mid-run changes nothing: 720 beams after 2-beam scans."""
    rng = np.random.default_rng(4)
    angles = np.linspace(-math.pi, math.pi, 720, endpoint=False)
    big = rng.uniform(0.2, 3.0, 720)
    big[::50] = math.inf
    warm = OccupancyGrid2D(OccupancyParams())
    for k in range(3):
        warm.insert_scan(POSE, np.array([0.1 * k, 2.0]), np.array([0.4, 0.6]), 0.1, 3.0)
    warm.insert_scan(POSE, angles, big, 0.1, 3.0)
    fresh = OccupancyGrid2D(OccupancyParams())
    for k in range(3):
        fresh.insert_scan(POSE, np.array([0.1 * k, 2.0]), np.array([0.4, 0.6]), 0.1, 3.0)
    fresh._buffers.clear()  # as if never used
    fresh.insert_scan(POSE, angles, big, 0.1, 3.0)
    assert np.array_equal(warm.logodds, fresh.logodds) and np.array_equal(warm.seen, fresh.seen)
    # alone, the scan marks exactly the cells holding its 720 - 15 returns' end points
    solo = OccupancyGrid2D(OccupancyParams())
    solo.insert_scan(POSE, angles, big, 0.1, 3.0)
    ends = POSE[:2, 3] + np.stack([np.cos(angles), np.sin(angles)], axis=1) * big[:, None]
    ret = np.isfinite(big)
    cells = {
        (int(np.floor((y - solo.origin[1]) / 0.05)), int(np.floor((x - solo.origin[0]) / 0.05))) for x, y in ends[ret]
    }
    occupied = {(int(r), int(c)) for r, c in zip(*np.nonzero(solo.logodds > 0))}
    assert occupied == cells and len(cells) > 600


def test_the_map_made_again_where_scans_changed_it_is_the_map_made_whole():
    """``to_map`` remakes only the box of the cells scans changed since its last call: after scans here and far
    off (the grid growing west and north between calls), after no scan, and after the grid's arrays were replaced,
    every map is the trinary definition over the whole grid: 100 where seen and above the occupied threshold's
    log-odds, 0 where seen and below the free one's, -1 elsewhere."""
    params = OccupancyParams(resolution=0.05, no_return_ray_length=2.0)
    grid = OccupancyGrid2D(params)
    rng = np.random.default_rng(4)

    def whole() -> np.ndarray:
        want = np.full(grid.logodds.shape, -1, dtype=np.int8)
        want[grid.seen & (grid.logodds > logit(params.occupied_threshold))] = 100
        want[grid.seen & (grid.logodds < logit(params.free_threshold))] = 0
        return want

    checked = []
    for k, (x, y) in enumerate([(1.0, 1.0), (1.3, 0.8), (-6.0, 1.0), (1.2, 9.0), (1.2, 9.0), (0.5, 0.5)]):
        for _ in range(3 if k != 4 else 0):  # the fifth call follows no scan
            pose = np.eye(4)
            pose[:2, 3] = (x + rng.uniform(-0.2, 0.2), y + rng.uniform(-0.2, 0.2))
            angles = np.linspace(-math.pi, math.pi, 90, endpoint=False)
            grid.insert_scan(pose, angles, rng.uniform(0.3, 2.5, 90), 0.1, 2.0)
        if k == 5:  # arrays replaced in place of the grid's (as a grid read back from a worker is)
            grid.logodds, grid.seen = grid.logodds.copy(), grid.seen.copy()
        got = grid.to_map()
        assert np.array_equal(got.data, whole()), k
        checked.append(got.data)
    assert checked[2].shape != checked[1].shape and checked[3].shape != checked[2].shape  # the grid grew
    assert {-1, 0, 100} <= set(np.unique(checked[-1]).tolist())
    got.data[:] = 100  # a map handed out is the caller's: the next is made from the grid
    assert np.array_equal(grid.to_map().data, whole())
