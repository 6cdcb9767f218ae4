"""Events and text topics as text logs: navlog's navigation events under ``events``, std_msgs/String
and rcl_interfaces/Log (``/rosout``) topics under ``text/``.

A collision-monitor event reads "<polygon>: <action> started" or "... ended"; a stop starting is a
warning (so is any other event whose kind speaks of failure, abort, collision, stop or error)."""

from __future__ import annotations

from collections import defaultdict
from typing import Any

from navlog.analysis.view.context import ViewContext, entity_name

ROSOUT_LEVELS = {10: "DEBUG", 20: "INFO", 30: "WARN", 40: "ERROR", 50: "CRITICAL"}
MONITOR_PREFIX = "collision_monitor_"


def monitor_event_text(kind: str, polygon: str) -> tuple[str, str]:
    """A collision-monitor event as (text, level): the polygon first, then its action; a stop is a
    warning, its end and the other actions information."""
    action = kind[len(MONITOR_PREFIX) :]
    ended = action.endswith("_end")
    action = action.removesuffix("_end")
    text = f"{polygon or '?'}: {action} {'ended' if ended else 'started'} (collision monitor)"
    return text, "WARN" if action == "stop" and not ended else "INFO"


class Events:
    """Navigation events (time, text, level) in arrival order, and text topics by name."""

    def __init__(self, ctx: ViewContext) -> None:
        self.ctx = ctx
        self.events: list[tuple[int, str, str]] = []
        self.texts: dict[str, list[tuple[int, str, str]]] = defaultdict(list)

    def on_event(self, topic: str, t: int, msg: Any) -> None:
        if msg.kind.startswith(MONITOR_PREFIX):
            self.events.append((t, *monitor_event_text(msg.kind, msg.detail)))
        else:
            text = f"{msg.kind} [{msg.source}]"
            if msg.detail:
                text += f": {msg.detail}"
            if msg.value:
                text += f" ({msg.value:g})"
            bad = any(w in msg.kind.lower() for w in ("fail", "abort", "collision", "stop", "error"))
            self.events.append((t, text, "WARN" if bad else "INFO"))
        self.ctx.summary.drawn[topic] = self.ctx.entity("events")

    def on_text(self, topic: str, t: int, msg: Any) -> None:
        if hasattr(msg, "msg"):  # rcl_interfaces/Log (/rosout)
            level = ROSOUT_LEVELS.get(int(msg.level), "INFO")
            self.texts[topic].append((t, f"[{msg.name}] {msg.msg}", level))
        else:
            self.texts[topic].append((t, str(msg.data), "INFO"))

    def send(self) -> None:
        ctx, rr = self.ctx, self.ctx.rr
        for topic, rows in sorted(self.texts.items()):
            ent = ctx.entity(f"text/{entity_name(topic)}")
            ctx.rec.send_columns(
                ent,
                indexes=[ctx.time_column([r[0] for r in rows])],
                columns=rr.TextLog.columns(text=[r[1] for r in rows], level=[r[2] for r in rows]),
            )
            ctx.summary.drawn[topic] = ent
        if not self.events:
            return
        ent = ctx.entity("events")
        ev = sorted(self.events, key=lambda e: e[0])
        ctx.rec.send_columns(
            ent,
            indexes=[ctx.time_column([e[0] for e in ev])],
            columns=rr.TextLog.columns(text=[e[1] for e in ev], level=[e[2] for e in ev]),
        )
