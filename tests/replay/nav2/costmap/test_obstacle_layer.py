"""The obstacle layer: marking and clearing along rays, ranges, height filters, footprint clearing."""

from __future__ import annotations

from navlog.replay.nav2.costmap import (
    FREE_SPACE,
    LETHAL,
    NO_INFORMATION,
    Costmap2D,
    ObservationSourceParams,
    ObstacleLayerParams,
)
from tests.replay.nav2.costmap.grids import costmap_params, observation, obstacle_costmap


def test_obstacle_marking_and_clearing():
    cm = obstacle_costmap()
    assert cm.add_observation(observation([[7.05, 5.05, 0.2]]))
    cm.update(5.0, 5.0)
    row = cm.costs[50]
    assert row[70] == LETHAL
    assert (row[50:70] == FREE_SPACE).all()  # the ray from the sensor cell is cleared
    assert row[71] == NO_INFORMATION and row[49] == NO_INFORMATION
    # the obstacle moves 0.4 m away: its old cell is cleared by the new ray
    cm.add_observation(observation([[7.45, 5.05, 0.2]]))
    cm.update(5.0, 5.0)
    assert cm.costs[50, 70] == FREE_SPACE and cm.costs[50, 74] == LETHAL
    # 2.8 m away, beyond obstacle_max_range 2.5: not marked, but the ray clears (raytrace_max_range 3.0)
    cm.add_observation(observation([[5.05, 2.25, 0.2]]))
    cm.update(5.0, 5.0)
    assert (cm.costs[22:50, 50] == FREE_SPACE).all()
    assert cm.costs[50, 74] == LETHAL  # not on any ray of this scan: kept
    # 3.5 m away: the ray is cut at ceil(3.0 / 0.1) = 30 cells
    cm.add_observation(observation([[5.05, 8.55, 0.2]]))
    cm.update(5.0, 5.0)
    assert (cm.costs[50:81, 50] == FREE_SPACE).all() and cm.costs[81, 50] == NO_INFORMATION


def test_obstacle_ranges_and_height_filter():
    cm = obstacle_costmap(raytrace_min_range=0.5, obstacle_min_range=0.3)
    cm.add_observation(observation([[5.25, 5.05, 0.2], [5.05, 6.55, 0.2], [3.05, 5.05, 2.5]]))
    cm.update(5.0, 5.0)
    assert cm.costs[50, 52] == NO_INFORMATION  # 0.2 m: below obstacle_min_range, inside raytrace_min_range
    col = cm.costs[:, 50]
    assert col[65] == LETHAL
    assert (col[50:55] == NO_INFORMATION).all() and (col[55:65] == FREE_SPACE).all()
    assert (cm.costs[50, 30:50] == NO_INFORMATION).all()  # z = 2.5 above max_obstacle_height: dropped entirely


def test_height_trap_default_source_max():
    src = ObservationSourceParams(topic="/scan", data_type="LaserScan", clearing=True)  # max_obstacle_height 0.0
    layer = ObstacleLayerParams(observation_sources=("scan",), sources={"scan": src}, footprint_clearing_enabled=False)
    cm = Costmap2D(
        costmap_params(width=10, height=10, resolution=0.1, track_unknown_space=True, layers={"obstacle_layer": layer})
    )
    cm.add_observation(observation([[7.05, 5.05, 0.2]]))
    cm.update(5.0, 5.0)
    assert (cm.costs == NO_INFORMATION).all()


def test_footprint_clearing():
    src = ObservationSourceParams(topic="/scan", data_type="LaserScan", max_obstacle_height=2.0)
    layer = ObstacleLayerParams(observation_sources=("scan",), sources={"scan": src})
    cm = Costmap2D(
        costmap_params(width=4, height=4, resolution=0.1, robot_radius=0.3, layers={"obstacle_layer": layer})
    )
    cm.add_observation(observation([[2.05, 2.15, 0.1], [3.05, 2.05, 0.1]], origin=(2.0, 2.0, 0.1)))
    cm.update(2.0, 2.0)
    assert cm.costs[21, 20] == FREE_SPACE  # inside the footprint: cleared
    assert cm.costs[20, 30] == LETHAL
