"""Plans (nav_msgs/Path): each message a 3D line strip over time under ``plans/``."""

from __future__ import annotations

from collections import defaultdict
from typing import Any

import numpy as np

from navlog.analysis.view.context import COLORS, ViewContext, entity_name


def path_positions(msg: Any) -> np.ndarray:
    """(N, 3) float32 positions of a Path's poses."""
    return np.array(
        [(ps.pose.position.x, ps.pose.position.y, ps.pose.position.z) for ps in msg.poses], dtype=np.float32
    ).reshape(-1, 3)


class Plans:
    """Path topics: (log time, frame, positions) per message."""

    def __init__(self, ctx: ViewContext) -> None:
        self.ctx = ctx
        self.topics: dict[str, list] = defaultdict(list)

    def on_path(self, topic: str, t: int, msg: Any) -> None:
        self.topics[topic].append((t, self.ctx.frame(msg.header.frame_id), path_positions(msg)))

    def send(self) -> None:
        ctx, rr = self.ctx, self.ctx.rr
        for topic, items in sorted(self.topics.items()):
            if not items:
                continue
            ent = ctx.entity(f"plans/{entity_name(topic)}")
            ctx.set_frame(ent, items[0][1])
            ctx.rec.send_columns(
                ent,
                indexes=[ctx.time_column([i[0] for i in items])],
                columns=rr.LineStrips3D.columns(strips=[i[2][:, :3] for i in items]),
            )
            ctx.rec.log(ent, rr.LineStrips3D.from_fields(colors=[COLORS["plan"]], radii=0.02), static=True)
            if len({i[1] for i in items}) > 1:
                ctx.summary.warnings.append(f"{topic}: frame_id changes; drawn in {items[0][1]}")
            ctx.summary.drawn.setdefault(topic, ent)
