"""Two logs compared topic by topic.

First pass: each topic's message count and the sha256 of its raw (CDR) message bytes in order; topics
whose hashes match are EQUAL without decoding anything. Second pass, for each other topic: both
streams read in lockstep (memory bounded by one message pair, plus the poses of a trajectory), each
pair with different bytes decoded and handed to the comparator of the topic's type:

- ``nav_msgs/OccupancyGrid``: ``grids`` (judged on the worst pair);
- ``nav_msgs/Path``: ``paths``; ``geometry_msgs/Twist`` and ``TwistStamped``: ``twists``;
- ``nav_msgs/Odometry``: ``trajectories`` (poses by header stamp);
- anything else: ``fields`` (count of messages beyond tolerance, largest difference).

The first divergence is the earliest (log time of A's message, then topic) message pair whose bytes
differ and whose fields differ beyond the field tolerance outside the ignored fields, or where one
stream ends before the other.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field, replace
from itertools import zip_longest
from pathlib import Path
from typing import Any

import numpy as np

from navlog.analysis.diff.fields import field_differences, first_field_difference
from navlog.analysis.diff.grids import grid_diff, judge_grid
from navlog.analysis.diff.paths import PlanPair, compare_plan_streams, plan_pair
from navlog.analysis.diff.result import Check, Divergence, Verdict
from navlog.analysis.diff.tolerances import DEFAULT_TOLERANCES, DiffTolerances, as_dict
from navlog.analysis.diff.trajectories import compare_trajectories
from navlog.analysis.diff.twists import compare_twists, twist_row
from navlog.analysis.metrics.trajectory import Trajectory, TrajectoryError
from navlog.errors import LogError, NavlogError, TruncatedLogError
from navlog.replay import messages as m
from navlog.replay.io.formats import open_log
from navlog.replay.io.reader import LogReader
from navlog.replay.occupancy_map import OccupancyMap

__all__ = ["TopicDigest", "compare_logs", "topic_digests"]


@dataclass
class TopicDigest:
    typename: str
    count: int = 0
    sha256: str = ""


def topic_digests(reader: LogReader, topics: Sequence[str] | None = None) -> dict[str, TopicDigest]:
    """Per topic: type, message count and the sha256 of the raw message bytes in log order."""
    hashes: dict[str, Any] = {}
    out: dict[str, TopicDigest] = {}
    for name, info in reader.topics.items():
        if topics is None or name in topics:
            out[name] = TopicDigest(info.typename)
            hashes[name] = hashlib.sha256()
    for env in reader.messages(list(out), decode=False):
        hashes[env.topic].update(env.msg)
        out[env.topic].count += 1
    for name, h in hashes.items():
        out[name].sha256 = h.hexdigest()
    return out


def _open(path: Path) -> LogReader:
    try:
        return open_log(path)
    except TruncatedLogError:  # (its message names --recover, which diff has not: diff compares whole logs)
        raise LogError(
            f"{path}: the log is truncated (cut off while it was written); repair it with "
            f"`navlog recover {path} -o FIXED.mcap` and diff that"
        ) from None
    except NavlogError:
        raise
    except Exception as exc:  # a library error on a corrupt file: reported with the path
        raise LogError(f"{path}: cannot read the log: {exc}") from None


@dataclass
class _Stream:
    """A topic's message pairs as the comparators consume them."""

    topic: str
    typename: str
    reader_a: LogReader
    reader_b: LogReader
    start_ns: int
    tol: DiffTolerances
    ignore: Sequence[str]
    count_a: int = 0
    count_b: int = 0
    differing: int = 0
    divergence: Divergence | None = None
    undecodable: int = 0
    extra: dict[str, Any] = field(default_factory=dict)

    def pairs(self) -> Iterator[tuple[int, Any, Any, bool]]:
        """(index, message A or None, message B or None, bytes equal) for every pair in order."""
        sa = self.reader_a.messages([self.topic], decode=False)
        sb = self.reader_b.messages([self.topic], decode=False)
        for i, (ea, eb) in enumerate(zip_longest(sa, sb)):
            self.count_a += ea is not None
            self.count_b += eb is not None
            same = ea is not None and eb is not None and bytes(ea.msg) == bytes(eb.msg)
            ma = self._decode(self.reader_a, ea)
            mb = self._decode(self.reader_b, eb)
            if not same:
                self.differing += 1
                self._note_divergence(i, ea, eb, ma, mb)
            yield i, ma, mb, same

    def _decode(self, reader: LogReader, env: Any) -> Any:
        if env is None:
            return None
        try:
            return reader.typestore.deserialize_cdr(bytes(env.msg), env.typename)
        except Exception:
            self.undecodable += 1
            return None

    def _note_divergence(self, i: int, ea: Any, eb: Any, ma: Any, mb: Any) -> None:
        if self.divergence is not None:
            return
        env = ea if ea is not None else eb
        if ea is None or eb is None:
            diff = ("(message)", "(none)" if ea is None else "(present)", "(none)" if eb is None else "(present)")
        else:
            d = first_field_difference(ma, mb, self.tol.field, self.ignore)
            if d is None:
                return
            diff = (d.path, d.old, d.new)
        t = int(env.time_ns)
        self.divergence = Divergence(self.topic, i, t, (t - self.start_ns) / 1e9, *diff)


def _grid_check(s: _Stream) -> Check:
    worst = None
    for _, a, b, same in s.pairs():
        if same or a is None or b is None:
            continue
        d = grid_diff(OccupancyMap.from_msg(a), OccupancyMap.from_msg(b))
        if worst is None or (d.changed_share, d.hausdorff_m) > (worst.changed_share, worst.hausdorff_m):
            worst = d
    values: dict[str, Any] = {"messages_a": s.count_a, "messages_b": s.count_b, "messages_differing": s.differing}
    verdict = Verdict.WITHIN
    detail = f"{s.differing} of {max(s.count_a, s.count_b)} grids differ"
    if worst is not None:
        values.update({f"worst.{k}": v for k, v in worst.values().items()})
        verdict = judge_grid(worst, s.tol.grid)
        detail += (
            f"; worst: {worst.changed_cells}/{worst.cells} cells changed class ({100 * worst.changed_share:.3f} %)"
        )
    if s.count_a != s.count_b:
        verdict = Verdict.CHANGED
    return Check(s.topic, "grid", verdict, values, as_dict(s.tol.grid), detail)


def _path_positions(msg: Any) -> np.ndarray:
    if msg is None:
        return np.zeros((0, 2))
    return np.array([(p.pose.position.x, p.pose.position.y) for p in msg.poses], dtype=np.float64).reshape(-1, 2)


def _plan_check(s: _Stream) -> Check:
    pairs: list[PlanPair] = []
    for _, a, b, same in s.pairs():
        if a is None or b is None:
            continue
        if same:
            ok = len(a.poses) > 0
            pairs.append(PlanPair(ok, ok, 0.0, 0.0, 0.0, float("nan")) if ok else plan_pair([], []))
        else:
            pairs.append(plan_pair(_path_positions(a), _path_positions(b)))
    return compare_plan_streams(s.topic, pairs, s.count_a, s.count_b, s.tol.path)


def _twist_check(s: _Stream) -> Check:
    rows_a, rows_b = [], []
    for _, a, b, _same in s.pairs():
        if a is not None:
            rows_a.append(twist_row(a))
        if b is not None:
            rows_b.append(twist_row(b))
    check = compare_twists(s.topic, rows_a, rows_b, s.tol.twist)
    if check.verdict is Verdict.EQUAL:  # same values, other bytes
        check = replace(check, verdict=Verdict.WITHIN)
    return check


def _odometry_trajectory(rows: list[tuple[int, tuple[float, ...]]]) -> Trajectory:
    rows = sorted(dict(reversed(rows)).items())  # by stamp; a repeated stamp keeps its first pose
    v = np.array([r for _, r in rows], dtype=np.float64).reshape(-1, 7)
    return Trajectory(np.array([t for t, _ in rows], dtype=np.int64), v[:, :3], v[:, 3:])


def _odometry_check(s: _Stream) -> Check:
    rows_a: list[tuple[int, tuple[float, ...]]] = []
    rows_b: list[tuple[int, tuple[float, ...]]] = []
    for _, a, b, _same in s.pairs():
        for msg, rows in ((a, rows_a), (b, rows_b)):
            if msg is not None:
                p, q = msg.pose.pose.position, msg.pose.pose.orientation
                rows.append((m.to_ns(msg.header.stamp), (p.x, p.y, p.z, q.x, q.y, q.z, q.w)))
    try:
        check = compare_trajectories(
            s.topic, _odometry_trajectory(rows_a), _odometry_trajectory(rows_b), s.tol.trajectory
        )
    except TrajectoryError as exc:
        return Check(
            s.topic, "trajectory", Verdict.CHANGED, {}, as_dict(s.tol.trajectory), f"cannot be compared: {exc}"
        )
    if check.verdict is Verdict.EQUAL:
        check = replace(check, verdict=Verdict.WITHIN)
    return check


def _field_check(s: _Stream) -> Check:
    beyond, max_diff = 0, 0.0
    for _, a, b, same in s.pairs():
        if same or a is None or b is None:
            continue
        diffs = list(field_differences(a, b, s.tol.field, s.ignore))
        beyond += bool(diffs)
        finite = [d.abs_diff for d in diffs if not math.isnan(d.abs_diff)]
        max_diff = max([max_diff, *finite])
    verdict = Verdict.CHANGED if beyond or s.count_a != s.count_b else Verdict.WITHIN
    values = {
        "messages_a": s.count_a,
        "messages_b": s.count_b,
        "messages_differing": s.differing,
        "beyond_tolerance": beyond,
        "max_abs_diff": max_diff,
    }
    detail = f"{s.count_a} -> {s.count_b} messages, {s.differing} differ, {beyond} beyond tolerance"
    return Check(s.topic, "fields", verdict, values, as_dict(s.tol.field), detail)


COMPARATORS = {
    m.OCCUPANCY_GRID: _grid_check,
    m.PATH: _plan_check,
    m.TWIST: _twist_check,
    m.TWIST_STAMPED: _twist_check,
    m.ODOMETRY: _odometry_check,
}


def _ignored_topics(ignore: Sequence[str]) -> tuple[set[str], dict[str, list[str]]]:
    """Whole topics (``/topic``) and field paths per topic (``/topic.field.path``) of an ignore list."""
    topics: set[str] = set()
    fields_by_topic: dict[str, list[str]] = {}
    for item in ignore:
        if not item.startswith("/"):
            continue
        topic, dot, path = item.partition(".")
        if dot:
            fields_by_topic.setdefault(topic, []).append(path)
        else:
            topics.add(topic)
    return topics, fields_by_topic


def compare_logs(
    a: Path | str, b: Path | str, tol: DiffTolerances = DEFAULT_TOLERANCES, ignore: Sequence[str] = ()
) -> tuple[list[Check], Divergence | None, list[str]]:
    """Checks of every topic of two logs (sorted by topic), the first divergence, and the ignored topics."""
    pa, pb = Path(a), Path(b)
    ignored_topics, ignored_fields = _ignored_topics(ignore)
    with _open(pa) as ra, _open(pb) as rb:
        names = sorted((set(ra.topics) | set(rb.topics)) - ignored_topics)
        da, db = topic_digests(ra, names), topic_digests(rb, names)
        checks: list[Check] = []
        divergences: list[Divergence] = []
        for topic in names:
            ta, tb = da.get(topic), db.get(topic)
            if ta is None or tb is None:
                side, t = ("A", ta) if tb is None else ("B", tb)
                assert t is not None
                values: dict[str, Any] = {"messages_a": ta.count if ta else 0, "messages_b": tb.count if tb else 0}
                checks.append(Check(topic, "topic", Verdict.CHANGED, values, {}, f"only in {side} ({t.typename})"))
                t_first = _first_time(ra if side == "A" else rb, topic)
                if t_first is not None:
                    start = ra.start_ns
                    divergences.append(Divergence(topic, 0, t_first, (t_first - start) / 1e9, "(topic)", "", ""))
                continue
            if ta.typename != tb.typename:
                values = {"type_a": ta.typename, "type_b": tb.typename}
                checks.append(
                    Check(topic, "topic", Verdict.CHANGED, values, {}, f"type {ta.typename} -> {tb.typename}")
                )
                continue
            if ta.count == tb.count and ta.sha256 == tb.sha256:
                values = {"messages": ta.count, "sha256": ta.sha256}
                checks.append(Check(topic, "bytes", Verdict.EQUAL, values, {}, f"{ta.count} messages, same bytes"))
                continue
            stream = _Stream(topic, ta.typename, ra, rb, ra.start_ns, tol, ignored_fields.get(topic, []))
            check = COMPARATORS.get(ta.typename, _field_check)(stream)
            if stream.undecodable:
                check = replace(
                    check,
                    values={**check.values, "undecodable": stream.undecodable},
                    detail=check.detail + f"; {stream.undecodable} undecodable messages skipped",
                )
            checks.append(check)
            if stream.divergence is not None:
                divergences.append(stream.divergence)
    first = min(divergences, key=lambda d: (d.time_ns, d.topic)) if divergences else None
    return checks, first, sorted(ignored_topics)


def _first_time(reader: LogReader, topic: str) -> int | None:
    for env in reader.messages([topic], decode=False):
        return int(env.time_ns)
    return None
