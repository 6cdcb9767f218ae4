"""The simulator's direct CDR: a log is the same bytes whether its messages were built as objects or not."""

from __future__ import annotations

import dataclasses
import hashlib

import numpy as np
import pytest

from navlog.recorder import sensors
from navlog.recorder.robot import load_robot
from navlog.recorder.sim import SimNode, SimOptions
from navlog.recorder.world import load_world, world_mesh
from navlog.replay import messages
from navlog.replay.io.logwriter import McapLogWriter
from navlog.replay.pointcloud import make_cloud
from navlog.replay.runtime.executor import Executor, Node


def _topics(robot: str) -> list[str]:
    """The simulator's topics published as CDR bytes when no node subscribes to them."""
    spec = load_robot(robot)
    sensors_ = (spec.imu, spec.scan, spec.lidar)
    return ["/clock", "/odom", "/odom/ground_truth", "/tf", *(c.topic for c in sensors_ if c is not None)]


class _Listen(Node):
    """Subscribes to the simulator's topics, so that it builds their message objects."""

    def __init__(self, topics: list[str]) -> None:
        super().__init__()
        self.got: dict[str, list] = {t: [] for t in topics}

    def setup(self) -> None:
        for topic in self.got:
            self.subscribe(topic, lambda msg, ns, topic=topic: self.got[topic].append(msg))


class _Kinds:
    """A sink noting what the simulator published on each topic: objects or bytes."""

    def __init__(self) -> None:
        self.kinds: dict[str, set[str]] = {}

    def write(self, env) -> None:
        self.kinds.setdefault(env.topic, set()).add("bytes" if isinstance(env.msg, bytes) else "object")


def _record(path, robot: str, listen: bool) -> tuple[_Kinds, _Listen | None]:
    ex = Executor()
    ex.add_node(SimNode(load_world("indoor_room"), load_robot(robot), SimOptions(seed=5, start=(0.5, -0.5, 0.3))))
    listener = _Listen(_topics(robot)) if listen else None
    if listener is not None:
        ex.add_node(listener)

    class Drive(Node):
        def setup(self) -> None:
            self.create_timer(
                50_000_000, lambda t: self.publish("/cmd_vel", messages.TWIST, messages.twist(0.2, 0.0, 0.4)), 0
            )

    ex.add_node(Drive())
    kinds = _Kinds()
    ex.add_sink(kinds)
    with McapLogWriter(path, background=True) as writer:
        ex.add_sink(writer)
        ex.run(until_ns=400_000_000)
    return kinds, listener


@pytest.mark.parametrize("robot", ["go2", "simple_robot"])  # with and without a base_footprint frame
def test_direct_cdr_writes_the_bytes_of_the_message_objects(tmp_path, robot):
    raw, _ = _record(tmp_path / "raw.mcap", robot, listen=False)
    obj, listener = _record(tmp_path / "obj.mcap", robot, listen=True)
    raw_kinds, obj_kinds = raw.kinds, obj.kinds
    spec = load_robot(robot)
    topics = _topics(robot)
    assert len(topics) == (7 if robot == "go2" else 6)  # simple_robot: a 2D lidar, no 3D LiDAR
    assert {t: raw_kinds[t] for t in topics} == {t: {"bytes"} for t in topics}
    assert {t: obj_kinds[t] for t in topics} == {t: {"object"} for t in topics}
    assert listener is not None and len(listener.got["/clock"]) == 41 and len(listener.got["/tf"]) == 21
    assert listener.got["/tf"][-1].transforms[0].header.frame_id == "map"
    assert [len(m.ranges) for m in listener.got[spec.scan.topic]] == [spec.scan.samples] * 5  # 10 Hz, t = 0 too
    if spec.lidar is not None:  # go2: 4 clouds (10 Hz, the first at 0.1 s) of 16 x 720 points
        assert [m.width for m in listener.got[spec.lidar.topic]] == [16 * 720] * 4
    digest = [hashlib.sha256((tmp_path / name).read_bytes()).hexdigest() for name in ("raw.mcap", "obj.mcap")]
    assert digest[0] == digest[1]


def test_scan_and_cloud_bytes_equal_their_messages_serialized():
    """``scan_cdr`` and ``cloud_cdr`` against the message builders, with REP 117 ranges (NaN, +-inf),
    non-finite points, an empty cloud and frame names of every alignment."""
    cfg = load_robot("go2").scan
    rng = np.random.default_rng(11)
    ranges = rng.uniform(0.1, 6.0, cfg.samples).astype(np.float32)
    ranges[[0, 1, 2, 719]] = [np.inf, -np.inf, np.nan, 0.12]
    for frame in ("", "l", "la", "las", "front_laser"):
        for ns in (0, 1, 999_999_999, 138_000_000_000):
            data = sensors.scan_cdr(ns, frame, cfg, ranges)
            assert data == messages.serialize(sensors.scan_message(ns, frame, cfg, ranges), messages.LASER_SCAN)
    for n in (0, 1, 5, 11520):
        cols = {name: rng.normal(size=n).astype(np.float32) for name in ("x", "y", "z", "intensity", "time")}
        cols["ring"] = (np.arange(n) % 16).astype(np.uint16)
        if n:
            cols["x"][0], cols["z"][-1] = np.nan, -np.inf
        for frame in ("", "l", "livox", "livox_frame"):
            data = sensors.cloud_cdr(100_000_001, frame, cols)
            assert data == messages.serialize(make_cloud(100_000_001, frame, cols), messages.POINT_CLOUD2)
            assert data[-1:] == b"\x01" and len(data) > 22 * n  # the points, then is_dense


@pytest.mark.parametrize(
    ("pattern", "shift"),
    [("velodyne", 0.0), ("velodyne", 0.0013), ("livox_mid360", 0.0)],
    ids=["velodyne", "velodyne-uneven-runs", "livox"],
)
def test_a_sweep_packed_from_its_returns_equals_its_columns_packed(pattern: str, shift: float) -> None:
    """``returns_cdr`` (the raw path: the points packed straight from the returns) gives the bytes
    ``cloud_cdr`` gives for the returns' columns, from a moving sensor near a wall, for runs of one length
    (their ray products all at once) and of unequal lengths (one product per run)."""
    lidar = dataclasses.replace(load_robot("go2").lidar, pattern=pattern, points=3000)
    caster = sensors.RayCaster(world_mesh(load_world("indoor_room")))
    n = 22  # the poses of a 10 Hz sweep: 20 ticks and two around it
    poses = []
    for k in range(n):
        pose = np.eye(4)
        yaw = 0.02 * k
        pose[:2, :2] = [[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]]
        pose[:3, 3] = (1.0 + 0.01 * k, -0.5, 0.3)
        poses.append(((k - n + 1) * 0.005 + shift, pose))
    runs = sensors._sweep_timing(lidar, 0, tuple(t for t, _ in poses))[1]
    if pattern == "velodyne":
        assert (len({b - a for _, a, b in runs}) == 1) == (shift == 0)  # the two paths of the ray products
        dirs = sensors.lidar_pattern(lidar, 0)[0]
        at_once, one_by_one = (sensors._run_rays(dirs, runs, poses, at_once=flag) for flag in (True, False))
        assert all(np.array_equal(x, y) for x, y in zip(at_once, one_by_one))
    for frame_index in (0, 3):
        returns = sensors.lidar_returns(caster, lidar, frame_index, poses, np.random.default_rng(5))
        cols = returns.columns()
        assert sensors.returns_cdr(700_000_000, "livox_frame", returns) == sensors.cloud_cdr(
            700_000_000, "livox_frame", cols
        )
        returned = len(cols["x"])
        # some velodyne rays miss (the sky): the selected returns; every livox ray returns: no selection
        assert 0 < returned < 16 * 720 if pattern == "velodyne" else returned == 3000
