"""The pose graph of keyframes: Pose2 nodes, relative-pose edges, optimised by gtsam.

Edges are gtsam ``BetweenFactorPose2`` factors with Gaussian noise (diagonal standard deviations, or a
full covariance: a scan match pins some directions better than others); loop closures sit behind a
robust kernel (Huber or Cauchy), so one wrong closure bends the graph less than a right one pulls it,
and ``remove_last_edge`` takes back a closure the optimised graph disagrees with. The first node is anchored by a tight prior. ``optimize`` runs gtsam's Levenberg-Marquardt
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
        self._gaussians: list[gtsam.noiseModel.Base] = []  # per edge, its noise without the robust kernel
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
        noise,
        kind: EdgeKind,
        *,
        response: float = 0.0,
        kernel: Literal["huber", "cauchy", "none"] = "none",
        kernel_k: float = 1.345,
    ) -> None:
        """An edge measuring ``target``'s pose in ``source``'s frame. ``noise``: three standard deviations
        (x, y, yaw) or a (3, 3) covariance, in ``target``'s frame (where gtsam's ``BetweenFactorPose2``
        measures the error); behind a robust ``kernel`` (Huber or Cauchy, threshold ``kernel_k`` standard
        deviations) unless ``none``."""
        rel = tuple(float(v) for v in relative)
        arr = np.asarray(noise, dtype=np.float64)
        model: gtsam.noiseModel.Base = (
            gtsam.noiseModel.Gaussian.Covariance(arr) if arr.ndim == 2 else gtsam.noiseModel.Diagonal.Sigmas(arr)
        )
        self._gaussians.append(model)
        if kernel == "huber":
            model = gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Huber.Create(kernel_k), model)
        elif kernel == "cauchy":
            model = gtsam.noiseModel.Robust.Create(gtsam.noiseModel.mEstimator.Cauchy.Create(kernel_k), model)
        self._graph.add(gtsam.BetweenFactorPose2(source, target, gtsam.Pose2(*rel), model))
        self.edges.append(Edge(source, target, kind, (rel[0], rel[1], rel[2]), float(response)))

    def edge_chi2(self, k: int = -1) -> float:
        """Squared whitened (Mahalanobis) error of edge ``k`` at the current estimate, before any kernel."""
        e = self.edges[k]
        measured = gtsam.Pose2(*e.relative)
        actual = self._values.atPose2(e.source).between(self._values.atPose2(e.target))
        err = measured.localCoordinates(actual)
        return float(np.sum(np.square(self._gaussians[k].whiten(err))))

    def snapshot(self) -> gtsam.Values:
        """The current estimate, to ``remove_last_edge`` back to."""
        return gtsam.Values(self._values)

    def remove_last_edge(self, restore: gtsam.Values) -> None:
        """Drop the newest edge and return the estimate to ``restore`` (a ``snapshot``)."""
        graph = gtsam.NonlinearFactorGraph()
        for i in range(self._graph.size() - 1):
            graph.add(self._graph.at(i))
        self._graph = graph
        self.edges.pop()
        self._gaussians.pop()
        self._values = restore

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
        """(n, 3) current poses, read in one call (gtsam's ``extractPose2``, the nodes in key order): the
        loop search and the map read them at every keyframe, and a Python loop over the nodes would make
        that work grow with the square of the travel."""
        return np.asarray(gtsam.utilities.extractPose2(self._values), dtype=np.float64).reshape(-1, 3)
