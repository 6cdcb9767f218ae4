"""Exporting a log as a ROS 2 bag (a rosbag2 folder, sqlite3 or MCAP storage).

``export_rosbag2`` copies every selected message's CDR bytes unchanged into a rosbag2 folder written
with ``rosbags.rosbag2.Writer``: metadata version 8 for Humble, 9 for Jazzy, transient-local QoS for
``/tf_static``, ``/map`` and Nav2's costmaps (``*/costmap``, ``*/costmap_raw``, ``*/costmap_updates``,
as Nav2 publishes them, even from a log that recorded them volatile), every other topic with the QoS it
was recorded with, receive times kept.

A window (``start_s``) keeps what a subscriber joining at its start would still receive: the
transient-local topics' messages published before it (``/tf_static``: the latest transform of every
child frame; ``/map``, the costmaps and any topic recorded transient-local: the latest message), written at the
window's start, so that a trimmed bag still has its static transforms and its map.

The folder is written inside a hidden temporary folder next to the output and moved into place only
when complete.
"""

from __future__ import annotations

import itertools
import logging
import shutil
import sqlite3
from collections import Counter
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from navlog.analysis.export.selection import check_output, check_window, select_topics, time_window
from navlog.errors import NavlogError
from navlog.replay import messages
from navlog.replay.config import suggest
from navlog.replay.io import LogReader
from navlog.replay.io.atomic import check_not_input, hold_output, output_failure, replace_output, temp_path
from navlog.version import __version__

__all__ = ["DISTRO_VERSIONS", "STORAGES", "BagOptions", "ExportSummary", "export_rosbag2"]

log = logging.getLogger("navlog")

DISTRO_VERSIONS = {"humble": 8, "jazzy": 9}
STORAGES = ("sqlite3", "mcap")


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
        check_window(self.start_s, self.end_s)
        return self


@dataclass
class ExportSummary:
    path: Path
    topics: dict[str, tuple[str, int]] = field(default_factory=dict)  # topic -> (type, count)
    skipped: Counter = field(default_factory=Counter)
    start_ns: int = 0
    end_ns: int = 0
    carried: dict[str, int] = field(default_factory=dict)  # latched topic -> messages kept from before the window

    @property
    def messages(self) -> int:
        return sum(c for _, c in self.topics.values())


def _recorded_qos(source_qos: str) -> list:
    """The QoS profiles a topic was recorded with (rosbag2's YAML form), [] when there are none or unreadable."""
    if not source_qos:
        return []
    from rosbags.rosbag2.metadata import parse_qos

    try:
        return parse_qos(source_qos)
    except Exception:
        return []


def _transient_local(topic: str, source_qos: str) -> bool:
    """A latched topic: /tf_static, /map, or one recorded with transient-local durability."""
    from rosbags.interfaces import QosDurability

    return messages.is_latched(topic) or any(
        q.durability == QosDurability.TRANSIENT_LOCAL for q in _recorded_qos(source_qos)
    )


def _latched_before(reader: LogReader, topics: list[str], start_ns: int) -> list[Any]:
    """Envelopes (bytes) of the transient-local ``topics`` a subscriber at ``start_ns`` would receive.

    ``/tf_static``: each message holding the latest transform of some child frame (in log order);
    other topics: their latest message.
    """
    kept: dict[str, list[Any]] = {}
    latest_child: dict[str, int] = {}  # /tf_static child frame -> index of its latest message
    statics: list[Any] = []
    for env in reader.messages(topics, decode=False, end_ns=start_ns - 1):
        if env.time_ns >= start_ns:
            break
        if env.topic != "/tf_static":
            kept[env.topic] = [env]
            continue
        statics.append(env)
        try:
            transforms = messages.deserialize(bytes(env.msg), reader.topics[env.topic].typename).transforms
        except Exception:  # not a TFMessage as navlog knows it: keep the latest message only
            latest_child = {"": len(statics) - 1}
            continue
        for tf in transforms:
            latest_child[tf.child_frame_id] = len(statics) - 1
    if statics:
        kept["/tf_static"] = [statics[i] for i in sorted(set(latest_child.values()))]
    return [env for topic in sorted(kept) for env in kept[topic]]


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
    if messages.is_latched(topic):
        return [default._replace(depth=1, durability=QosDurability.TRANSIENT_LOCAL)]
    recorded = _recorded_qos(source_qos)
    return recorded[:1] if recorded else [default]


def _type_source(reader: LogReader, typename: str):
    """A type store that can describe a type (navlog's, or the one the reader built from the log)."""
    store = messages.typestore()
    if typename in store.types:
        return store
    other = reader.typestore
    if typename in other.types:
        return other
    return None


def _temp_dir_beside(out: Path) -> Path:
    tmp = temp_path(out)  # .NAME.PID.part; what killed exports left beside ``out`` is removed first
    tmp.mkdir()
    return tmp


def export_rosbag2(
    reader: LogReader, out: Path | str, options: BagOptions | None = None, *, force: bool = False
) -> ExportSummary:
    """Write the selected messages of a log as a rosbag2 folder; message bytes are copied unchanged. One
    run writes ``out`` at a time (``hold_output``); a folder that holds the log is refused (``check_not_input``)."""
    out = Path(out)
    check_not_input(out, [reader.path], folder=True)
    if out.parent.is_dir():
        with hold_output(out):
            return _export_rosbag2(reader, out, options, force)
    return _export_rosbag2(reader, out, options, force)


def _export_rosbag2(reader: LogReader, out: Path, options: BagOptions | None, force: bool) -> ExportSummary:
    from rosbags.rosbag2 import StoragePlugin, Writer

    opt = (options or BagOptions()).validate()
    check_output(out, force)
    topics = select_topics(reader, opt.topics)
    unknown = {t: reader.topics[t].why or reader.topics[t].typename for t in topics if not reader.topics[t].known}
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
        why = reader.topics[t].why or f"unknown type {ty}"  # (a refused schema says why)
        summary.skipped[f"{why} on {t}"] += reader.topics[t].count
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
            carried: list[Any] = []
            if start_ns is not None:
                latched = [t for t in topics if _transient_local(t, reader.topics[t].qos)]
                carried = _latched_before(reader, latched, start_ns) if latched else []
                summary.carried = dict(sorted(Counter(e.topic for e in carried).items()))
            window = reader.messages(topics, decode=False, start_ns=start_ns, end_ns=end_ns)
            for env in itertools.chain((replace(e, time_ns=start_ns) for e in carried), window):
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
        replace_output(bag, out)
    except (OSError, sqlite3.Error) as exc:  # a read-only folder, a full disk, a file-size limit
        failure = output_failure(out, exc)
        if failure is None:
            raise
        raise failure from None
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
