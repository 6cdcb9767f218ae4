"""Paths (nav_msgs/Path): plans under ``plans/``, other paths (a mapper's estimated path) under ``paths/``.

A Path topic whose name speaks of a plan or waypoints (``/plan``, ``/local_plan``,
``/transformed_global_plan``, ``/waypoints``) is a plan: each message a 3D line strip over time, in
the plan colour (a local plan in its own). Any other Path topic (``/lidar_mapper/path``, ``/trajectory``)
is an estimated trajectory: drawn the same way, thinner, in the colour of its estimate, and left out
of the top-down view, which draws trajectories from odometry.

In 3D both are drawn ``PATH_LIFT_M`` above their poses: a plan lies on the floor (z = 0), where the
costmaps are drawn just above the map (``grids.COSTMAP_LIFT_M``) and would hide it.
"""

from __future__ import annotations

from collections import defaultdict
from typing import Any

import numpy as np

from navlog.analysis.view.context import COLORS, ViewContext, entity_name, trajectory_role
from navlog.analysis.view.grids import COSTMAP_LIFT_M

# m above a path's poses in 3D: above the highest costmap, so that the plans on the floor show
PATH_LIFT_M = max(COSTMAP_LIFT_M.values()) + 0.03


def path_positions(msg: Any) -> np.ndarray:
    """(N, 3) float32 positions of a Path's poses."""
    return np.array(
        [(ps.pose.position.x, ps.pose.position.y, ps.pose.position.z) for ps in msg.poses], dtype=np.float32
    ).reshape(-1, 3)


def is_plan(topic: str) -> bool:
    """True for a Path topic that holds a plan or waypoints rather than an estimated trajectory."""
    name = topic.lower()
    return "plan" in name or "waypoint" in name


class Plans:
    """Path topics: (log time, frame, positions) per message; plans and other paths apart."""

    def __init__(self, ctx: ViewContext) -> None:
        self.ctx = ctx
        self.topics: dict[str, list] = defaultdict(list)  # plans
        self.paths: dict[str, list] = defaultdict(list)  # estimated paths

    def on_path(self, topic: str, t: int, msg: Any) -> None:
        rows = self.topics if is_plan(topic) else self.paths
        rows[topic].append((t, self.ctx.frame(msg.header.frame_id), path_positions(msg)))

    def send(self) -> None:
        for topic, items in sorted(self.topics.items()):
            color = COLORS["local_plan" if "local" in topic.lower() else "plan"]
            self._send(f"plans/{entity_name(topic)}", topic, items, color, 0.02)
        for topic, items in sorted(self.paths.items()):
            self._send(f"paths/{entity_name(topic)}", topic, items, COLORS[trajectory_role(topic)], 0.01)

    def _send(self, path: str, topic: str, items: list, color: tuple[int, int, int], radius: float) -> None:
        ctx, rr = self.ctx, self.ctx.rr
        if not items:
            return
        ent = ctx.entity(path)
        ctx.set_frame(ent, items[0][1])
        ctx.rec.send_columns(
            ent,
            indexes=[ctx.time_column([i[0] for i in items])],
            columns=rr.LineStrips3D.columns(
                strips=[i[2][:, :3] + np.array([0, 0, PATH_LIFT_M], dtype=np.float32) for i in items]
            ),
        )
        ctx.rec.log(ent, rr.LineStrips3D.from_fields(colors=[color], radii=radius), static=True)
        if len({i[1] for i in items}) > 1:
            ctx.summary.warnings.append(f"{topic}: frame_id changes; drawn in {items[0][1]}")
        ctx.summary.drawn.setdefault(topic, ent)
