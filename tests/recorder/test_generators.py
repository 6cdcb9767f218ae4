"""World generators and routes: deterministic worlds, the cellular automaton, optimal paths, start/goal pairs."""

from __future__ import annotations

import math

import numpy as np
import pytest

from navlog.errors import ConfigError, NavlogError
from navlog.recorder.generators import cellular_automaton, generate_world, world_yaml, write_world_yaml
from navlog.recorder.routes import optimal_path, sample_routes, true_grid
from navlog.recorder.world import load_world


@pytest.mark.parametrize("kind", ["barn", "room", "corridor", "office"])
def test_generated_world_is_deterministic_and_loads_back(kind, tmp_path):
    a, b, c = generate_world(kind, 4), generate_world(kind, 4), generate_world(kind, 5)
    assert world_yaml(a) == world_yaml(b)
    assert world_yaml(a) != world_yaml(c)
    path = write_world_yaml(a, tmp_path / "w.yaml")
    assert load_world(str(path)).solids == a.world.solids
    with pytest.raises(NavlogError, match="already exists"):
        write_world_yaml(a, path)


def test_cellular_automaton_rule():
    g = np.zeros((5, 5), dtype=bool)
    g[1:4, 1:4] = True
    g[2, 2] = False  # a hole with 8 obstacle neighbours fills
    g[0, 4] = True  # a lone cell (0 neighbours) clears
    out = cellular_automaton(g, 1, fill_threshold=5, clear_threshold=3)
    assert out[2, 2] and not out[0, 4]
    assert not out[1, 1]  # a corner of the block: 2 obstacle neighbours (< 3) clears
    assert out[1, 2]  # an edge: 4 neighbours, between the thresholds, stays
    assert cellular_automaton(g, 0).tolist() == g.tolist()


def test_barn_field_is_passable_and_rated():
    gen = generate_world("barn", 0, {"fill": 0.35})
    info = gen.info
    assert info["generator"] == "barn" and info["seed"] == 0
    assert 0.1 < info["fill_actual"] < 0.35
    # the robot_radius it was made passable for (NavFn's path cuts corners between cell centres by a few cm)
    assert info["path_min_clearance_m"] >= 0.22
    assert 0.25 < info["difficulty"] <= 1.0
    assert info["optimal_path_m"] >= 6.0  # from the lower strip's middle to the upper one's: 6 m straight


def test_barn_difficulty_grows_with_fill():
    mean = [np.mean([generate_world("barn", s, {"fill": f}).info["difficulty"] for s in range(3)]) for f in (0.2, 0.35)]
    assert mean[1] > mean[0] + 0.1


def test_impossible_fields_are_errors():
    with pytest.raises(ConfigError, match="fill must be at least 0 and below 1"):
        generate_world("barn", 0, {"fill": 1.0})
    with pytest.raises(ConfigError, match="no passable field .* in 2 tries"):
        generate_world("barn", 0, {"fill": 0.6, "tries": 2})
    with pytest.raises(ConfigError, match="did you mean 'fill'"):
        generate_world("barn", 0, {"fil": 0.2})
    with pytest.raises(ConfigError, match="unknown world generator 'corridoor'.*did you mean 'corridor'"):
        generate_world("corridoor", 0)


def test_optimal_path_down_an_empty_corridor():
    world = generate_world("corridor", 0, {"doors": 0, "length": 10.0, "width": 2.0}).world
    grid = true_grid(world)
    path = optimal_path(grid, (-4.0, 0.0, 0.0), (4.0, 0.0, 0.0), radius=0.25)
    assert path is not None
    assert path.length_m == pytest.approx(8.0, abs=0.05)
    # clearance 1 m (the walls' inner faces at y = +-1), less the rasterisation's 1.5 cells (0.075 m):
    # a cell counts as occupied within half a cell of a wall, and clearance runs to that cell's edge
    assert path.min_clearance_m == pytest.approx(0.925, abs=0.01)
    assert path.difficulty == pytest.approx(0.25 / 0.925, abs=0.01)
    assert optimal_path(grid, (-4.0, 0.0, 0.0), (4.0, 0.0, 0.0), radius=1.1) is None  # too wide for it


def test_doorways_lengthen_the_path_and_block_a_wide_robot():
    gen = generate_world("corridor", 3, {"doors": 3, "door_width": 0.8})
    grid = true_grid(gen.world)
    path = optimal_path(grid, (-5.5, 0.0, 0.0), (5.5, 0.0, 0.0), radius=0.25)
    assert path is not None and path.length_m > 11.0
    assert path.min_clearance_m < 0.4  # it goes through 0.8 m doorways
    assert optimal_path(grid, (-5.5, 0.0, 0.0), (5.5, 0.0, 0.0), radius=0.45) is None


def test_sample_routes_free_apart_connected_and_seeded():
    world = generate_world("room", 2).world
    grid = true_grid(world)
    routes = sample_routes(world, 0.3, 5, seed=11, min_distance=3.0, margin=0.1, grid=grid)
    assert routes == sample_routes(world, 0.3, 5, seed=11, min_distance=3.0, margin=0.1, grid=grid)
    assert routes != sample_routes(world, 0.3, 5, seed=12, min_distance=3.0, margin=0.1, grid=grid)
    for start, goal in routes:
        assert math.dist(start[:2], goal[:2]) >= 3.0
        assert grid.clearance_at(np.array([start[:2], goal[:2]])).min() >= 0.4 - 1e-9
        assert optimal_path(grid, start, goal, 0.3) is not None
    with pytest.raises(ConfigError, match="lower min_distance"):
        sample_routes(world, 0.3, 1, seed=0, min_distance=50.0, grid=grid, tries=20)


def test_office_rooms_open_onto_the_corridor_through_their_doorways():
    gen = generate_world("office", 3, {"rooms": 3, "furniture": 0})
    assert gen.spec.walls.size == (9.0, 7.6)  # 3 rooms of 3 m; 1.6 m corridor + 2 x 3 m rooms
    grid = true_grid(gen.world)
    corridor = (0.0, 0.0, 0.0)
    rooms = [(x, sign * 2.3, 0.0) for x in (-3.0, 0.0, 3.0) for sign in (-1, 1)]  # each room's middle
    paths = [optimal_path(grid, corridor, room, 0.33) for room in rooms]
    assert all(p is not None for p in paths)
    # from the corridor's middle into a room's middle: at least the 1.5 m straight across, through a doorway
    assert all(1.5 < p.length_m < 6.0 for p in paths)
    narrow = true_grid(generate_world("office", 3, {"rooms": 3, "furniture": 0, "door_width": 0.5}).world)
    assert all(optimal_path(narrow, corridor, room, 0.33) is None for room in rooms)  # 0.5 m < 0.66 m wide
    assert optimal_path(narrow, corridor, (4.0, 0.0, 0.0), 0.33) is not None  # the corridor itself is open
