"""The mapping pipeline on a log with a PointCloud2 and no scan: the 3D mapper runs alone, the LiDAR
topic and the sensor mount are found or asked for before replaying, and an empty result says why."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
import pytest

from navlog.errors import NavlogError
from navlog.replay import messages
from navlog.replay.io.logwriter import McapLogWriter
from navlog.replay.runtime.executor import Envelope
from navlog.replay.session import run_replay
from tests.replay import lidar_scene as scene

pytestmark = pytest.mark.slow

MOUNT = "lidar.mount=[0.2,0.0,0.08,0.0,0.0,0.0]"  # scene.EXTRINSIC_XYZ


def cloud_log(path: Path, seq: scene.Sequence, *, topics=("/points",), frame="velodyne", tf_static=False) -> Path:
    """Clouds only (each at the end of its sweep), in ``frame``; /tf_static (base_link -> livox_frame) if asked."""
    envs = [Envelope("/tf_static", messages.TF_MESSAGE, 0, scene.tf_static_msg())] if tf_static else []
    for f in seq.frames:
        for topic in topics:
            envs.append(
                Envelope(topic, messages.POINT_CLOUD2, f.stamp_ns + scene.SWEEP_NS_INT, scene.cloud_msg(f, frame))
            )
    with McapLogWriter(path) as w:
        for env in envs:
            w.write(env)
    return path


def relative_to_first(poses: np.ndarray) -> np.ndarray:
    return np.linalg.inv(poses[0]) @ poses


def tum_poses(path: Path) -> tuple[np.ndarray, np.ndarray]:
    from scipy.spatial.transform import Rotation

    rows = np.atleast_2d(np.loadtxt(path))
    out = np.tile(np.eye(4), (len(rows), 1, 1))
    out[:, :3, 3] = rows[:, 1:4]
    out[:, :3, :3] = Rotation.from_quat(rows[:, 4:8]).as_matrix()
    return np.round(rows[:, 0] * 1e9).astype(np.int64), out


@pytest.fixture(scope="module")
def seq() -> scene.Sequence:
    # 0.3 m/s on a 0.6 m circle: the sensor, 0.2 m ahead of base_link, swings around it
    return scene.make_sequence(scene.loop_trajectory(speed=0.3, radius=0.6), 50)


@pytest.fixture(scope="module")
def log(seq, tmp_path_factory) -> Path:
    return cloud_log(tmp_path_factory.mktemp("log") / "clouds.mcap", seq)


def test_cloud_only_log_maps_alone_with_one_mount_warning(seq, log, tmp_path, caplog):
    with caplog.at_level(logging.WARNING, logger="navlog"):
        res = run_replay(log, "mapping", tmp_path / "out", progress=False)
    warnings = [r.getMessage() for r in caplog.records if r.levelno >= logging.WARNING]
    assert len(warnings) == 1 and "'velodyne'" in warnings[0] and "lidar.mount" in warnings[0]
    info = res.manifest["pipeline_info"]
    assert info["lidar_topic"] == "/points"  # the log's only PointCloud2, /livox/lidar being absent
    assert info["occupancy_mapper"].startswith("off (no /scan in the log")
    assert "identity" in info["lidar_mapper mount"]
    assert info["lidar_mapper time_field"] == "per-point time from field 'time' (relative s)"
    assert info["lidar_mapper preset"].startswith("auto: indoor")
    assert set(res.manifest["outputs"]) == {"replay_mcap", "map_pcd", "trajectory_tum"}
    assert res.manifest["published"]["/Odometry"] == len(seq.frames)
    # with no mount the trajectory is the sensor's: it matches the true sensor motion within 3 cm
    stamps, poses = tum_poses(tmp_path / "out" / "trajectory.tum")
    truth = relative_to_first(seq.ground_truth(stamps) @ seq.extrinsic)
    err = np.linalg.norm(relative_to_first(poses)[:, :3, 3] - truth[:, :3, 3], axis=1)
    assert len(stamps) == len(seq.frames) and err.max() <= 0.03


def test_mount_parameter_gives_the_base_link_trajectory(seq, log, tmp_path, caplog):
    with caplog.at_level(logging.WARNING, logger="navlog"):
        res = run_replay(log, "mapping", tmp_path / "out", overrides=[MOUNT], progress=False)
    assert not [r for r in caplog.records if r.levelno >= logging.WARNING]
    assert "lidar_mapper mount" not in res.manifest["pipeline_info"]
    stamps, poses = tum_poses(tmp_path / "out" / "trajectory.tum")
    base = relative_to_first(seq.ground_truth(stamps))
    sensor = relative_to_first(seq.ground_truth(stamps) @ seq.extrinsic)
    est = relative_to_first(poses)[:, :3, 3]
    # the known 0.2 m lever arm: base_link's path differs from the sensor's by up to ~0.1 m here,
    # and the mapper's trajectory is base_link's within 3 cm
    assert np.linalg.norm(base[:, :3, 3] - sensor[:, :3, 3], axis=1).max() > 0.08
    assert np.linalg.norm(est - base[:, :3, 3], axis=1).max() <= 0.03


def test_a_frame_tf_static_does_not_link_is_an_error_before_replaying(seq, tmp_path):
    short = scene.Sequence(seq.frames[:3], seq.imu_ns, seq.gyro, seq.accel, seq.trajectory, seq.extrinsic)
    log = cloud_log(tmp_path / "unlinked.mcap", short, frame="velodyne", tf_static=True)
    with pytest.raises(NavlogError) as exc:
        run_replay(log, "mapping", tmp_path / "out", progress=False)
    text = str(exc.value)
    assert "'velodyne'" in text and "'base_link'" in text and "livox_frame" in text
    assert "--set lidar.mount=[x,y,z,roll,pitch,yaw]" in text
    assert not (tmp_path / "out").exists()
    # the mount given: the same log replays
    res = run_replay(log, "mapping", tmp_path / "ok", overrides=[MOUNT], progress=False)
    assert res.manifest["published"]["/Odometry"] == 3


def test_several_cloud_topics_need_a_choice(seq, tmp_path):
    short = scene.Sequence(seq.frames[:2], seq.imu_ns, seq.gyro, seq.accel, seq.trajectory, seq.extrinsic)
    log = cloud_log(tmp_path / "two.mcap", short, topics=("/points", "/velodyne_points"))
    with pytest.raises(NavlogError, match=r"/points, /velodyne_points.*--set lidar.lidar_topic=/points"):
        run_replay(log, "mapping", tmp_path / "out", progress=False)
    res = run_replay(log, "mapping", tmp_path / "b", overrides=["lidar.lidar_topic=/velodyne_points"], progress=False)
    assert res.manifest["pipeline_info"]["lidar_topic"] == "/velodyne_points"


def test_no_usable_cloud_says_why_instead_of_failing_to_write(seq, tmp_path):
    frames = [scene.Frame(f.stamp_ns, np.full_like(f.points, np.nan), f.times, f.rings) for f in seq.frames[:3]]
    short = scene.Sequence(frames, seq.imu_ns, seq.gyro, seq.accel, seq.trajectory, seq.extrinsic)
    log = cloud_log(tmp_path / "nan.mcap", short)
    with pytest.raises(NavlogError) as exc:
        run_replay(log, "mapping", tmp_path / "out", progress=False)
    text = str(exc.value)
    assert "no 3D map: no cloud on /points could be registered" in text
    assert "lidar_mapper: cloud_no_finite_points x3" in text and "cannot write" not in text
    assert not (tmp_path / "out").exists()


def test_manifest_records_the_decided_topic(seq, log, tmp_path):
    run_replay(log, "mapping", tmp_path / "out", overrides=[MOUNT], progress=False)
    manifest = json.loads((tmp_path / "out" / "manifest.json").read_text())
    assert manifest["parameters"]["lidar"]["lidar_topic"] == "/points"
    assert manifest["parameters"]["lidar"]["mount"] == [0.2, 0.0, 0.08, 0.0, 0.0, 0.0]
