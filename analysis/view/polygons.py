"""Collision-monitor polygons (geometry_msgs/PolygonStamped) as closed line strips under ``safety/``.

Each PolygonStamped topic is an entity in its message's frame (placed through TF like every 3D
entity), one closed strip per message; a message without vertices clears it. Its colour follows
the action state of the polygon it shows, read from the collision monitor's events
(``collision_monitor_<action>`` starts an action, ``collision_monitor_<action>_end`` ends it; the
event's detail is the polygon's name): grey while idle, amber for slowdown and limit, orange for
approach, red for stop. The polygon's name is the topic's last segment (Nav2 publishes a polygon on
its name unless ``polygon_pub_topic`` says otherwise; a renamed topic stays grey). The approach
model's prediction (``/navlog/collision_monitor/<polygon>/collision_footprint``) is drawn as a
thinner, translucent orange outline: the footprint where the simulation met the obstacle.
"""

from __future__ import annotations

import bisect
from collections import defaultdict
from typing import Any

import numpy as np

from navlog.analysis.view.context import ViewContext, entity_name

EVENT_PREFIX = "collision_monitor_"
PREDICTION_PREFIX = "/navlog/collision_monitor/"
PREDICTION_SUFFIX = "/collision_footprint"
IDLE = "idle"
# action state -> RGBA
STATE_COLORS = {
    IDLE: (150, 150, 150, 255),
    "none": (150, 150, 150, 255),
    "slowdown": (255, 191, 0, 255),
    "limit": (255, 191, 0, 255),
    "approach": (255, 110, 0, 255),
    "stop": (230, 20, 20, 255),
}
PREDICTION_COLOR = (255, 110, 0, 150)
POLYGON_RADIUS = 0.012  # m: line half-width at robot scale
PREDICTION_RADIUS = 0.007
Z = 0.02  # m above the frame's ground, over the occupancy grid


def polygon_name(topic: str) -> tuple[str, bool]:
    """The polygon a topic shows and whether it is the approach prediction."""
    if topic.startswith(PREDICTION_PREFIX) and topic.endswith(PREDICTION_SUFFIX):
        return topic[len(PREDICTION_PREFIX) : -len(PREDICTION_SUFFIX)], True
    return topic.rstrip("/").rsplit("/", 1)[-1], False


def event_state(kind: str) -> str | None:
    """The state a collision-monitor event kind puts its polygon in (None: not such an event)."""
    if not kind.startswith(EVENT_PREFIX):
        return None
    action = kind[len(EVENT_PREFIX) :]
    return IDLE if action.endswith("_end") else action


def closed_strip(xy: np.ndarray) -> np.ndarray:
    """(N + 1, 3) float32 points of a closed outline at height Z."""
    pts = np.column_stack([xy, np.full(len(xy), Z)]).astype(np.float32)
    return np.vstack([pts, pts[:1]])


class Polygons:
    """PolygonStamped topics (log time, frame, (N, 2) vertices) and the polygons' action states over time."""

    def __init__(self, ctx: ViewContext) -> None:
        self.ctx = ctx
        self.topics: dict[str, list[tuple[int, str, np.ndarray]]] = defaultdict(list)
        self.states: dict[str, list[tuple[int, str]]] = defaultdict(list)  # polygon -> (time, state)

    def on_polygon(self, topic: str, t: int, msg: Any) -> None:
        xy = np.array([(p.x, p.y) for p in msg.polygon.points], dtype=np.float64).reshape(-1, 2)
        self.topics[topic].append((t, self.ctx.frame(msg.header.frame_id), xy))

    def on_event(self, topic: str, t: int, msg: Any) -> None:
        state = event_state(msg.kind)
        if state is not None and msg.detail:
            self.states[msg.detail].append((t, state))

    def state_at(self, polygon: str, times: list[int]) -> list[str]:
        """The polygon's state at each time (events at the same time count: they come first)."""
        changes = sorted(self.states.get(polygon, []), key=lambda c: c[0])
        ts = [c[0] for c in changes]
        return [changes[i - 1][1] if (i := bisect.bisect_right(ts, t)) else IDLE for t in times]

    def send(self) -> None:
        ctx, rr = self.ctx, self.ctx.rr
        for topic, rows in sorted(self.topics.items()):
            name, predicted = polygon_name(topic)
            ent = ctx.entity(f"safety/{entity_name(topic)}")
            ctx.set_frame(ent, rows[0][1])
            times = [r[0] for r in rows]
            shown = [r for r in rows if len(r[2]) >= 2]
            lengths = [1 if len(r[2]) >= 2 else 0 for r in rows]
            if predicted:
                colors = [PREDICTION_COLOR] * len(shown)
            else:
                states = self.state_at(name, [r[0] for r in shown])
                colors = [STATE_COLORS.get(s, STATE_COLORS[IDLE]) for s in states]
            strips = [closed_strip(r[2]) for r in shown]
            ctx.rec.send_columns(
                ent,
                indexes=[ctx.time_column(times)],
                columns=rr.LineStrips3D.columns(
                    strips=strips, colors=np.array(colors, dtype=np.uint8).reshape(-1, 4)
                ).partition(lengths),
            )
            radius = PREDICTION_RADIUS if predicted else POLYGON_RADIUS
            ctx.rec.log(ent, rr.LineStrips3D.from_fields(radii=radius), static=True)
            if len({r[1] for r in rows}) > 1:
                ctx.summary.warnings.append(f"{topic}: frame_id changes; drawn in {rows[0][1]}")
            ctx.summary.drawn[topic] = ent
