"""``LidarOdometry`` run frame by frame on ray-cast sweeps of the test room: GICP with an odometry
prior, chunks of frames, and frames it cannot use."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from navlog.replay.mapping.lidar_odometry import LidarOdometry, LidarOdometryParams, MotionPrior, PoseTrack
from tests.replay import lidar_scene as scene
from tests.replay.mapping.lidar_odometry.helpers import ate_rmse, share_within

pytestmark = pytest.mark.slow


def test_gicp_and_odometry_prior(room):
    seq = scene.make_sequence(scene.loop_trajectory(), 40, scene=room)
    gt = seq.ground_truth([f.stamp_ns for f in seq.frames])
    odom = PoseTrack()
    drift = Rotation.from_euler("z", 0.05).as_matrix()  # a drifting odometry frame: only relative motion is used
    for t in np.arange(0, 4.1, 0.02):
        g = seq.ground_truth([int(round(t * 1e9))])[0]
        g[:3, :3] = drift @ g[:3, :3]
        g[:3, 3] = drift @ g[:3, 3] + [1.0, 2.0, 0.0]
        odom.add(int(round(t * 1e9)), g)
    odo = LidarOdometry(LidarOdometryParams(method="gicp"), seq.extrinsic, gt[0])
    for f in seq.frames:
        odo.process(f.stamp_ns, f.points, f.times, MotionPrior(odom=odom))
    stamps, poses = odo.poses()
    assert len(stamps) == 40
    assert ate_rmse(stamps, poses, seq) <= 0.03


def test_chunks_every_n_frames(room):
    seq = scene.make_sequence(scene.loop_trajectory(), 12, scene=room)
    odo = LidarOdometry(LidarOdometryParams(save_every_n_frames=5), seq.extrinsic, seq.ground_truth([0])[0])
    for f in seq.frames:
        odo.process(f.stamp_ns, f.points, f.times)
    chunks = odo.finish_chunks()
    assert len(chunks) == 3  # frames 1-5, 6-10, 11-12
    assert all(share_within(c, 0.05, room) >= 0.95 for c in chunks)
    full = odo.global_map()
    assert max(len(c) for c in chunks) <= len(full)


def test_all_nan_and_too_few_points_are_counted():
    odo = LidarOdometry(LidarOdometryParams())
    assert odo.process(0, np.full((50, 3), np.nan)) is None
    assert odo.process(1, np.ones((3, 3))) is None
    assert odo.process(2, np.ones((10, 3)), np.zeros(4)) is None
    assert odo.skipped == {"too_few_points": 2, "time_field_length_mismatch": 1}
    assert len(odo.poses()[0]) == 0


def test_the_vgicp_odometry_loads_neither_open3d_nor_scipy():
    # a second or so of a replay's start-up: they serve the Open3D methods only
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from navlog.replay.mapping.lidar_odometry import LidarOdometry, LidarOdometryParams\n"
        "import navlog.replay.nodes.lidar_mapper, navlog.replay.pipelines.mapping\n"
        "import numpy as np\n"
        "odo = LidarOdometry(LidarOdometryParams(method='vgicp'))\n"
        "rng = np.random.default_rng(0)\n"
        "for k in range(3):\n"
        "    odo.process(k * 100_000_000, rng.uniform(-5, 5, (2000, 3)))\n"
        "assert len(odo.global_map()) > 1000\n"
        "print('open3d' in sys.modules, 'scipy' in sys.modules)\n"
        "LidarOdometry(LidarOdometryParams(method='point_to_plane'))\n"
        "print('open3d' in sys.modules)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out == ["False", "False", "True"]
