"""`navlog info`: a summary of any log, like `ros2 bag info`."""

from __future__ import annotations

from typing import Any

from navlog.replay.io.logreader import LogReader


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
        "metadata": reader.metadata,
    }


def _size(n: int) -> str:
    for unit in ("B", "KiB", "MiB", "GiB"):
        if n < 1024 or unit == "GiB":
            return f"{n:.1f} {unit}" if unit != "B" else f"{n} B"
        n /= 1024  # type: ignore[assignment]
    return str(n)


def _time(ns: int) -> str:
    return f"{ns / 1e9:.9f} s"


def format_info(info: dict[str, Any]) -> str:
    lines = [
        f"Files:             {info['path']}",
        f"Format:            {info['format']} (storage {info['storage']})",
        f"Bag size:          {_size(info['size_bytes'])}",
        f"Compression:       {info['compression']}",
        f"Duration:          {info['duration_s']:.3f} s",
        f"Start:             {_time(info['start_ns'])}",
        f"End:               {_time(info['end_ns'])}",
        f"Messages:          {info['messages']}",
    ]
    if info["truncated"]:
        lines.append("State:             TRUNCATED (read up to the last complete chunk)")
    lines.append("Topic information:")
    width = max([len(t["topic"]) for t in info["topics"]] + [5])
    twidth = max([len(t["type"]) for t in info["topics"]] + [4])
    for t in info["topics"]:
        mark = "" if t["known"] else "  [unknown type: skipped]"
        lines.append(
            f"  {t['topic']:<{width}}  {t['type']:<{twidth}}  {t['count']:>7} msgs  {t['rate_hz']:>9.2f} Hz{mark}"
        )
    for name, data in info["metadata"].items():
        lines.append(f"Metadata {name}:")
        for k, v in data.items():
            lines.append(f"  {k}: {v}")
    return "\n".join(lines)
