"""Where a fleet's logs and outputs live: local paths, or URLs read and written through ``fsspec``.

A ``file://`` URL is a local path. Any other URL (``s3://``, ``gs://``, ``memory://``, ...) goes
through ``fsspec``: a log is copied to a local temporary folder to be replayed (readers need a file),
and an output folder is replayed locally and then uploaded, its ``manifest.json`` last, so a folder
whose manifest is there is complete. ``fsspec`` is imported only when a URL is used.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from navlog.errors import ConfigError

__all__ = [
    "download",
    "filesystem",
    "is_url",
    "join",
    "local_path",
    "private_to_process",
    "upload_folder",
    "write_bytes",
]

# filesystems that live in one process's memory: no worker process or Ray task can see them
PRIVATE_PROTOCOLS = ("memory",)


def is_url(address: str) -> bool:
    """Whether ``address`` is a URL that needs ``fsspec`` (``file://`` is a local path)."""
    return "://" in address and not address.startswith("file://")


def local_path(address: str | Path) -> Path:
    """A local address (a path or a ``file://`` URL) as a path."""
    text = str(address)
    return Path(text[len("file://") :]) if text.startswith("file://") else Path(text)


def join(address: str, name: str) -> str:
    """``address/name`` for a local path or a URL."""
    return f"{address.rstrip('/')}/{name}" if is_url(address) else str(local_path(address) / name)


def private_to_process(address: str) -> bool:
    return is_url(address) and address.split("://", 1)[0] in PRIVATE_PROTOCOLS


def filesystem(url: str) -> tuple[Any, str]:
    """The ``fsspec`` filesystem of ``url`` and the path inside it; a clear error if fsspec or the
    protocol's driver is missing."""
    try:
        import fsspec
    except ImportError:
        raise ConfigError(f"{url}: reading URLs needs fsspec: pip install navlog[fleet]") from None
    try:
        return fsspec.core.url_to_fs(url)
    except (ImportError, ValueError) as exc:
        protocol = url.split("://", 1)[0]
        raise ConfigError(
            f"{url}: no filesystem for '{protocol}://' ({exc}); install its fsspec driver (s3fs for s3://, gcsfs for gs://)"
        ) from None


def download(url: str, dest: Path) -> Path:
    """Copy the file or folder at ``url`` to ``dest`` (a new path) and return ``dest``."""
    fs, path = filesystem(url)
    if fs.isdir(path):
        dest.mkdir(parents=True)
        for entry in sorted(fs.find(path)):
            target = dest / Path(entry[len(path.rstrip("/")) + 1 :])
            target.parent.mkdir(parents=True, exist_ok=True)
            fs.get_file(entry, str(target))
    else:
        dest.parent.mkdir(parents=True, exist_ok=True)
        fs.get_file(path, str(dest))
    return dest


def upload_folder(folder: Path, url: str, last: str) -> None:
    """Replace the folder at ``url`` by the files of ``folder``; the file named ``last`` goes up last."""
    fs, path = filesystem(url)
    if fs.exists(path):
        fs.rm(path, recursive=True)
    fs.makedirs(path, exist_ok=True)
    files = sorted(p for p in folder.rglob("*") if p.is_file())
    for p in sorted(files, key=lambda p: p.name == last):
        fs.put_file(str(p), f"{path.rstrip('/')}/{p.relative_to(folder).as_posix()}")


def write_bytes(url: str, data: bytes) -> None:
    fs, path = filesystem(url)
    fs.pipe_file(path, data)
