"""The pose graph of keyframes: Pose2 nodes, relative-pose edges, optimised by gtsam.

Edges are gtsam ``BetweenFactorPose2`` factors with diagonal noise (x, y, yaw standard deviations);
loop closures sit behind a Huber kernel, so one wrong closure bends the graph less than a right one
pulls it. The first node is anchored by a tight prior. ``optimize`` runs gtsam's Levenberg-Marquardt
on the whole graph from the current estimate (deterministic: the same graph gives the same poses).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import gtsam
import numpy as np

EdgeKind = Literal["match", "odometry", "loop"]
PRIOR_SIGMAS = (1e-6, 1e-6, 1e-6)


@dataclass(frozen=True)
class Edge:
    source: int  # node the measurement is expressed in
    target: int
    kind: EdgeKind
    relative: tuple[float, float, float]  # target's pose in source's frame (x, y, yaw)
    response: float  # the scan match's response (0 for odometry)


class PoseGraph:
    """Nodes 0..n-1 (planar poses) and the edges between them."""

    def __init__(self) -> None:
        self._graph = gtsam.NonlinearFactorGraph()
        self._values = gtsam.Values()
        self.edges: list[Edge] = []
        self.optimizations = 0

    def __len__(self) -> int:
        return int(self._values.size())

    def add_node(self, pose) -> int:
        """A new node at ``pose`` (x, y, yaw); the first one is anchored there."""
        i = len(self)
        p = gtsam.Pose2(*(float(v) for v in pose))
        self._values.insert(i, p)
        if i == 0:
            self._graph.add(gtsam.PriorFactorPose2(0, p, gtsam.noiseModel.Diagonal.Sigmas(np.array(PRIOR_SIGMAS))))
        return i

    def add_edge(
        self,
        source: int,
        target: int,
        relative,
        sigmas,
        kind: EdgeKind,
        *,
        response: float = 0.0,
        huber_k: float | None = None,
    ) -> None:
        """An edge measuring ``target``'s pose in ``source``'s frame; robust (Huber) when ``huber_k`` is set."""
        rel = tuple(float(v) for v in relative)
        noise: gtsam.noiseModel.Base = gtsam.noiseModel.Diagonal.Sigmas(np.asarray(sigmas, dtype=np.float64))
        if huber_k is not None:
            noise = gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Huber.Create(huber_k), noise)
        self._graph.add(gtsam.BetweenFactorPose2(source, target, gtsam.Pose2(*rel), noise))
        self.edges.append(Edge(source, target, kind, (rel[0], rel[1], rel[2]), float(response)))

    def optimize(self) -> None:
        """Levenberg-Marquardt on the whole graph; the result becomes the current estimate."""
        params = gtsam.LevenbergMarquardtParams()
        params.setMaxIterations(100)
        params.setRelativeErrorTol(1e-8)
        params.setAbsoluteErrorTol(1e-10)
        self._values = gtsam.LevenbergMarquardtOptimizer(self._graph, self._values, params).optimize()
        self.optimizations += 1

    def pose(self, i: int) -> np.ndarray:
        p = self._values.atPose2(i)
        return np.array([p.x(), p.y(), p.theta()])

    def poses(self) -> np.ndarray:
        """(n, 3) current poses."""
        return np.array([self.pose(i) for i in range(len(self))]).reshape(-1, 3)

    def error(self) -> float:
        """The graph's total (robust) squared error at the current estimate."""
        return float(self._graph.error(self._values))
