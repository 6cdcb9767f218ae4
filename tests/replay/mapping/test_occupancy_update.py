"""The occupancy grid's NumPy ray update against a per-beam oracle: the same bits on random and edge scans."""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

import navlog.replay.mapping.occupancy as occupancy_module
from navlog.replay.mapping.occupancy import OccupancyGrid2D, OccupancyParams
from tests.replay.mapping.occupancy_oracle import reference_update, scan_update


def pose(x: float, y: float, yaw: float, roll: float = 0.0) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    rz = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    cr, sr = math.cos(roll), math.sin(roll)
    rx = np.array([[1, 0, 0], [0, cr, -sr], [0, sr, cr]])
    p = np.eye(4)
    p[:3, :3] = rz @ rx
    p[:2, 3] = x, y
    return p


def random_scans(seed: int, count: int):
    """720-beam (and tiny) scans with inf, -inf, NaN, readings at range_min/range_max, poses far apart."""
    rng = np.random.default_rng(seed)
    for _ in range(count):
        n = int(rng.choice([1, 3, 720]))
        ang = -math.pi + 2 * math.pi * np.arange(n) / n
        r = rng.uniform(0.0, 12.0, n)
        kind = rng.random(n)
        r[kind < 0.05] = np.inf
        r[(kind >= 0.05) & (kind < 0.08)] = np.nan
        r[(kind >= 0.08) & (kind < 0.1)] = -np.inf
        r[(kind >= 0.1) & (kind < 0.12)] = 10.0  # range_max: no return
        r[(kind >= 0.12) & (kind < 0.13)] = 0.1  # range_min: too close
        x, y = rng.uniform(-8, 8, 2)
        yield pose(float(x), float(y), float(rng.uniform(-3, 3)), float(rng.choice([0.0, 0.3]))), ang, r


def grids_after(monkeypatch, params: OccupancyParams, seed: int, count: int) -> list[OccupancyGrid2D]:
    grids = [OccupancyGrid2D(params), OccupancyGrid2D(params)]
    monkeypatch.setattr(grids[1], "_update", functools.partial(reference_update, grids[1]))
    for p, ang, r in random_scans(seed, count):
        grids[0].insert_scan(p, ang, r, 0.1, 10.0)
        grids[1].insert_scan(p, ang, r, 0.1, 10.0)
    return grids


@pytest.mark.parametrize(
    "params",
    [
        OccupancyParams(),
        OccupancyParams(resolution=0.1, max_laser_range=6.0, no_return_ray_length=2.5),
        OccupancyParams(resolution=0.03, grow_block=2.0, no_return_ray_length=12.0),
    ],
)
def test_the_numpy_update_equals_the_per_beam_oracle_on_random_scans(monkeypatch, params):
    a, b = grids_after(monkeypatch, params, seed=int(params.resolution * 100), count=12)
    assert a.logodds.tobytes() == b.logodds.tobytes()
    assert a.seen.tobytes() == b.seen.tobytes()
    assert (a.origin == b.origin).all() and a.stats == b.stats
    assert a.seen.sum() > 1000 and (a.logodds > 0).any() and (a.logodds < 0).any()


def test_beams_at_the_grid_edge_and_a_grid_grown_between_scans(monkeypatch):
    # beams ending exactly on block borders (the grid's last cells) and a grid grown between scans
    params = OccupancyParams(grow_block=1.0)
    grids = [OccupancyGrid2D(params), OccupancyGrid2D(params)]
    monkeypatch.setattr(grids[1], "_update", functools.partial(reference_update, grids[1]))
    ang = np.array([0.0, math.pi / 2, math.pi, -math.pi / 2])
    for p, r in ((pose(0.5, 0.5, 0.0), np.full(4, 0.49)), (pose(0.5, 0.5, 0.0), np.full(4, 3.0))):
        for grid in grids:
            grid.insert_scan(p, ang, r, 0.01, 10.0)
    assert grids[0].logodds.tobytes() == grids[1].logodds.tobytes()


def test_the_per_beam_oracle_is_the_same_function():
    g = OccupancyGrid2D(OccupancyParams(resolution=0.1))
    ang = np.array([0.0, 0.5, math.pi])
    g.insert_scan(np.eye(4), ang, np.array([1.0, 1.0, 1.0]), 0.1, 10.0)  # grows the grid
    ny, nx = g.logodds.shape
    logodds, seen = np.zeros(nx * ny, np.float32), np.zeros(nx * ny, bool)
    want = OccupancyGrid2D(OccupancyParams(resolution=0.1))
    want.insert_scan(np.eye(4), ang, np.array([1.0, 1.0, 1.0]), 0.1, 10.0)
    g0 = ((np.zeros(2) - g.origin) / 0.1).astype(np.float32)
    d = np.column_stack([np.cos(ang), np.sin(ang)]).astype(np.float32)
    t = np.arange(21, dtype=np.float32) * np.float32(0.5)
    last = np.full(3, (1.0 - 0.05) / 0.1, dtype=np.float32)
    ends = g._cells(np.column_stack([np.cos(ang), np.sin(ang)]), nx)
    f32 = np.float32
    scan_update(
        logodds, seen, np.zeros(nx * ny, np.int8), nx, g0, d, t, last, ends,
        f32(g.l_miss), f32(g.l_min), f32(g.l_hit), f32(g.l_max),
    )  # fmt: skip
    assert logodds.tobytes() == want.logodds.reshape(-1).tobytes()
    # one scan: each seen cell updated once, the three end cells as hits, the sensor's cell as a miss
    assert np.isclose(logodds[ends], g.l_hit).all()
    sensor = int(g0[1]) * nx + int(g0[0])
    assert np.isclose(logodds[sensor], g.l_miss)
    assert np.isclose(logodds[seen], g.l_miss).sum() == seen.sum() - 3 > 3 * 9


def test_a_beam_leaving_the_grid_is_an_error_and_leaves_the_mask_clear():
    mask = np.zeros(16, np.int8)
    f32 = np.float32
    with pytest.raises(IndexError, match="leaves the occupancy grid"):
        scan_update(
            np.zeros(16, np.float32), np.zeros(16, bool), mask, 4, np.array([1.0, 1.0], np.float32),
            np.array([[0.0, 1.0]], np.float32), np.arange(10, dtype=np.float32), np.array([9.0], np.float32),
            np.zeros(0, np.int64), f32(-0.4), f32(-2.0), f32(0.8), f32(3.5),
        )  # fmt: skip
    assert not mask.any()


@pytest.mark.parametrize("groups", [2, 4, 720])
def test_the_numpy_update_gives_the_same_bits_whatever_the_beam_groups(monkeypatch, groups):
    # beams of every length in one scan: grouped by length, each group's arrays only as long as its
    # longest beam; one group (as long as the longest beam of the scan) is the reference
    scans = list(random_scans(11, 6))
    grids = {}
    for n in (1, groups):
        monkeypatch.setattr(occupancy_module, "NUMPY_BEAM_GROUPS", n)
        grids[n] = OccupancyGrid2D(OccupancyParams())
        for p, ang, r in scans:
            grids[n].insert_scan(p, ang, r, 0.1, 10.0)
    assert grids[groups].logodds.tobytes() == grids[1].logodds.tobytes()
    assert grids[groups].seen.tobytes() == grids[1].seen.tobytes() and grids[1].seen.sum() > 1000
    # the largest work array of the grouped update holds fewer samples than 720 beams x the longest beam
    assert grids[groups]._buffers["x"].size < grids[1]._buffers["x"].size


def test_a_group_larger_than_the_sample_budget_is_taken_in_parts_with_the_same_bits(monkeypatch):
    scans = list(random_scans(11, 6))
    grids, shapes = {}, []
    crossed = OccupancyGrid2D._crossed

    def recorded(self, t, last, *rest):
        shapes.append((len(last), len(t)))
        return crossed(self, t, last, *rest)

    monkeypatch.setattr(OccupancyGrid2D, "_crossed", recorded)
    for budget in (occupancy_module.GROUP_SAMPLES, 200):
        monkeypatch.setattr(occupancy_module, "GROUP_SAMPLES", budget)
        shapes.clear()
        grids[budget] = OccupancyGrid2D(OccupancyParams())
        for p, ang, r in scans:
            grids[budget].insert_scan(p, ang, r, 0.1, 10.0)
    default, small = grids[occupancy_module.GROUP_SAMPLES], grids[200]
    assert small.logodds.tobytes() == default.logodds.tobytes() and small.seen.tobytes() == default.seen.tobytes()
    # every part within the budget, but for a single beam longer than it
    assert all(beams * samples <= 200 or beams == 1 for beams, samples in shapes) and len(shapes) > 100


@pytest.mark.parametrize(("resolution", "block"), [(0.03, 0.7), (0.07, 5.0), (0.045, 5.0)])
def test_a_block_that_is_no_whole_number_of_cells_grows_the_grid_by_whole_cells(resolution, block):
    # 0.7 m is 23.3 cells of 3 cm: a grid of 23 cells would end 1 cm short of the block, and an end point there
    # would fall off it (or into the next row); the grid grows by the 24 cells over the block instead
    grid = OccupancyGrid2D(OccupancyParams(resolution=resolution, grow_block=block))
    edge = math.ceil(block / resolution - 1e-9) * resolution
    far = edge - 0.25 * resolution  # in the block's last whole cell, beyond the block itself where it is short
    ang = np.array([0.0, math.pi / 4, math.pi / 2])
    grid.insert_scan(pose(0.0, 0.0, 0.0), ang, np.array([far, far * math.sqrt(2), far]), 0.001, 100.0)
    n = math.ceil(block / resolution - 1e-9)
    assert grid.logodds.shape == (n, n) and (grid.origin == 0).all()
    hits = {tuple(int(v) for v in rc) for rc in np.argwhere(grid.logodds > 0)}
    assert hits == {(0, n - 1), (n - 1, n - 1), (n - 1, 0)}
    assert not grid._buffers["mask"].any()
    # grown by a block down and left, the grid keeps its cells on the same lattice: those hits lie a block's cells on
    grid.insert_scan(pose(-0.5 * edge, -0.5 * edge, 0.0), ang[:1], np.array([0.25 * edge]), 0.001, 100.0)
    assert grid.logodds.shape == (2 * n, 2 * n) and np.allclose(grid.origin, -edge)
    grown = {tuple(int(v) for v in rc) for rc in np.argwhere(grid.logodds > 0)}
    assert {(r + n, c + n) for r, c in hits} < grown and len(grown) == 4


@pytest.mark.parametrize("block", [0.0, -1.0, 0.01, math.inf, math.nan])
def test_a_block_under_one_cell_or_not_finite_is_refused(block):
    with pytest.raises(ValueError, match="grow_block"):
        OccupancyParams(resolution=0.05, grow_block=block)


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ({"grow_block": 1e6}, r"grow_block \(1000000.0 m\) is a block of 4e\+14 cells"),
        ({"clamp": (0.0, 1.0)}, "clamp"),  # logit(0) and logit(1) are infinite
        ({"clamp": (-1.0, 2.0)}, "clamp"),
        ({"clamp": (0.9, 0.1)}, "clamp"),
        ({"clamp": (0.5, 0.5)}, "clamp"),
    ],
)
def test_absurd_grid_parameters_are_refused_with_their_keys(values, message):
    with pytest.raises(ValueError, match=message):
        OccupancyParams(**values)
