"""Goals and waypoints as labelled arrows under ``goals/``.

Goals (PoseStamped, PoseWithCovarianceStamped) accumulate: at each goal's time the arrows of every
goal so far are drawn, labelled with the detail of the goal event that follows within a second.
Waypoints (PoseArray, or a Path on a topic named like ``*waypoint*``) are drawn per message.
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any

import numpy as np

from navlog.analysis.view.context import COLORS, ViewContext, entity_name
from navlog.analysis.view.plans import path_positions
from navlog.analysis.view.trajectories import yaw_vectors

# the kinds of goal event that end a goal: the previous goal's end shares the next goal's stamp
GOAL_END_WORDS = ("succeeded", "reached", "failed", "aborted", "canceled", "cancelled")


def goal_labels(goals: list, events: list[tuple[int, str, str]]) -> list[str]:
    """'goal N' plus the detail of the goal event that starts it (accepted, sent) within a second, if any.

    An event that ends a goal (``GOAL_END_WORDS``) names the goal before when it shares the next goal's
    stamp (the navigator ends one goal and accepts the next in the same tick), so it labels a goal
    only when no starting event does; each event labels one goal."""
    labels = []
    used: set[int] = set()
    for i, (t, _, xyz, _) in enumerate(goals):
        label = f"goal {i + 1} ({xyz[0]:.2f}, {xyz[1]:.2f})"
        near = [
            k
            for k, (te, text, _) in enumerate(events)
            if k not in used and t <= te <= t + 1_000_000_000 and text.lower().startswith("goal") and ": " in text
        ]
        starts = [k for k in near if not any(w in events[k][1].split(" ", 1)[0].lower() for w in GOAL_END_WORDS)]
        chosen = (starts or near)[:1]
        for k in chosen:
            used.add(k)
            label = f"goal {i + 1}: {events[k][1].split(': ', 1)[1]}"
        labels.append(label)
    return labels


class Goals:
    """Goal poses and waypoint lists by topic."""

    def __init__(self, ctx: ViewContext) -> None:
        self.ctx = ctx
        self.goals: dict[str, list] = defaultdict(list)  # (t, frame, xyz, q)
        self.waypoints: dict[str, list] = defaultdict(list)  # (t, frame, (N, 3) xyz, (N, 4) q)

    def on_goal(self, topic: str, t: int, msg: Any) -> None:
        pose = msg.pose.pose if hasattr(msg.pose, "pose") else msg.pose
        p, q = pose.position, pose.orientation
        self.goals[topic].append((t, self.ctx.frame(msg.header.frame_id), (p.x, p.y, p.z), (q.x, q.y, q.z, q.w)))

    def on_waypoints(self, topic: str, t: int, msg: Any) -> None:
        xyz = np.array([(p.position.x, p.position.y, p.position.z) for p in msg.poses], dtype=np.float32).reshape(-1, 3)
        q = np.array([(p.orientation.x, p.orientation.y, p.orientation.z, p.orientation.w) for p in msg.poses]).reshape(
            -1, 4
        )
        self.waypoints[topic].append((t, self.ctx.frame(msg.header.frame_id), xyz, q))

    def on_path(self, topic: str, t: int, msg: Any) -> None:
        """A Path on a waypoint topic is a waypoint list (it is drawn as a plan too)."""
        if "waypoint" not in topic.lower():
            return
        q = np.array(
            [
                (ps.pose.orientation.x, ps.pose.orientation.y, ps.pose.orientation.z, ps.pose.orientation.w)
                for ps in msg.poses
            ]
        ).reshape(-1, 4)
        self.waypoints[topic].append((t, self.ctx.frame(msg.header.frame_id), path_positions(msg), q))

    def send(self, events: list[tuple[int, str, str]]) -> None:
        """Draw the goals (labelled from ``events``: (time, text, level)) and the waypoints."""
        ctx, rr = self.ctx, self.ctx.rr
        for topic, goals in sorted(self.goals.items()):
            ent = ctx.entity(f"goals/{entity_name(topic)}")
            ctx.set_frame(ent, goals[0][1])
            labels = goal_labels(goals, events)
            for k, (t, _, _, _) in enumerate(goals):
                ctx.set_time(t)
                origins = np.array([g[2] for g in goals[: k + 1]], dtype=np.float32)
                vecs = yaw_vectors(np.array([g[3] for g in goals[: k + 1]]), 0.5).astype(np.float32)
                ctx.rec.log(
                    ent,
                    rr.Arrows3D(
                        origins=origins, vectors=vecs, labels=labels[: k + 1], colors=[COLORS["goal"]], radii=0.03
                    ),
                )
            ctx.summary.drawn[topic] = ent
        for topic, items in sorted(self.waypoints.items()):
            ent = ctx.entity(f"goals/{entity_name(topic)}")
            ctx.set_frame(ent, items[0][1])
            for t, _, xyz, q in items:
                ctx.set_time(t)
                labels = [f"wp {i + 1}" for i in range(len(xyz))]
                ctx.rec.log(
                    ent,
                    rr.Arrows3D(
                        origins=xyz,
                        vectors=yaw_vectors(q, 0.5).astype(np.float32),
                        labels=labels,
                        colors=[COLORS["waypoint"]],
                        radii=0.03,
                    ),
                )
            ctx.summary.drawn[topic] = ent
