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
    params = from_mapping(
        LidarMapperParams, {"cloud_every_n_frames": 5, "odometry": {"method": "gicp", "deskew": False}}
    )
    assert params.odometry.method == "gicp" and params.cloud_every_n_frames == 5
