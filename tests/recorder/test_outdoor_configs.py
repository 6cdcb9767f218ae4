"""The outdoor configs: the 64-beam car (outdoor_car), the town block (town_block) and its tour
(town_tour): they load, the tour is collision-free, and the LiDAR sees the known facade."""

from __future__ import annotations

import numpy as np

from navlog.recorder.robot import load_robot
from navlog.recorder.scenarios import check_scenario, load_scenario
from navlog.recorder.sensors import RayCaster, lidar_pattern
from navlog.recorder.world import clearance, load_world, world_mesh


def test_the_64_beam_pattern():
    lidar = load_robot("outdoor_car").lidar
    assert lidar is not None and lidar.topic == "/points" and lidar.range_max == 100.0
    dirs, ring, _ = lidar_pattern(lidar, 0)
    assert len(dirs) == 64 * 1024 and ring.max() == 63
    elevation = np.degrees(np.arcsin(dirs[:, 2]))
    np.testing.assert_allclose([elevation.min(), elevation.max()], [-25.0, 3.0], atol=1e-6)


def test_town_block_and_its_tour():
    world, robot, tour = load_world("town_block"), load_robot("outdoor_car"), load_scenario("town_tour")
    check_scenario(tour, robot, world)  # raises on a collision
    x0, y0, x1, y1 = world.bounds()
    assert x1 - x0 >= 100 and y1 - y0 >= 100  # outdoor scale
    # the ring road is clear by at least 2 m either side of the centreline at the corners
    corners = np.array([[40.0, -40.0], [40.0, 40.0], [-40.0, 40.0], [-40.0, -40.0]])
    assert (clearance(world, corners) >= 2.0).all()


def test_the_known_facade_is_the_plane_y_minus_32():
    caster = RayCaster(world_mesh(load_world("town_block")))
    origin = np.array([[-5.0, -40.0, 1.8]])  # on the south street, in front of south_inner_2
    d = caster.cast_distances(origin, np.array([[0.0, 1.0, 0.0]]))
    np.testing.assert_allclose(d, [8.0], atol=1e-4)
