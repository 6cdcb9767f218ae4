"""Exporting logs: ROS 2 bags (rosbag2, sqlite3 or MCAP storage) and TUM trajectories.

``export_rosbag2`` copies every selected message's CDR bytes unchanged into a rosbag2 folder written
with ``rosbags.rosbag2.Writer``: metadata version 8 for Humble, 9 for Jazzy, transient-local QoS for
``/tf_static`` and ``/map``, receive times kept. The folder is written inside a hidden temporary
folder next to the output and moved into place only when complete.

``export_tum`` writes ``t x y z qx qy qz qw`` lines (the format evo and KISS-ICP read) from an
Odometry, PoseStamped, PoseWithCovarianceStamped or Path topic, or from a TF chain.
"""

from __future__ import annotations

import fnmatch
import logging
import os
import shutil
import tempfile
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from navlog.errors import NavlogError
from navlog.replay import messages
from navlog.replay.config import suggest
from navlog.replay.io.logreader import LogReader
from navlog.version import __version__

log = logging.getLogger("navlog")

DISTRO_VERSIONS = {"humble": 8, "jazzy": 9}
STORAGES = ("sqlite3", "mcap")
POSE_COV_STAMPED = "geometry_msgs/msg/PoseWithCovarianceStamped"
TUM_TYPES = (messages.ODOMETRY, messages.POSE_STAMPED, POSE_COV_STAMPED, messages.PATH)


@dataclass(frozen=True)
class BagOptions:
    storage: str = "sqlite3"
    distro: str = "humble"
    topics: tuple[str, ...] = ()  # names or shell patterns; empty: all
    start_s: float | None = None  # seconds from the log's first message
    end_s: float | None = None

    def validate(self) -> BagOptions:
        if self.storage not in STORAGES:
            raise NavlogError(
                f"storage {self.storage!r}: choose one of {', '.join(STORAGES)}{suggest(self.storage, STORAGES)}"
            )
        if self.distro not in DISTRO_VERSIONS:
            raise NavlogError(
                f"distro {self.distro!r}: choose one of {', '.join(DISTRO_VERSIONS)}{suggest(self.distro, DISTRO_VERSIONS)}"
            )
        _check_window(self.start_s, self.end_s)
        return self


@dataclass
class ExportSummary:
    path: Path
    topics: dict[str, tuple[str, int]] = field(default_factory=dict)  # topic -> (type, count)
    skipped: Counter = field(default_factory=Counter)
    start_ns: int = 0
    end_ns: int = 0

    @property
    def messages(self) -> int:
        return sum(c for _, c in self.topics.values())


def _check_window(start_s: float | None, end_s: float | None) -> None:
    if start_s is not None and start_s < 0:
        raise NavlogError(f"--start {start_s}: must be >= 0 (seconds from the log's first message)")
    if start_s is not None and end_s is not None and end_s < start_s:
        raise NavlogError(f"--end {end_s} is before --start {start_s}")


def time_window(reader: LogReader, start_s: float | None, end_s: float | None) -> tuple[int | None, int | None]:
    """Absolute log times (ns) of a window given in seconds from the log's first message."""
    _check_window(start_s, end_s)
    dur = reader.duration_ns / 1e9
    if start_s is not None and start_s > dur:
        raise NavlogError(f"--start {start_s}: the log {reader.path} lasts only {dur:.3f} s; nothing to export")
    s = None if start_s is None else reader.start_ns + int(round(start_s * 1e9))
    e = None if end_s is None else reader.start_ns + int(round(end_s * 1e9))
    return s, e


def select_topics(reader: LogReader, patterns: Iterable[str]) -> list[str]:
    """Topics of a log matching names or shell patterns; every pattern must match something."""
    names = sorted(reader.topics)
    patterns = [p for p in patterns if p]
    if not patterns:
        return names
    chosen: set[str] = set()
    for p in patterns:
        hits = [n for n in names if n == p or fnmatch.fnmatchcase(n, p)]
        if not hits:
            raise NavlogError(
                f"--topics {p}: matches no topic of {reader.path}{suggest(p, names)}; it has {', '.join(names) or 'none'}"
            )
        chosen.update(hits)
    return sorted(chosen)


def _qos_profiles(topic: str, source_qos: str, distro: str) -> list:
    """Offered QoS for an exported topic: transient-local reliable depth 1 for latched topics,
    otherwise the source's profile when it has one, else reliable volatile keep-last 10."""
    from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

    infinite = QosTime(9223372036, 854775807)
    default = Qos(
        QosHistory.KEEP_LAST,
        10,
        QosReliability.RELIABLE,
        QosDurability.VOLATILE,
        infinite,
        infinite,
        QosLiveliness.AUTOMATIC,
        infinite,
        False,
    )
    if topic in messages.LATCHED_TOPICS:
        return [default._replace(depth=1, durability=QosDurability.TRANSIENT_LOCAL)]
    if source_qos:
        from rosbags.rosbag2.metadata import parse_qos

        try:
            parsed = parse_qos(source_qos)
        except Exception:
            parsed = []
        if parsed:
            return parsed[:1]
    return [default]


def _type_source(reader: LogReader, typename: str):
    """A type store that can describe a type (navlog's, or the one a bag reader built from the bag)."""
    store = messages.typestore()
    if typename in store.types:
        return store
    inner = getattr(reader, "_reader", None)
    other = getattr(inner, "typestore", None)
    if other is not None and typename in other.types:
        return other
    return None


def _temp_dir_beside(out: Path) -> Path:
    return Path(tempfile.mkdtemp(prefix=f".{out.name}.", suffix=".part", dir=out.parent))


def _check_out(out: Path, force: bool) -> None:
    if out.exists() and not force:
        raise NavlogError(f"{out}: already exists; choose another name or pass --force to overwrite it")
    if not out.parent.is_dir():
        raise NavlogError(f"{out.parent}: output folder does not exist")


def _replace(tmp: Path, out: Path) -> None:
    """Move a finished output into place (replacing an old one only now)."""
    if out.exists():
        old = out.with_name(f".{out.name}.old-{os.getpid()}")
        os.replace(out, old)
        os.replace(tmp, out)
        shutil.rmtree(old) if old.is_dir() else old.unlink()
    else:
        os.replace(tmp, out)


def export_rosbag2(
    reader: LogReader, out: Path | str, options: BagOptions | None = None, *, force: bool = False
) -> ExportSummary:
    """Write the selected messages of a log as a rosbag2 folder; message bytes are copied unchanged."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    opt = (options or BagOptions()).validate()
    out = Path(out)
    _check_out(out, force)
    topics = select_topics(reader, opt.topics)
    unknown = {t: reader.topics[t].typename for t in topics if not reader.topics[t].known}
    stores = {}
    for t in topics:
        if t in unknown:
            continue
        store = _type_source(reader, reader.topics[t].typename)
        if store is None:
            unknown[t] = reader.topics[t].typename
        else:
            stores[t] = store
    if unknown:
        log.warning(
            "%s: skipping topics of unknown types: %s",
            reader.path,
            ", ".join(f"{t} ({ty})" for t, ty in sorted(unknown.items())),
        )
    topics = [t for t in topics if t not in unknown]
    if not topics:
        raise NavlogError(
            f"{reader.path}: no topic of a known type to export (unknown: {', '.join(sorted(unknown)) or 'none'})"
        )
    start_ns, end_ns = time_window(reader, opt.start_s, opt.end_s)

    summary = ExportSummary(out)
    for t, ty in unknown.items():
        summary.skipped[f"unknown type {ty} on {t}"] += reader.topics[t].count
    tmpdir = _temp_dir_beside(out)
    bag = tmpdir / out.name
    plugin = StoragePlugin.MCAP if opt.storage == "mcap" else StoragePlugin.SQLITE3
    version = DISTRO_VERSIONS[opt.distro]
    try:
        writer = Writer(bag, version=version, storage_plugin=plugin)  # type: ignore[arg-type]
        writer.set_custom_data("navlog.version", __version__)
        writer.set_custom_data("navlog.source", reader.path.name)
        writer.open()
        _stamp_distro(writer, opt.distro)
        conns: dict[str, Any] = {}
        first = last = None
        try:
            for env in reader.messages(topics, decode=False, start_ns=start_ns, end_ns=end_ns):
                conn = conns.get(env.topic)
                if conn is None:
                    info = reader.topics[env.topic]
                    conn = writer.add_connection(
                        env.topic,
                        info.typename,
                        typestore=stores[env.topic],
                        offered_qos_profiles=_qos_profiles(env.topic, info.qos, opt.distro),
                    )
                    conns[env.topic] = conn
                writer.write(conn, env.time_ns, env.msg)
                n = summary.topics.get(env.topic, ("", 0))[1]
                summary.topics[env.topic] = (reader.topics[env.topic].typename, n + 1)
                first = env.time_ns if first is None else first
                last = env.time_ns
        except BaseException:
            writer.abort()
            raise
        if not conns:
            writer.abort()
            raise NavlogError(
                f"{reader.path}: no message of {', '.join(topics)} between --start and --end; nothing exported"
            )
        writer.close()
        for reason, n in reader.report.skipped.items():
            summary.skipped[reason] += n
        _fix_metadata_distro(bag / "metadata.yaml", opt.distro)
        summary.start_ns, summary.end_ns = first or 0, last or 0
        _replace(bag, out)
    finally:
        shutil.rmtree(tmpdir, ignore_errors=True)
    return summary


def _stamp_distro(writer: Any, distro: str) -> None:
    """rosbags records ros_distro 'rosbags'; the copy embedded in the storage file names the distro."""
    storage = writer.storage
    close = storage.close

    def close_with_distro(version: int, metadata: str) -> None:
        close(version, metadata.replace("ros_distro: rosbags", f"ros_distro: {distro}"))

    storage.close = close_with_distro


def _fix_metadata_distro(path: Path, distro: str) -> None:
    text = path.read_text()
    path.write_text(text.replace("ros_distro: rosbags", f"ros_distro: {distro}"))


# ---------------------------------------------------------------- TUM


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
    times, pos, quat, dropped = [], [], [], 0
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
    buf = TFBuffer(cache_ns=1 << 62, frame_prefix=frame_prefix)

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
        rows.append((stamp if use_header else t_log, tuple(m[:3, 3]), messages.matrix_to_quat(m[:3, :3])))
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
    _check_out(out, force)
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
        rows = _tf_rows(reader, tf[0], tf[1], frame_prefix, use_header, start_ns, end_ns, skipped)
        source = f"tf {tf[0]} <- {tf[1]}"
    if not rows:
        raise NavlogError(f"{reader.path}: no pose from {source} in the chosen time window; nothing written")
    from navlog.analysis.tum import format_tum

    traj, dropped = trajectory_from_rows(rows)
    if dropped:
        skipped["repeated timestamp"] += dropped
        log.warning("%s: dropped %d poses with a repeated timestamp", source, dropped)
    tmp = out.with_name(f".{out.name}.{os.getpid()}.part")
    try:
        tmp.write_text(format_tum(traj), encoding="utf-8")
        os.replace(tmp, out)
    finally:
        tmp.unlink(missing_ok=True)
    return TumSummary(out, source, len(traj.times_ns), skipped)
