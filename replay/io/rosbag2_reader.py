"""rosbag2 folders (sqlite3 or MCAP storage, split files) and bare .db3 files, read with rosbags' ``AnyReader``.

``AnyReader`` builds the reader's type store from the bag's own definitions (the shared base store
only fills in for a bag that has none); it is the reader's ``typestore``.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from navlog.errors import LogError
from navlog.replay import messages
from navlog.replay.io.reader import LogReader, TopicInfo
from navlog.replay.io.typestore import LogTypestore
from navlog.replay.runtime.executor import Envelope


class RosbagLogReader(LogReader):
    """A rosbag2 folder (sqlite3 or MCAP storage, split files) or a bare .db3, read with rosbags."""

    def __init__(self, path: Path) -> None:
        super().__init__(path)
        from rosbags.highlevel import AnyReader
        from rosbags.rosbag2.metadata import dump_qos_v8

        self.format = "rosbag2"
        files = [p for p in path.iterdir() if p.is_file()] if path.is_dir() else [path]
        self.size_bytes = sum(p.stat().st_size for p in files)
        vetting = LogTypestore()  # the bag's definitions vetted; rosbags builds the store
        try:
            self._reader = AnyReader([path], default_typestore=messages.typestore())
            with bounded_definitions(vetting):
                self._reader.open()
        except Exception as exc:
            if vetting.refused:  # the bag's type hashes name a type whose definition was refused
                raise LogError(
                    f"{path}: cannot open as a ROS 2 bag: {'; '.join(sorted(vetting.refused.values()))}, and "
                    "the bag's type hashes need every definition; re-record it without that type"
                ) from None
            raise LogError(f"{path}: cannot open as a ROS 2 bag: {exc}") from None
        self.storage = (
            ",".join(sorted({p.suffix.lstrip(".") for p in files if p.suffix in (".db3", ".mcap")})) or "unknown"
        )
        self.metadata.update(self.bag_metadata(path))
        self.compression = self.metadata.get("rosbag2", {}).get("compression_format") or "none"
        try:
            self.start_ns, self.end_ns = self._reader.start_time, self._reader.end_time
            refused = vetting.refused
            self._types = LogTypestore(self._reader.typestore)
            self._types.refused = refused
            types = self.typestore.types
            for conn in sorted(self._reader.connections, key=lambda c: c.id):
                if not (isinstance(conn.topic, str) and isinstance(conn.msgtype, str)):
                    raise TypeError(f"topic {conn.topic!r} of type {conn.msgtype!r}")
                prev = self.topics.get(conn.topic)
                count = conn.msgcount + (prev.count if prev else 0)
                qos = ""
                ext = getattr(conn, "ext", None)
                if ext is not None:
                    profiles = getattr(ext, "offered_qos_profiles", "") or ""
                    # rosbags parses them into Qos tuples: keep rosbag2's own YAML form
                    qos = dump_qos_v8(profiles) if isinstance(profiles, list) else str(profiles)
                known = conn.msgtype in types
                why = "" if known else refused.get(conn.msgtype, "")
                self.topics[conn.topic] = TopicInfo(conn.topic, conn.msgtype, count, known, qos, why)
        except (TypeError, ValueError, AttributeError) as exc:  # topics, counts or times of the wrong kind
            raise LogError(
                f"{path}: malformed rosbag2 metadata ({exc}); repair metadata.yaml, or open a .db3/.mcap inside"
            ) from None

    @staticmethod
    def bag_metadata(path: Path) -> dict[str, dict[str, str]]:
        """The rosbag2 facts from a folder's metadata.yaml (version, storage, distro, compression)."""
        meta = path / "metadata.yaml"
        if not (path.is_dir() and meta.is_file()):
            return {}
        info = bag_info(path)
        keys = ("version", "storage_identifier", "ros_distro", "compression_format", "compression_mode")
        return {"rosbag2": {k: str(info.get(k, "") or "") for k in keys}}

    def messages(self, topics=None, *, decode=True, light=(), start_ns=None, end_ns=None) -> Iterator[Envelope]:
        wanted = self._wanted(topics)
        conns = [c for c in self._reader.connections if c.topic in wanted]
        if not conns:
            return
        store = self.typestore
        try:
            stream = self._reader.messages(
                connections=conns, start=start_ns, stop=None if end_ns is None else end_ns + 1
            )
            for conn, t, raw in self._in_sequence(stream, _time_of):
                self.report.read += 1
                if not decode:
                    yield Envelope(conn.topic, conn.msgtype, t, bytes(raw))
                    continue
                try:
                    msg = store.deserialize_cdr(raw, conn.msgtype)
                except Exception:
                    self.report.note_skip(f"undecodable {conn.msgtype} on {conn.topic}")
                    continue
                yield Envelope(conn.topic, conn.msgtype, t, msg)
        except Exception as exc:
            raise LogError(f"{self.path}: cannot read messages after {self.report.read}: {exc}") from None

    def close(self) -> None:
        self._reader.close()


@contextmanager
def bounded_definitions(types: LogTypestore) -> Iterator[None]:
    """While ``AnyReader`` opens a bag, the message definitions it parses are vetted first by ``types``
    (``LogTypestore.vetted``: size bounds, recursive types): a refused one defines nothing, so its
    topics are of an unknown type (counted skips) and the others still work. ``AnyReader`` parses them
    inside ``open`` with no hook, so its module's parser is swapped for the call (readers run in one
    thread; the original is always put back)."""
    from rosbags.highlevel import anyreader

    parse = anyreader.get_types_from_msg

    def vetted(text: str, name: str) -> dict[str, Any]:
        return types.vetted(name, text, parse) or {}

    anyreader.get_types_from_msg = vetted
    try:
        yield
    finally:
        anyreader.get_types_from_msg = parse


def _time_of(item: tuple) -> int:
    return int(item[1])


def bag_files(path: Path) -> list[Path]:
    """The storage files a rosbag2 folder lists in its metadata.yaml, in order."""
    names = bag_info(path).get("relative_file_paths") or sorted(p.name for p in path.iterdir())
    if not isinstance(names, list):
        names = [names]
    return [path / n for n in names if isinstance(n, str) and (path / n).is_file()]


def bag_info(path: Path) -> dict:
    """The ``rosbag2_bagfile_information`` mapping of a folder's metadata.yaml, checked to be one."""
    from navlog.errors import ConfigError
    from navlog.replay.config import load_yaml

    meta = path / "metadata.yaml"
    hint = f"repair {meta} (rosbag2 writes it when a recording ends), or open a .db3/.mcap in {path} directly"
    try:
        doc = load_yaml(meta) or {}
    except ConfigError as exc:
        raise LogError(f"{exc}; {hint}") from None
    info = doc.get("rosbag2_bagfile_information", {}) if isinstance(doc, dict) else None
    if not isinstance(info, dict):
        raise LogError(f"{meta}: expected a 'rosbag2_bagfile_information' mapping; {hint}")
    return info
