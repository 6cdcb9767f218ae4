"""The odometry's parameters are checked once, with the name of the bad key."""

from __future__ import annotations

import pytest

from navlog.errors import ConfigError
from navlog.replay.config import from_mapping
from navlog.replay.mapping.lidar_odometry import LidarOdometryParams
from navlog.replay.nodes.lidar_mapper import LidarMapperParams


def test_parameters_are_validated_with_names():
    with pytest.raises(ConfigError, match="scan_voxl.*did you mean 'scan_voxel'"):
        from_mapping(LidarMapperParams, {"odometry": {"scan_voxl": 0.2}})
    with pytest.raises(ConfigError, match="method.*'gicp'"):
        from_mapping(LidarMapperParams, {"odometry": {"method": "gicpp"}})
    with pytest.raises(ConfigError, match="scan_voxel must be positive"):
        from_mapping(LidarOdometryParams, {"scan_voxel": 0.0})
    with pytest.raises(ConfigError, match="covariance_threads must be at least 1"):
        from_mapping(LidarOdometryParams, {"covariance_threads": 0})
    params = from_mapping(
        LidarMapperParams, {"cloud_every_n_frames": 5, "odometry": {"method": "gicp", "deskew": False}}
    )
    assert params.odometry.method == "gicp" and params.cloud_every_n_frames == 5


def test_presets_and_sizing_from_the_sweep():
    import math

    import numpy as np

    from navlog.replay.mapping.lidar_odometry.params import for_sweep, observed_range, preset

    indoor = LidarOdometryParams()
    assert preset(indoor, "indoor") is indoor and preset(indoor, "auto") is indoor
    outdoor = preset(indoor, "outdoor")
    # vgicp (the default): Gaussian voxels and the scan filter of max_range / 100
    sizes = (outdoor.max_range, outdoor.gaussian_voxel, outdoor.scan_voxel, outdoor.local_map_radius)
    assert sizes == (100, 1, 1, 100)
    plane_icp = preset(LidarOdometryParams(method="point_to_plane"), "outdoor")
    assert (plane_icp.scan_voxel, plane_icp.map_voxel) == (1, 0.5)
    assert outdoor.adaptive_threshold and outdoor.max_correspondence == 2.0
    # a room: the 99th percentile of the ranges is within 30 m, the parameters stay as they are
    rng = np.random.default_rng(0)
    room = rng.uniform(0.5, 8.0, 10_000)
    assert for_sweep(indoor, room) is indoor
    # a street: 1 % of the returns reach further than 72 m -> 80 m range (10 % margin), 0.8 m voxels
    street = np.concatenate([rng.uniform(2.0, 72.0, 9_900), np.full(100, 75.0)])
    assert math.isclose(observed_range(street), 72.0, rel_tol=0.01)
    sized = for_sweep(indoor, street)
    assert sized.max_range == 80.0 and math.isclose(sized.gaussian_voxel, 0.8) and math.isclose(sized.scan_voxel, 0.8)
    # absurd coordinates (a corrupt sweep) do not make a room look like a 200 m field
    corrupt = np.concatenate([room, np.full(500, 3.0e38), [np.nan, np.inf]])
    assert for_sweep(indoor, corrupt) is indoor
    assert observed_range(np.zeros(0)) == 0.0
    assert for_sweep(indoor, np.full(10, 5000.0)) is indoor  # nothing believable: keep the start


def test_adaptive_threshold_is_three_sigma_of_the_model_deviation():
    import numpy as np

    from navlog.replay.mapping.lidar_odometry.odometry import AdaptiveThreshold

    th = AdaptiveThreshold(initial=2.0, max_range=100.0, min_motion=0.1, low=0.5, high=6.0)
    assert th.value == 2.0  # nothing measured yet
    moved = np.eye(4)
    moved[0, 3] = 1.0
    still = np.eye(4)
    dev = np.eye(4)
    dev[:3, 3] = (0.03, 0.04, 0.0)  # 5 cm
    angle = np.deg2rad(0.2)
    dev[:2, :2] = [[np.cos(angle), -np.sin(angle)], [np.sin(angle), np.cos(angle)]]
    th.update(dev, still)  # a frame that did not move adds nothing
    assert th.value == 2.0
    th.update(dev, moved)
    expected = 3 * (2 * 100.0 * np.sin(angle / 2) + 0.05)  # 3 * (0.349 + 0.05) m
    assert abs(th.value - expected) < 1e-9 and abs(th.value - 1.197) < 1e-3
    th.update(np.eye(4), moved)  # a perfect prediction: sigma = sqrt((e^2 + 0) / 2)
    assert abs(th.value - expected / np.sqrt(2)) < 1e-9
    for _ in range(100):
        th.update(np.eye(4), moved)
    assert th.value == 0.5  # never below the lower bound
