"""The pose graph of keyframes: Pose2 nodes, relative-pose edges, optimised by gtsam's iSAM2.

Edges are gtsam ``BetweenFactorPose2`` factors with Gaussian noise (diagonal standard deviations, or a
full covariance: a scan match pins some directions better than others); loop closures sit behind a
robust kernel (Huber or Cauchy), so one wrong closure bends the graph less than a right one pulls it,
and ``remove_last_edge`` takes back a closure the optimised graph disagrees with. The first node is
anchored by a tight prior.

Nodes and edges wait until ``optimize``, which hands them to iSAM2 (Kaess et al. 2012) and updates
until no variable is relinearised (at most ``MAX_UPDATES`` updates): iSAM2 re-eliminates only the
part of the graph a new edge touches, where a batch optimiser would solve the whole graph at every
closure and its cost would grow with the travel. Variables are checked for relinearisation from the
Bayes tree's root down, and the check stops below a variable whose update stays under
``RELINEARIZE_THRESHOLD`` (gtsam's partial check): a closure that moves a long loop does not
relinearise every pose of it at every update. Deeper variables then keep an older linearisation
point; the tests hold the result to gtsam's batch optimum of the same graph. Between optimisations the
estimate of a new node is the pose it was added at. iSAM2 factorises by Cholesky; where that finds
the system indeterminate (an edge that pins almost nothing, a yaw left free by a round room, with no
loop around it), the graph goes whole to a new iSAM2 that factorises by QR, and stays there.
Deterministic: the same nodes and edges in the same order give the same poses.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import gtsam
import numpy as np

from navlog.replay.mapping.slam2d.rows import Rows

EdgeKind = Literal["match", "odometry", "loop"]
# what found a loop edge: the new scan's own match in the loop square, the running buffer's surfaces in the same
# square (the scan's own match left the place ambiguous), or the global search
ClosedBy = Literal["", "scan", "buffer", "global"]
PRIOR_SIGMAS = (1e-6, 1e-6, 1e-6)
# iSAM2 relinearises a variable whose update exceeds this (metres and radians of its tangent space; below
# one that does not, the check stops)...
RELINEARIZE_THRESHOLD = 0.001
# ...and ``optimize`` repeats the update while any variable was relinearised, this many times at most
MAX_UPDATES = 10


@dataclass(frozen=True)
class Edge:
    source: int  # node the measurement is expressed in
    target: int
    kind: EdgeKind
    relative: tuple[float, float, float]  # target's pose in source's frame (x, y, yaw)
    response: float  # the scan match's response (0 for odometry)
    closed_by: ClosedBy = ""  # a loop edge's search (``ClosedBy``); empty for the others


class PoseGraph:
    """Nodes 0..n-1 (planar poses) and the edges between them."""

    def __init__(self) -> None:
        self._isam = _isam("CHOLESKY")
        self._qr = False  # whether the graph moved to a QR-factorising iSAM2
        self._prior: gtsam.PriorFactorPose2 | None = None
        self._factors: list[gtsam.BetweenFactorPose2] = []  # per edge, its factor (to move the graph whole)
        self._new_factors = gtsam.NonlinearFactorGraph()  # waiting for the next optimisation
        self._new_values = gtsam.Values()
        self._values = gtsam.Values()  # the current estimate of every node
        self.edges: list[Edge] = []
        self._gaussians: list[gtsam.noiseModel.Base] = []  # per edge, its noise without the robust kernel
        self._slots: list[int | None] = []  # per edge, its factor's index in iSAM2 (None while waiting)
        self._prior_waiting = False
        self.optimizations = 0
        # the estimate as rows (x, y, yaw): read at every keyframe, taken from gtsam only after an optimisation
        self._rows = Rows((3,))

    def __len__(self) -> int:
        return int(self._values.size())

    def add_node(self, pose) -> int:
        """A new node at ``pose`` (x, y, yaw); the first one is anchored there."""
        i = len(self)
        p = gtsam.Pose2(*(float(v) for v in pose))
        self._values.insert(i, p)
        self._new_values.insert(i, p)
        self._rows.append((p.x(), p.y(), p.theta()))
        if i == 0:
            self._prior = gtsam.PriorFactorPose2(0, p, gtsam.noiseModel.Diagonal.Sigmas(np.array(PRIOR_SIGMAS)))
            self._new_factors.add(self._prior)
            self._prior_waiting = True
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
        closed_by: ClosedBy = "",
    ) -> None:
        """An edge measuring ``target``'s pose in ``source``'s frame. ``noise``: three standard deviations
        (x, y, yaw) or a (3, 3) covariance, in ``target``'s frame (where gtsam's ``BetweenFactorPose2``
        measures the error); behind a robust ``kernel`` (Huber or Cauchy, threshold ``kernel_k`` standard
        deviations) unless ``none``; a loop edge says what found it (``closed_by``)."""
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
        factor = gtsam.BetweenFactorPose2(source, target, gtsam.Pose2(*rel), model)
        self._new_factors.add(factor)
        self._factors.append(factor)
        self._slots.append(None)
        self.edges.append(Edge(source, target, kind, (rel[0], rel[1], rel[2]), float(response), closed_by))

    def edge_chi2(self, k: int = -1) -> float:
        """Squared whitened (Mahalanobis) error of edge ``k`` at the current estimate, before any kernel."""
        e = self.edges[k]
        measured = gtsam.Pose2(*e.relative)
        actual = self._values.atPose2(e.source).between(self._values.atPose2(e.target))
        err = measured.localCoordinates(actual)
        return float(np.sum(np.square(self._gaussians[k].whiten(err))))

    def remove_last_edge(self) -> None:
        """Drop the newest edge and optimise without it (a closure the optimised graph disagrees with)."""
        slot = self._slots.pop()
        self.edges.pop()
        self._gaussians.pop()
        self._factors.pop()
        if slot is None:  # not handed to iSAM2 yet: out of the waiting factors
            kept = gtsam.NonlinearFactorGraph()
            for i in range(self._new_factors.size() - 1):
                kept.add(self._new_factors.at(i))
            self._new_factors = kept
        self._flush([] if slot is None else [slot])

    def optimize(self) -> None:
        """Hand the waiting nodes and edges to iSAM2 and update; the result becomes the current estimate."""
        self._flush([])

    def _flush(self, remove: list[int]) -> None:
        """One iSAM2 update with the waiting nodes and edges added and the factors at ``remove`` taken out,
        then more until no variable the partial check reaches is relinearised (``MAX_UPDATES`` in all at
        most; see the module docstring); the graph moves to QR where Cholesky finds it indeterminate (gtsam
        raises ``RuntimeError``)."""
        try:
            self._update(remove)
        except RuntimeError:
            if self._qr:
                raise
            self._move_to_qr()
        self._values = self._isam.calculateEstimate()
        self._rows.view()[:] = np.asarray(gtsam.utilities.extractPose2(self._values), dtype=np.float64).reshape(-1, 3)
        self.optimizations += 1

    def _update(self, remove: list[int]) -> None:
        waiting = [k for k, slot in enumerate(self._slots) if slot is None]
        result = self._isam.update(self._new_factors, self._new_values, remove)
        added = [int(i) for i in result.getNewFactorsIndices()]
        if self._prior_waiting:  # the prior came first
            added, self._prior_waiting = added[1:], False
        for k, slot in zip(waiting, added, strict=True):
            self._slots[k] = slot
        self._new_factors, self._new_values = gtsam.NonlinearFactorGraph(), gtsam.Values()
        for _ in range(MAX_UPDATES - 1):
            if self._isam.update().getVariablesRelinearized() == 0:
                break

    def _move_to_qr(self) -> None:
        """The whole graph (the prior, every edge kept, the estimate as it stood) to a new iSAM2 that
        factorises by QR."""
        self._isam, self._qr = _isam("QR"), True
        self._new_factors = gtsam.NonlinearFactorGraph()
        if self._prior is not None:
            self._new_factors.add(self._prior)
        for factor in self._factors:
            self._new_factors.add(factor)
        self._new_values = gtsam.Values(self._values)
        self._slots = [None] * len(self._factors)
        self._prior_waiting = self._prior is not None
        self._update([])

    def pose(self, i: int) -> np.ndarray:
        """Node ``i``'s current pose (x, y, yaw), a copy."""
        return self._rows.view()[i].copy()

    def poses(self) -> np.ndarray:
        """(n, 3) current poses (x, y, yaw) in node order, a read-only view: the loop search and the map read
        them at every keyframe, so they are kept as rows (gtsam's ``extractPose2`` after each optimisation,
        a new node's pose as it is added) rather than read from gtsam each time."""
        rows = self._rows.view()
        rows.flags.writeable = False
        return rows


def _isam(factorization: str) -> gtsam.ISAM2:
    params = gtsam.ISAM2Params()
    params.setRelinearizeThreshold(RELINEARIZE_THRESHOLD)
    params.relinearizeSkip = 1
    params.enablePartialRelinearizationCheck = True
    params.setFactorization(factorization)
    return gtsam.ISAM2(params)
