"""What every log reader offers: a summary known up front and a message stream in log-time order.

``LogReader`` holds the summary (topics, types, counts, times, metadata), the ``ReadReport`` of what
streaming read and skipped, and the reader's own ``typestore`` (see ``navlog.replay.io.typestore``).
The implementations are ``McapLogReader`` and ``SplitMcapLogReader`` (``mcap_reader``) and
``RosbagLogReader`` (``rosbag2_reader``); ``open_log`` (``formats``) picks one for a path.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from navlog.errors import LogError
from navlog.replay.io.typestore import LogTypestore
from navlog.replay.runtime.executor import Envelope

# A log time is evidence, not an order: in a stream in log-time order, a message more than this after the
# one before it is a counted skip (one flipped bit moves a time days ahead, and the replay's timers would
# run until then). Robot logs do not pause for an hour inside one file; a stream first trusts a run of
# ``TRUST_AFTER`` messages without such a jump, so a lone early time (a bit flipped the other way) is
# skipped too.
MAX_LOG_TIME_JUMP_NS = 3600 * 10**9
TRUST_AFTER = 16
HELD_AT_MOST = 64  # messages held while no run is trusted yet (then the longest so far is): bounded memory
LATE = "messages whose log time jumps more than an hour past the message before (corrupt log time)"
EARLY = "messages whose log time lies more than an hour before the messages after (corrupt log time)"


@dataclass
class TopicInfo:
    name: str
    typename: str
    count: int
    known: bool = True
    qos: str = ""
    why: str = ""  # why an unknown type is unknown (a refused schema), when there is more to say


@dataclass
class ReadReport:
    """What happened while streaming: messages read, skipped (and why), and recovery figures."""

    read: int = 0
    skipped: Counter = field(default_factory=Counter)
    truncated: bool = False
    recovered_until_ns: int | None = None

    def note_skip(self, reason: str, n: int = 1) -> None:
        self.skipped[reason] += n


class LogReader:
    """Summary and message stream of one log; see ``open_log``."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.format = ""
        self.storage = ""
        self.compression = ""
        self.size_bytes = 0
        self.start_ns = 0
        self.end_ns = 0
        self.topics: dict[str, TopicInfo] = {}
        self.metadata: dict[str, dict[str, str]] = {}
        self.report = ReadReport()
        self._types: LogTypestore = LogTypestore()

    @property
    def typestore(self) -> Any:
        """The rosbags type store this reader decodes with: the shared base store, or the reader's own."""
        return self._types.store

    @property
    def duration_ns(self) -> int:
        return max(0, self.end_ns - self.start_ns)

    @property
    def message_count(self) -> int:
        return sum(t.count for t in self.topics.values())

    @property
    def unknown_types(self) -> dict[str, str]:
        """topic -> type name, for topics whose messages cannot be decoded."""
        return {t.name: t.typename for t in self.topics.values() if not t.known}

    @property
    def unknown_listed(self) -> str:
        """The topics of unknown type as "topic (type)", or "topic (why)" for a refused schema, for a message."""
        return ", ".join(
            f"{t.name} ({t.why or t.typename})"
            for t in sorted(self.topics.values(), key=lambda t: t.name)
            if not t.known
        )

    def require(self, needed: Iterable[str], remap_hint: str = "") -> None:
        """Fail with what is needed, what the log has, and how to remap, if a topic is missing."""
        missing = [t for t in needed if t not in self.topics]
        if missing:
            have = ", ".join(f"{t.name} ({t.typename})" for t in self.topics.values()) or "nothing"
            raise LogError(
                f"{self.path}: missing topic(s) {', '.join(missing)}; the log has {have}."
                + (f" {remap_hint}" if remap_hint else "")
            )

    def messages(
        self,
        topics: Iterable[str] | None = None,
        *,
        decode: bool = True,
        light: Iterable[str] = (),
        start_ns: int | None = None,
        end_ns: int | None = None,
    ) -> Iterator[Envelope]:
        """The wanted topics' messages in log-time order: decoded message objects (raw CDR bytes when not
        ``decode``). On the ``light`` topics a reader may give a type's light form instead
        (``messages.TFTransforms`` for a TFMessage), for subscribers that accept it."""
        raise NotImplementedError

    def close(self) -> None:
        pass

    def __enter__(self) -> LogReader:
        return self

    def __exit__(self, *exc: Any) -> None:
        self.close()

    def _wanted(self, topics: Iterable[str] | None) -> set[str]:
        names = set(self.topics) if topics is None else {t for t in topics if t in self.topics}
        unknown = {n for n in names if not self.topics[n].known}
        for n in sorted(unknown):
            info = self.topics[n]
            self.report.note_skip(f"{info.why or 'unknown type ' + info.typename} on {n}", info.count)
        return names - unknown

    def _in_sequence(self, items: Iterable[Any], time_of: Callable[[Any], int]) -> Iterator[Any]:
        """``items`` (in log-time order) without those whose time jumps (``MAX_LOG_TIME_JUMP_NS``) away from
        the others: the first run of ``TRUST_AFTER`` messages without a jump is trusted, earlier runs are
        early outliers, and after it a message more than the bound past the last kept one is a late one;
        a stream that never has such a run keeps its longest (the earliest of equals)."""
        runs: list[list[Any]] = []  # before a run is trusted: runs without a jump inside, in order
        held = 0
        last = None
        for item in items:
            t = time_of(item)
            if last is not None:
                if t - last > MAX_LOG_TIME_JUMP_NS:
                    self.report.note_skip(LATE)
                    continue
                last = t
                yield item
                continue
            if runs and t - time_of(runs[-1][-1]) <= MAX_LOG_TIME_JUMP_NS:
                runs[-1].append(item)
            else:
                runs.append([item])
            held += 1
            if len(runs[-1]) >= TRUST_AFTER or held >= HELD_AT_MOST:
                kept = self._trust(runs)
                yield from kept
                last = time_of(kept[-1])
                runs = []
        if runs:
            yield from self._trust(runs)

    def _trust(self, runs: list[list[Any]]) -> list[Any]:
        """The longest run (the earliest of equals); the others are counted skips."""
        best = max(range(len(runs)), key=lambda i: (len(runs[i]), -i))
        for i, run in enumerate(runs):
            if i != best:
                self.report.note_skip(EARLY if i < best else LATE, len(run))
        return runs[best]

    def _decode(self, data: bytes, typename: str, topic: str) -> Any:
        try:
            return self._types.store.deserialize_cdr(data, typename)
        except Exception:  # corrupt bytes: counted, never fatal
            self.report.note_skip(f"undecodable {typename} on {topic}")
            return None
