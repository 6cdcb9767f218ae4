"""`navlog info`: a summary of any log, like `ros2 bag info`, as a dict (the JSON) and as text."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from navlog.analysis.tables import grid, indented, render, table

if TYPE_CHECKING:
    from navlog.replay.io import LogReader

__all__ = ["format_info", "summarize"]

UNKNOWN_TYPE = "[unknown type: skipped]"


def summarize(reader: LogReader) -> dict[str, Any]:
    """Duration, times, size, storage, topics (type, count, rate) and metadata of a log."""
    dur_s = reader.duration_ns / 1e9
    topics = []
    for t in sorted(reader.topics.values(), key=lambda t: t.name):
        rate = (t.count - 1) / dur_s if dur_s > 0 and t.count > 1 else 0.0
        topics.append(
            {"topic": t.name, "type": t.typename, "count": t.count, "rate_hz": round(rate, 3), "known": t.known}
        )
    return {
        "path": str(reader.path),
        "format": reader.format,
        "storage": reader.storage,
        "compression": reader.compression,
        "size_bytes": reader.size_bytes,
        "start_ns": reader.start_ns,
        "end_ns": reader.end_ns,
        "duration_s": round(dur_s, 9),
        "messages": reader.message_count,
        "truncated": reader.report.truncated,
        "topics": topics,
        "unknown_types": reader.unknown_types,
        "refused_schemas": {t.name: t.why for t in reader.topics.values() if t.why},
        "skipped": dict(sorted(reader.report.skipped.items())),  # what opening the log found unusable
        "metadata": reader.metadata,
    }


def _size(n: int) -> str:
    for unit in ("B", "KiB", "MiB", "GiB"):
        if n < 1024 or unit == "GiB":
            return f"{n:.1f} {unit}" if unit != "B" else f"{n} B"
        n /= 1024  # type: ignore[assignment]
    return str(n)


def _time(ns: int) -> str:
    """Integer nanoseconds as exact seconds (no float: 1.7e18 ns has more digits than a double holds)."""
    sign = "-" if ns < 0 else ""
    sec, frac = divmod(abs(int(ns)), 1_000_000_000)
    return f"{sign}{sec}.{frac:09d} s"


def format_info(info: dict[str, Any]) -> str:
    """A ``summarize`` dict as text: the log's figures, a table of its topics, its metadata."""
    head = [
        ("Files:", info["path"]),
        ("Format:", f"{info['format']} (storage {info['storage']})"),
        ("Bag size:", _size(info["size_bytes"])),
        ("Compression:", info["compression"]),
        ("Duration:", f"{info['duration_s']:.3f} s"),
        ("Start:", _time(info["start_ns"])),
        ("End:", _time(info["end_ns"])),
        ("Messages:", str(info["messages"])),
    ]
    if info["truncated"]:
        head.append(("State:", "TRUNCATED (read up to the last complete chunk)"))
    topics = table(
        ("Topic", "Type", "Count", "Rate (Hz)", ""),
        (
            (t["topic"], t["type"], str(t["count"]), f"{t['rate_hz']:.2f}", "" if t["known"] else UNKNOWN_TYPE)
            for t in info["topics"]
        ),
        right=(2, 3),
    )
    items: list[Any] = [grid(head), "Topic information:", indented(topics)]
    for topic, why in info.get("refused_schemas", {}).items():
        items.append(f"  {topic}: {why}; its messages are skipped")
    if info.get("skipped"):
        items.append("Skipped (counted):")
        items.append(indented(grid((f"{n}", reason) for reason, n in info["skipped"].items())))
    for name, data in info["metadata"].items():
        items.append(f"Metadata {name}:")
        items.append(indented(grid((f"{k}:", str(v)) for k, v in data.items())))
    return render(*items)
