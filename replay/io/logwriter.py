"""Writing ROS 2 MCAP logs: profile ros2, ros2msg schemas, cdr encoding, zstd chunks.

The file is written under a temporary name (``NAME.part``) and renamed when complete, so a
finished name is always a whole file. An existing output is refused unless ``force`` is set.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from mcap.writer import CompressionType, Writer

from navlog.errors import NavlogError
from navlog.replay import messages
from navlog.replay.io.atomic import open_new, write_error
from navlog.replay.runtime.executor import Envelope
from navlog.version import __version__


def check_output(path: Path, force: bool) -> None:
    """Refuse to overwrite an existing output unless forced, and never put a file where a folder is."""
    if path.is_dir():
        raise NavlogError(f"{path}: is a folder; give the output a file name, e.g. {path / 'out.mcap'}")
    if path.exists() and not force:
        raise NavlogError(f"{path}: already exists; choose another name or pass --force to overwrite it")
    if not path.parent.exists():
        raise NavlogError(f"{path.parent}: output folder does not exist")


class McapLogWriter:
    """A sink that writes every message it is given to a ROS 2 MCAP file.

    Use as a context manager: on success (or Ctrl-C) the file is finished and renamed into place;
    on any other error the partial file is removed.
    """

    def __init__(
        self,
        path: Path | str,
        *,
        force: bool = False,
        metadata: dict[str, dict[str, str]] | None = None,
        compression: str = "zstd",
        chunk_size: int = 4 << 20,
    ) -> None:
        self.path = Path(path)
        check_output(self.path, force)
        self.tmp_path = self.path.with_name(self.path.name + ".part")
        self._file = open_new(self.tmp_path)
        comp = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE}[compression]
        self._writer = Writer(self._file, compression=comp, chunk_size=chunk_size)
        self._writer.start(profile="ros2", library=f"navlog {__version__}")
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, int] = {}
        self._channel_types: dict[str, str] = {}
        self._known: dict[tuple[str, str], int] = {}  # (topic, type) -> channel id, once checked
        self._add = self._writer.add_message
        self._metadata = metadata or {}
        self.count = 0
        self.first_ns: int | None = None
        self.last_ns: int | None = None
        self._closed = False

    def _channel(self, topic: str, typename: str) -> int:
        cid = self._channels.get(topic)
        if cid is not None:
            if self._channel_types[topic] != typename:
                raise NavlogError(
                    f"topic {topic}: published as {typename} but already recorded as {self._channel_types[topic]}"
                )
            return cid
        sid = self._schemas.get(typename)
        if sid is None:
            sid = self._writer.register_schema(typename, "ros2msg", messages.msgdef(typename).encode())
            self._schemas[typename] = sid
        cid = self._writer.register_channel(
            topic, "cdr", sid, metadata={"offered_qos_profiles": messages.qos_for(topic)}
        )
        self._channels[topic] = cid
        self._channel_types[topic] = typename
        self._known[(topic, typename)] = cid
        return cid

    @property
    def topic_types(self) -> dict[str, str]:
        """topic -> message type of every channel written so far."""
        return dict(self._channel_types)

    def write(self, env: Envelope) -> None:
        msg = env.msg
        data = (
            bytes(msg)
            if isinstance(msg, (bytes, bytearray, memoryview))
            else messages.serialize_buffer(msg, env.typename)
        )
        self.write_raw(env.topic, env.typename, env.time_ns, data)

    def write_raw(self, topic: str, typename: str, time_ns: int, data: bytes | bytearray) -> None:
        cid = self._known.get((topic, typename))
        if cid is None:
            cid = self._channel(topic, typename)
        try:
            # the mcap writer takes any bytes-like data, though its annotation says bytes
            self._add(cid, log_time=time_ns, publish_time=time_ns, data=data, sequence=self.count)  # type: ignore[arg-type]
        except OSError as exc:
            raise write_error(self.path, exc) from None
        self.count += 1
        if self.first_ns is None:
            self.first_ns = time_ns
        self.last_ns = time_ns

    def close(self) -> Path:
        """Finish the file (summary, metadata) and move it to its final name."""
        if self._closed:
            return self.path
        try:
            for name in sorted(self._metadata):
                self._writer.add_metadata(name, {k: str(v) for k, v in self._metadata[name].items()})
            self._writer.finish()
            self._file.flush()
            os.fsync(self._file.fileno())
            self._file.close()
            os.replace(self.tmp_path, self.path)
        except OSError as exc:
            self.abort()
            raise write_error(self.path, exc) from None
        self._closed = True
        return self.path

    def abort(self) -> None:
        """Drop the partial file."""
        if not self._closed:
            try:
                self._file.close()
            except OSError:  # the buffered tail cannot be written either (a full disk): drop it
                pass
            self.tmp_path.unlink(missing_ok=True)
            self._closed = True

    def __enter__(self) -> McapLogWriter:
        return self

    def __exit__(self, exc_type: Any, exc: Any, tb: Any) -> None:
        if exc_type is None or issubclass(exc_type, KeyboardInterrupt):
            self.close()
        else:
            self.abort()
