"""Opening any ROS 2 log by its form: a .mcap file, a .db3 file, or a rosbag2 folder.

``open_log(path)`` returns a ``LogReader`` whose summary (topics, types, counts, times, metadata)
is known up front and whose ``messages()`` streams envelopes in log-time order without loading the
log whole. Topics whose type has no definition (neither in the file nor in the ROS 2 type store)
are listed in ``unknown_types`` and skipped, never fatal. A truncated MCAP is refused with a clear
error unless ``recover=True``, which reads every complete chunk and reports how far it got.
"""

from __future__ import annotations

from pathlib import Path

from navlog.errors import LogError
from navlog.replay.io.mcap_reader import MCAP_MAGIC, McapLogReader, SplitMcapLogReader
from navlog.replay.io.reader import LogReader
from navlog.replay.io.rosbag2_reader import RosbagLogReader, bag_files


def open_log(path: Path | str, *, recover: bool = False) -> LogReader:
    """Open any ROS 2 log: a .mcap file, a .db3 file, or a rosbag2 folder."""
    p = Path(path)
    if not p.exists():
        raise LogError(f"{p}: no such file or folder")
    if p.is_file() and p.suffix == ".mcap":
        return McapLogReader(p, recover=recover)
    if p.is_file() and p.suffix == ".db3":
        return RosbagLogReader(p)
    if p.is_dir():
        if (p / "metadata.yaml").is_file():
            files = bag_files(p)
            if files and all(f.suffix == ".mcap" for f in files):
                reader = SplitMcapLogReader(p, files, recover=recover)
                reader.metadata.update(RosbagLogReader.bag_metadata(p))
                return reader
            return RosbagLogReader(p)
        logs = sorted(f.name for f in p.iterdir() if f.is_file() and f.suffix in (".mcap", ".db3"))
        if not logs:
            raise LogError(f"{p}: not a log: no metadata.yaml and no .mcap or .db3 file in this folder")
        raise LogError(
            f"{p}: folder without metadata.yaml (not a rosbag2 folder); pass a log file inside it instead: "
            + ", ".join(str(p / name) for name in logs[:5])
            + (f" (and {len(logs) - 5} more)" if len(logs) > 5 else "")
        )
    if p.is_file():
        with open(p, "rb") as f:
            if f.read(8) == MCAP_MAGIC:
                return McapLogReader(p, recover=recover)
    raise LogError(f"{p}: unknown log format (expected .mcap, .db3 or a rosbag2 folder)")
