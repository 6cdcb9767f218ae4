"""Trajectories: odometry topics (and a replay's TUM file) as a 3D path plus a pose arrow over time, and a SLAM
replay's loop closures as segments between the keyframes they join.

Paths carry no text labels (they would pile up where the robot stands and where tours end): each
topic keeps one colour in every view, and the speed plot's legend names them. The TUM file of a
replay whose own trajectory topic is drawn is a thinner line (it is the same estimate).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from navlog.analysis.view.context import COLORS, ViewContext, entity_name, trajectory_role
from navlog.replay.geometry import unit_quats_to_matrices


def yaw_vectors(q_xyzw: np.ndarray, length: float) -> np.ndarray:
    """(N, 3) arrows of ``length`` along each orientation's x axis (the first column of its rotation)."""
    q = np.asarray(q_xyzw, dtype=np.float64).reshape(-1, 4)
    return unit_quats_to_matrices(q)[:, :, 0] * length


@dataclass
class PoseRows:
    """The poses of one topic: frame, child frame, log times, positions, quaternions, planar speed."""

    frame: str = ""
    child: str = ""
    t: list[int] = field(default_factory=list)
    xyz: list[tuple[float, float, float]] = field(default_factory=list)
    q: list[tuple[float, float, float, float]] = field(default_factory=list)
    speed: list[float] = field(default_factory=list)


class Trajectories:
    """Odometry topics by name; drawn under ``trajectories/`` in their header frames."""

    def __init__(self, ctx: ViewContext) -> None:
        self.ctx = ctx
        self.topics: dict[str, PoseRows] = {}
        # name -> (frame, (N, 2, 3) segments): a pose graph's loop closures, each joining two keyframes
        self.loops: dict[str, tuple[str, np.ndarray]] = {}
        self.pose_topics: set[str] = set()  # estimates with a covariance (``on_pose``), not odometry

    def on_odom(self, topic: str, t: int, msg: Any) -> None:
        o = self.topics.setdefault(
            topic, PoseRows(frame=self.ctx.frame(msg.header.frame_id), child=self.ctx.frame(msg.child_frame_id))
        )
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        lin = msg.twist.twist.linear
        o.t.append(t)
        o.xyz.append((p.x, p.y, p.z))
        o.q.append((q.x, q.y, q.z, q.w))
        o.speed.append(math.hypot(lin.x, lin.y))

    def on_pose(self, topic: str, t: int, msg: Any) -> None:
        """A pose estimate with its covariance (PoseWithCovarianceStamped: AMCL's, the SLAM's), without a speed."""
        o = self.topics.setdefault(topic, PoseRows(frame=self.ctx.frame(msg.header.frame_id), child=""))
        self.pose_topics.add(topic)
        p, q = msg.pose.pose.position, msg.pose.pose.orientation
        o.t.append(t)
        o.xyz.append((p.x, p.y, p.z))
        o.q.append((q.x, q.y, q.z, q.w))

    def role(self, topic: str) -> str:
        """The colour role of a drawn trajectory (``trajectory_role``): trajectory.tum is the white copy
        (``replay_file``) of the replay's odometry topic (the 3D mapper's /Odometry) when the replay has one; else
        (a SLAM's final poses, beside the /pose it published as it went) it is the replay's estimate."""
        role = trajectory_role(topic)
        if role == "replay_file" and not any(
            trajectory_role(k) == "replay" and k not in self.pose_topics for k in self.topics
        ):
            return "replay"
        return role

    def send(self) -> None:
        ctx, rr = self.ctx, self.ctx.rr
        for topic, o in sorted(self.topics.items()):
            if not o.t:
                continue
            role = self.role(topic)
            color = COLORS[role]
            copy = role == "replay_file"  # drawn thin over the estimate it copies
            base = f"trajectories/{entity_name(topic)}"
            xyz = np.asarray(o.xyz, dtype=np.float32)
            line = ctx.entity(f"{base}/path")
            ctx.set_frame(line, o.frame)
            ctx.rec.log(line, rr.LineStrips3D([xyz], radii=0.005 if copy else 0.01, colors=[color]), static=True)
            pose = ctx.entity(f"{base}/pose")
            ctx.set_frame(pose, o.frame)
            ctx.rec.send_columns(
                pose,
                indexes=[ctx.time_column(o.t)],
                columns=rr.Arrows3D.columns(origins=xyz, vectors=yaw_vectors(np.asarray(o.q), 0.3).astype(np.float32)),
            )
            ctx.rec.log(pose, rr.Arrows3D.from_fields(colors=[color], radii=0.015), static=True)
            ctx.summary.drawn[topic] = base
        for name, (frame, segments) in sorted(self.loops.items()):
            ent = ctx.entity(f"trajectories/{entity_name(name)}/loops")
            ctx.set_frame(ent, frame)
            ctx.rec.log(ent, rr.LineStrips3D(segments, radii=0.01, colors=[COLORS["loop"]]), static=True)
            ctx.summary.drawn[name] = ent
