"""What makes a replay: one key for the log, the pipeline, its parameters, the remaps and navlog's version.

``replay_identity(log_sha256, pipeline, params, remap)`` is the one key of a replay. Two replays with
the same key write the same bytes, so the CI cache (``replays/KEY/``), the fleet's resume check
(``OUT/.fleet/NAME.json``) and ``run_replay``'s result (``ReplayResult.identity``) all name a replay
by it, and a replay made by one of them is the replay the others would make.

- ``log_sha256``: of a log file, its sha256; of a rosbag2 folder, the sha256 of its files' names and
  hashes (``input_entries`` lists them as the manifest's ``inputs`` does; ``inputs_sha256`` turns
  that list into the log's hash, so a manifest names its log without reading it again).
- ``parameter_hash``: the sha256 of the parameter tree's canonical JSON (``config_hash``), where a
  parameter naming an existing file counts by the file's content, not its path: the key does not
  depend on where a checkout, a cache or a Nav2 file lives.
- the remaps count as a sorted mapping; the version is navlog's (a new release replays again).
"""

from __future__ import annotations

import hashlib
import os
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from navlog.errors import NavlogError
from navlog.replay.config import config_hash, to_mapping
from navlog.version import __version__

__all__ = [
    "HASH_BLOCK",
    "input_entries",
    "inputs_sha256",
    "log_sha256",
    "parameter_hash",
    "replay_identity",
    "sha256_file",
]

HASH_BLOCK = 1 << 20  # bytes hashed per call: the interpreter lock is taken once per block


def sha256_file(path: Path) -> str:
    """The file's SHA-256, read into one reused buffer of up to 1 MiB: the memory stays flat whatever the file's
    size (a memory map of the whole file would count it all in the process's resident size, a larger
    buffer a larger share of a long replay's output), and the interpreter lock is released for each
    block's read and hash, so hashing beside a replay costs the replay's thread about a thousand lock
    hand-offs for a 1 GB log."""
    h = hashlib.sha256()
    with open(path, "rb", buffering=0) as f:
        buf = bytearray(max(1, min(HASH_BLOCK, os.fstat(f.fileno()).st_size)))  # a small file: a small buffer
        view = memoryview(buf)
        while n := f.readinto(buf):
            h.update(view[:n])
    return h.hexdigest()


def input_entries(log: Path) -> list[dict[str, Any]]:
    """The log's files as a manifest lists them: ``{"file", "bytes", "sha256"}`` each, in name order (a
    log file: itself; a rosbag2 folder: its files)."""
    files = sorted(p for p in log.iterdir() if p.is_file()) if log.is_dir() else [log]
    return [{"file": p.name, "bytes": p.stat().st_size, "sha256": sha256_file(p)} for p in files]


def inputs_sha256(entries: Sequence[Mapping[str, Any]], *, folder: bool) -> str:
    """The log's sha256 from its ``input_entries``: a file's own hash; a folder's, the hash of its files'
    names and hashes."""
    if not folder:
        if len(entries) != 1:
            raise ValueError(f"a log file has one input entry, got {len(entries)}")
        return str(entries[0]["sha256"])
    return config_hash([[e["file"], e["sha256"]] for e in entries])


def log_sha256(path: Path) -> str:
    """sha256 of a log file; of a rosbag2 folder, of its files' names and hashes."""
    path = Path(path)
    if not path.exists():
        raise NavlogError(f"{path}: no such log file or folder")
    return inputs_sha256(input_entries(path), folder=path.is_dir())


def parameter_hash(params: Any) -> str:
    """sha256 of a pipeline's parameters (canonical JSON). A parameter naming an existing file counts by
    the file's content, not its path."""

    def plain(v: Any) -> Any:
        if isinstance(v, dict):
            return {k: plain(x) for k, x in v.items()}
        if isinstance(v, list):
            return [plain(x) for x in v]
        if isinstance(v, str) and os.sep in v and Path(v).is_file():
            return f"file:sha256:{sha256_file(Path(v))}"
        return v

    return config_hash(plain(to_mapping(params)))


def replay_identity(
    log_sha256: str,
    pipeline: str,
    params: Any,
    remap: Mapping[str, str],
    navlog_version: str = __version__,
) -> str:
    """The key of a replay (see the module docstring). ``params`` is the parameter dataclass the replay
    is given (before the pipeline settles its ``auto`` values from the log: those follow from the log)."""
    return config_hash(
        {
            "pipeline": pipeline,
            "log": log_sha256,
            "parameters": parameter_hash(params),
            "remap": dict(sorted(remap.items())),
            "navlog_version": navlog_version,
        }
    )
