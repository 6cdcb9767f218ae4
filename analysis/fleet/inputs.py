"""A fleet's logs from what a user names: paths, folders, glob patterns, list files and URLs.

- a log: a ``.mcap`` or ``.db3`` file, or a rosbag2 folder (one with ``metadata.yaml``);
- a folder that is not a log: every log directly inside it (files and rosbag2 folders), by name; a
  replay's output folder (with ``manifest.json``) is refused, naming the log it was replayed from;
- a glob pattern (``logs/*.mcap``, ``s3://bucket/2026-*/*.mcap``; ``**`` descends): every match;
- a list file (``lists``): one entry per line, any of the above; blank lines and ``#`` comments are
  skipped, and relative paths are read from the list file's folder;
- URLs (``s3://``, ``gs://``, ``memory://``, ...) go through ``fsspec``; ``file://`` is a local path.

Each log gets an output folder name: its file name without the suffix (a rosbag2 folder: its name).
Logs that would share a name get ``NAME-<8 hex digits of their address's sha1>`` instead, so names
never collide and do not depend on the order the logs were named in. A log named twice counts once.
"""

from __future__ import annotations

import glob
import hashlib
import os
import re
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from navlog.analysis.fleet.storage import filesystem, is_url, local_path
from navlog.errors import ConfigError

__all__ = ["LOG_SUFFIXES", "LogSource", "collect_logs"]

LOG_SUFFIXES = (".mcap", ".db3")
REPLAY_MANIFEST = "manifest.json"  # what marks a replay's output folder (it holds replay.mcap, not a log)
GLOB_CHARS = "*?["


@dataclass(frozen=True)
class LogSource:
    """One log of a fleet: where it is (a local path or a URL) and the name of its output folder."""

    address: str
    name: str


def collect_logs(
    sources: Sequence[str | Path], *, lists: Sequence[str | Path] = (), output: str | Path | None = None
) -> list[LogSource]:
    """The logs that ``sources`` and the list files ``lists`` name, in the order named (see the module
    docstring), but those a folder or a pattern finds inside the fleet's own ``output`` folder (``logs/**/*.mcap``
    with the output under ``logs/`` finds its replays' logs); ``ConfigError`` naming the entry when one names no
    log."""
    own = Path(output).resolve() if output is not None and not is_url(str(output)) else None
    addresses: list[str] = []
    for source in sources:
        found = _expand(str(source), where="")
        if own is not None and found != [str(source)]:  # a folder or a pattern found them, not the user
            found = [a for a in found if is_url(a) or own not in Path(a).resolve().parents]
        addresses += found
    for listing in lists:
        addresses += _read_list(str(listing))
    unique = list(dict.fromkeys(addresses))
    if not unique:
        raise ConfigError("no logs given: name log files, folders of logs, glob patterns or a list file (--list)")
    stems = {a: _stem(a) for a in unique}
    counts = Counter(stems.values())
    return [
        LogSource(a, s if counts[s] == 1 else f"{s}-{hashlib.sha1(a.encode()).hexdigest()[:8]}")
        for a, s in stems.items()
    ]


MAX_NAME = 100  # characters of an output folder name taken from a log's name


def _stem(address: str) -> str:
    name = PurePosixPath(address.rstrip("/").split("://", 1)[-1]).name
    for suffix in LOG_SUFFIXES:
        if name.endswith(suffix) and len(name) > len(suffix):
            name = name[: -len(suffix)]
            break
    return safe_name(name, address)


def safe_name(name: str, address: str) -> str:
    """``name`` as the name of one folder inside the fleet's output: characters other than letters, digits,
    ``._+-`` become ``_``, a leading dot too (no ``.``, ``..`` or hidden name, which the output's own
    temporaries use), an empty name becomes ``log``; a name changed or cut to ``MAX_NAME`` characters gets
    ``-`` and 8 hex digits of ``address``'s sha1, so that two logs never share it."""
    clean = re.sub(r"[^A-Za-z0-9._+-]", "_", name)
    clean = re.sub(r"^\.", "_", clean) or "log"
    if clean == name and len(name) <= MAX_NAME:
        return name
    return f"{clean[:MAX_NAME]}-{hashlib.sha1(address.encode()).hexdigest()[:8]}"


def _read_list(listing: str) -> list[str]:
    if is_url(listing):
        fs, inside = filesystem(listing)
        try:
            text = fs.cat_file(inside).decode()
        except OSError as exc:
            raise ConfigError(f"--list {listing}: cannot read: {exc}") from None
        base = listing.rsplit("/", 1)[0]
    else:
        local = local_path(listing)
        try:
            text = local.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as exc:
            raise ConfigError(f"--list {listing}: cannot read: {exc}") from None
        base = str(local.parent)
    out: list[str] = []
    for number, raw in enumerate(text.splitlines(), 1):
        entry = raw.split("#", 1)[0].strip()
        if not entry:
            continue
        if not is_url(entry) and not entry.startswith("file://") and not Path(entry).is_absolute():
            entry = f"{base.rstrip('/')}/{entry}"
        out += _expand(entry, where=f"{listing}, line {number}: ")
    return out


def _expand(source: str, *, where: str) -> list[str]:
    if is_url(source):
        return _expand_url(source, where)
    text = str(local_path(source))
    if any(c in text for c in GLOB_CHARS):
        matches = sorted(glob.glob(text, recursive=True))
        if not matches:
            raise ConfigError(f"{where}{source}: the pattern matches no file or folder")
        return [a for m in matches for a in _local_logs(Path(m), where, inside_pattern=True)]
    return _local_logs(Path(text), where, inside_pattern=False)


def _local_logs(path: Path, where: str, *, inside_pattern: bool) -> list[str]:
    if not path.exists():
        raise ConfigError(f"{where}{path}: no such file or folder")
    if path.is_file() or (path / "metadata.yaml").is_file():
        return [os.path.abspath(path)]
    if (path / REPLAY_MANIFEST).is_file():
        if inside_pattern:
            return []
        raise ConfigError(f"{where}{path} is a replay output folder, not a log; replay its input LOG{_input_of(path)}")
    found = [
        os.path.abspath(p)
        for p in sorted(path.iterdir())
        if (p.is_file() and p.suffix in LOG_SUFFIXES) or (p.is_dir() and (p / "metadata.yaml").is_file())
    ]
    if not found and not inside_pattern:
        raise ConfigError(
            f"{where}{path}: no logs in this folder (expected .mcap or .db3 files or rosbag2 folders with metadata.yaml)"
        )
    return found


def _input_of(folder: Path) -> str:
    """' (FILE, as its manifest.json names it)' for the error about a replay output folder, or ''."""
    import json

    try:
        inputs = json.loads((folder / REPLAY_MANIFEST).read_text(encoding="utf-8")).get("inputs") or []
        names = [str(e["file"]) for e in inputs]
    except (OSError, ValueError, TypeError, KeyError, AttributeError):
        return ""
    return f" ({', '.join(names)}, as its {REPLAY_MANIFEST} names it)" if names else ""


def _expand_url(url: str, where: str) -> list[str]:
    fs, path = filesystem(url)
    unstrip = fs.unstrip_protocol
    if any(c in path for c in GLOB_CHARS):
        matches = sorted(fs.glob(path))
        if not matches:
            raise ConfigError(f"{where}{url}: the pattern matches no file or folder")
        return [a for m in matches for a in _url_logs(fs, m, unstrip, where, inside_pattern=True)]
    if not fs.exists(path):
        raise ConfigError(f"{where}{url}: no such file or folder")
    return _url_logs(fs, path, unstrip, where, inside_pattern=False)


def _url_logs(fs, path: str, unstrip, where: str, *, inside_pattern: bool) -> list[str]:
    if not fs.isdir(path) or fs.exists(f"{path.rstrip('/')}/metadata.yaml"):
        return [unstrip(path)]
    found: Iterable[str] = (
        entry["name"]
        for entry in sorted(fs.ls(path, detail=True), key=lambda e: e["name"])
        if (entry["type"] == "file" and entry["name"].endswith(LOG_SUFFIXES))
        or (entry["type"] == "directory" and fs.exists(f"{entry['name'].rstrip('/')}/metadata.yaml"))
    )
    out = [unstrip(p) for p in found]
    if not out and not inside_pattern:
        raise ConfigError(
            f"{where}{unstrip(path)}: no logs in this folder (expected .mcap or .db3 files or rosbag2 folders)"
        )
    return out
