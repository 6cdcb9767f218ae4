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
