"""Reading exported bags back: every message of a log or a bag as (topic, type, time, CDR bytes)."""

from __future__ import annotations

from pathlib import Path

from navlog.cli import main
from navlog.replay import messages as m
from navlog.replay.io import open_log


def source_messages(log: Path, topics=None) -> list[tuple[str, str, int, bytes]]:
    with open_log(log) as r:
        return [(e.topic, e.typename, e.time_ns, bytes(e.msg)) for e in r.messages(topics, decode=False)]


def rosbags_messages(bag: Path) -> tuple[list[tuple[str, str, int, bytes]], dict]:
    from rosbags.highlevel import AnyReader

    with AnyReader([bag], default_typestore=m.typestore()) as r:
        msgs = [(c.topic, c.msgtype, t, bytes(raw)) for c, t, raw in r.messages()]
        qos = {c.topic: c.ext.offered_qos_profiles for c in r.connections}
    return msgs, qos


def by_topic(msgs):
    out: dict[str, list] = {}
    for topic, typename, t, data in msgs:
        out.setdefault(topic, []).append((typename, t, data))
    return out


def export_bag(log: Path, out: Path, *args: str) -> int:
    """Run `navlog -q export LOG --to rosbag2 -o OUT ARGS...`; returns its exit status."""
    return main(["-q", "export", str(log), "--to", "rosbag2", "-o", str(out), *args])
