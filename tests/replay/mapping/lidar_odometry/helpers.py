"""Shared helpers of the LiDAR odometry tests: running the mapper node on a scene, errors against the truth."""

from __future__ import annotations

import hashlib

import numpy as np
import open3d as o3d
from scipy.spatial.transform import Rotation

from navlog.replay import messages
from navlog.replay.mapping.lidar_odometry import LidarOdometryParams
from navlog.replay.nodes.lidar_mapper import LidarMapperNode, LidarMapperParams
from navlog.replay.runtime.executor import Envelope, Executor
from tests.replay import lidar_scene as scene

SWEEP_NS = 100_000_000


class Recorder:
    def __init__(self) -> None:
        self.items: list[tuple[str, int, bytes]] = []

    def write(self, env: Envelope) -> None:
        if env.topic in ("/Odometry", "/cloud_registered", "/lidar_mapper/path"):
            raw = env.msg if isinstance(env.msg, bytes) else messages.serialize(env.msg, env.typename)
            self.items.append((env.topic, env.time_ns, raw))

    def digest(self) -> str:
        h = hashlib.sha256()
        for topic, t, data in self.items:
            h.update(f"{topic}:{t}:".encode())
            h.update(data)
        return h.hexdigest()


def run_node(
    seq: scene.Sequence, params: LidarMapperParams, extra: list[Envelope] = ()
) -> tuple[LidarMapperNode, Recorder]:
    ex = Executor()
    node = LidarMapperNode(params)
    ex.add_node(node)
    rec = Recorder()
    ex.add_sink(rec)
    ex.add_source(scene.envelopes(seq, extra))
    ex.run()
    ex.finish()
    return node, rec


def initial_pose_params(seq: scene.Sequence, **odometry) -> LidarMapperParams:
    g = seq.ground_truth([seq.frames[0].stamp_ns])[0]
    rpy = Rotation.from_matrix(g[:3, :3]).as_euler("xyz")
    return LidarMapperParams(initial_pose=(*g[:3, 3], *rpy), odometry=LidarOdometryParams(**odometry))


def ate_rmse(stamps: np.ndarray, poses: np.ndarray, seq: scene.Sequence) -> float:
    gt = seq.ground_truth(stamps)
    return float(np.sqrt(np.mean(np.sum((poses[:, :3, 3] - gt[:, :3, 3]) ** 2, axis=1))))


def share_within(points: np.ndarray, tau: float, mesh_scene) -> float:
    d = mesh_scene.compute_distance(o3d.core.Tensor(np.asarray(points, dtype=np.float32))).numpy()
    return float(np.mean(d <= tau))
