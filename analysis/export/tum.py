"""Exporting a trajectory as a TUM file (``t x y z qx qy qz qw``, the format evo and KISS-ICP read).

``export_tum`` takes the poses of an Odometry, PoseStamped, PoseWithCovarianceStamped or Path topic,
or of a TF chain (the pose of a source frame in a target frame at every /tf update on the chain),
stamped by header or log time, sorted by time (a repeated stamp keeps its first pose), and writes
them with ``navlog.replay.io.tum``'s formatting under a temporary name, renamed when complete.
"""

from __future__ import annotations

import logging
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from navlog.analysis.export.selection import check_output, time_window
from navlog.errors import NavlogError
from navlog.replay import messages
from navlog.replay.config import suggest
from navlog.replay.geometry import matrix_to_quat
from navlog.replay.io import LogReader
from navlog.replay.io.atomic import check_not_input, write_file
from navlog.replay.io.tum import format_rows

__all__ = ["TUM_TYPES", "TumSummary", "export_tum", "trajectory_from_rows"]

log = logging.getLogger("navlog")

POSE_COV_STAMPED = "geometry_msgs/msg/PoseWithCovarianceStamped"
TUM_TYPES = (messages.ODOMETRY, messages.POSE_STAMPED, POSE_COV_STAMPED, messages.PATH)


@dataclass
class TumSummary:
    path: Path
    source: str
    poses: int = 0
    skipped: Counter = field(default_factory=Counter)


def trajectory_from_rows(rows: Iterable[tuple[int, tuple, tuple]]) -> tuple[Any, int]:
    """A Trajectory from (stamp ns, xyz, q xyzw) rows, sorted by time; a repeated stamp keeps its first pose.

    Returns (trajectory, number of dropped repeats).
    """
    from navlog.analysis.metrics.trajectory import Trajectory

    ordered = sorted(enumerate(rows), key=lambda r: (r[1][0], r[0]))
    times: list[int] = []
    pos: list[tuple[float, ...]] = []
    quat: list[tuple[float, ...]] = []
    dropped = 0
    for _, (t, xyz, q) in ordered:
        if times and t == times[-1]:
            dropped += 1
            continue
        times.append(int(t))
        pos.append(tuple(float(v) for v in xyz))
        quat.append(tuple(float(v) for v in q))
    return Trajectory(np.asarray(times, dtype=np.int64), np.asarray(pos), np.asarray(quat)), dropped


def _pose_rows(reader: LogReader, topic: str, typename: str, use_header: bool, start_ns, end_ns) -> list:
    rows = []
    last_path = None
    for env in reader.messages([topic], start_ns=start_ns, end_ns=end_ns):
        msg = env.msg
        if typename == messages.PATH:
            last_path = env
            continue
        pose = msg.pose.pose if typename in (messages.ODOMETRY, POSE_COV_STAMPED) else msg.pose
        t = messages.to_ns(msg.header.stamp) if use_header else env.time_ns
        p, q = pose.position, pose.orientation
        rows.append((t, (p.x, p.y, p.z), (q.x, q.y, q.z, q.w)))
    if last_path is not None:  # a Path is a whole trajectory: the last one is the most complete
        for ps in last_path.msg.poses:
            t = messages.to_ns(ps.header.stamp) if use_header else last_path.time_ns
            p, q = ps.pose.position, ps.pose.orientation
            rows.append((t, (p.x, p.y, p.z), (q.x, q.y, q.z, q.w)))
    return rows


def _tf_rows(
    reader: LogReader, target: str, source: str, frame_prefix: str, use_header: bool, start_ns, end_ns, skipped: Counter
) -> list:
    from navlog.replay.runtime.tf import TFBuffer, TransformError

    tf_topics = [t for t in ("/tf_static", "/tf") if t in reader.topics]
    if "/tf" not in tf_topics:
        raise NavlogError(f"{reader.path}: no /tf topic; a TF chain needs one")
    buf = TFBuffer(cache_ns=1 << 62, frame_prefix=frame_prefix, skipped=skipped)

    def name(frame: str) -> str:
        f = frame.lstrip("/")
        return f[len(frame_prefix) :] if frame_prefix and f.startswith(frame_prefix) else f

    parent: dict[str, str] = {}
    samples: list[tuple[int, list[tuple[str, int]]]] = []  # (log time, [(child, stamp)])
    for env in reader.messages(tf_topics):
        static = env.topic == "/tf_static"
        buf.add_message(env.msg, static=static)
        for ts in env.msg.transforms:
            parent[name(ts.child_frame_id)] = name(ts.header.frame_id)
        if not static:
            samples.append(
                (env.time_ns, [(name(ts.child_frame_id), messages.to_ns(ts.header.stamp)) for ts in env.msg.transforms])
            )
    frames = buf.frames()
    for f in (target, source):
        if name(f) not in frames:
            raise NavlogError(
                f"--tf: frame {f!r} is not in the TF tree of {reader.path}{suggest(f, frames)}; frames: {', '.join(frames)}"
            )
    try:
        buf.lookup(target, source, None)
    except TransformError as exc:
        raise NavlogError(f"--tf {target}:{source}: {exc}") from None

    def up(frame: str) -> list[str]:
        out = [frame]
        while out[-1] in parent and parent[out[-1]] not in out:
            out.append(parent[out[-1]])
        return out

    chain = set(up(name(source))) ^ set(up(name(target)))  # the edges between the two frames, by child
    rows = []
    for t_log, updates in samples:
        stamp = next((st for child, st in updates if child in chain), None)
        if stamp is None:
            continue
        if (start_ns is not None and t_log < start_ns) or (end_ns is not None and t_log > end_ns):
            continue
        try:
            m = buf.lookup(target, source, stamp)
        except TransformError:
            skipped["TF chain not available at a /tf stamp"] += 1
            continue
        rows.append((stamp if use_header else t_log, tuple(m[:3, 3]), matrix_to_quat(m[:3, :3])))
    return rows


def export_tum(
    reader: LogReader,
    out: Path | str,
    *,
    topic: str | None = None,
    tf: tuple[str, str] | None = None,
    time_source: str = "header",
    start_s: float | None = None,
    end_s: float | None = None,
    frame_prefix: str = "",
    force: bool = False,
) -> TumSummary:
    """Write a TUM trajectory from a pose topic or a TF chain (target, source): the pose of source in target."""
    out = Path(out)
    if (topic is None) == (tf is None):
        raise NavlogError("TUM export needs exactly one of --topic TOPIC or --tf TARGET:SOURCE")
    if time_source not in ("header", "log"):
        raise NavlogError(f"--time {time_source}: choose header or log")
    check_not_input(out, [reader.path])
    check_output(out, force)
    start_ns, end_ns = time_window(reader, start_s, end_s)
    use_header = time_source == "header"
    skipped: Counter = Counter()
    if topic is not None:
        info = reader.topics.get(topic)
        if info is None:
            names = sorted(reader.topics)
            raise NavlogError(
                f"--topic {topic}: not in {reader.path}{suggest(topic, names)}; it has {', '.join(names) or 'none'}"
            )
        if info.typename not in TUM_TYPES:
            raise NavlogError(
                f"--topic {topic}: type {info.typename} has no pose; use an Odometry, PoseStamped, "
                f"PoseWithCovarianceStamped or Path topic, or --tf TARGET:SOURCE"
            )
        rows = _pose_rows(reader, topic, info.typename, use_header, start_ns, end_ns)
        source = topic
    else:
        assert tf is not None  # exactly one of topic and tf, checked above
        rows = _tf_rows(reader, tf[0], tf[1], frame_prefix, use_header, start_ns, end_ns, skipped)
        source = f"tf {tf[0]} <- {tf[1]}"
    if not rows:
        raise NavlogError(f"{reader.path}: no pose from {source} in the chosen time window; nothing written")

    traj, dropped = trajectory_from_rows(rows)
    if dropped:
        skipped["repeated timestamp"] += dropped
        log.warning("%s: dropped %d poses with a repeated timestamp", source, dropped)
    write_file(out, format_rows(traj.times_ns, traj.positions, traj.quaternions))
    return TumSummary(out, source, len(traj.times_ns), skipped)
