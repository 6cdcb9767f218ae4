"""The checks, one function per kind, from what ``collect`` gathered to ``Check`` results.

Times in messages are seconds after the log's first message (``t=``) for log times, and seconds as
stamped for header stamps. Indices are 0-based positions of a message within its topic.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from navlog.analysis.check.collect import Collected, EdgeSeries, TopicSeries
from navlog.analysis.check.result import Check, Status, TopicFigures
from navlog.analysis.check.tf_coverage import chain_coverage, tf_tree
from navlog.replay.config import suggest
from navlog.replay.io.reader import LogReader

# types published at a steady rate: their rates and gaps are checked even when not required
PERIODIC_TYPES = frozenset(
    {
        "sensor_msgs/msg/LaserScan",
        "sensor_msgs/msg/PointCloud2",
        "sensor_msgs/msg/Imu",
        "sensor_msgs/msg/JointState",
        "sensor_msgs/msg/Image",
        "sensor_msgs/msg/CompressedImage",
        "sensor_msgs/msg/NavSatFix",
        "nav_msgs/msg/Odometry",
        "rosgraph_msgs/msg/Clock",
    }
)


@dataclass(frozen=True)
class CheckOptions:
    """Tolerances of the checks (rates relative, times in seconds, coverage as a share of the span)."""

    rate_tolerance: float = 0.10  # |rate - expected| / expected (or against the median rate)
    gap_factor: float = 5.0  # a gap is a period longer than this many median periods ...
    max_gap_s: float = 1.0  # ... and a gap this long or longer fails the check
    tf_max_gap_s: float = 1.0  # a TF edge is not available across a longer stretch without a sample
    tf_min_coverage: float = 0.99  # below: WARN
    tf_fail_coverage: float = 0.90  # below: FAIL


def _s(ns: int | float) -> str:
    return f"{ns / 1e9:.3f} s"


def _ns_s(ns: int | float) -> float:
    return round(ns / 1e9, 9)


def integrity(reader: LogReader, got: Collected) -> Check:
    """Read to the end, or truncated / corrupt (with the readable span); summary counts match what was read."""
    path = str(reader.path)
    read_counts = {name: len(s.log_times) for name, s in got.topics.items()}
    times = [s.log_times for s in got.topics.values() if len(s.log_times)]
    first = min((min(t) for t in times), default=None)
    last = max((max(t) for t in times), default=None)
    numbers: dict[str, int | float | str | None] = {
        "size_bytes": reader.size_bytes,
        "messages_read": got.read,
        "truncated": int(reader.report.truncated),
        "readable_start_ns": first,
        "readable_end_ns": last,
        "readable_s": None if first is None or last is None else _ns_s(last - first),
        "undecodable": sum(s.undecodable for s in got.topics.values()),
    }
    span = (
        "nothing"
        if first is None or last is None
        else f"{_s(last - first)} ({got.read} messages, log times {_s(first)} to {_s(last)})"
    )
    if reader.report.truncated:
        return Check(
            "integrity",
            path,
            Status.FAIL,
            f"{path}: truncated (the writer stopped before the end); its readable part spans {span}; "
            f"salvage it with `navlog recover {path} -o FIXED.mcap`, or re-record",
            numbers,
        )
    if got.error:
        return Check(
            "integrity",
            path,
            Status.FAIL,
            f"{path}: corrupt data after {got.read} messages ({got.error}); readable part spans {span}; "
            "try `navlog recover` or re-record",
            numbers,
        )
    chunks = {r: n for r, n in reader.report.skipped.items() if r.startswith("chunks skipped")}
    if chunks:
        lost = sum(n for r, n in reader.report.skipped.items() if r.startswith("messages in skipped chunks"))
        numbers["chunks_skipped"], numbers["messages_in_skipped_chunks"] = sum(chunks.values()), lost
        why = "; ".join(f"{n} {r}" for r, n in sorted(chunks.items()))
        return Check(
            "integrity",
            path,
            Status.FAIL,
            f"{path}: damaged: {why}, {lost} message(s) of the checked topics in them; the rest spans {span}; "
            "every command skips them and counts them; re-record or re-export the log",
            numbers,
        )
    short = [(n, reader.topics[n].count, c) for n, c in sorted(read_counts.items()) if c != reader.topics[n].count]
    if short:
        n, want, have = short[0]
        return Check(
            "integrity",
            path,
            Status.FAIL,
            f"{n}: the log's summary lists {want} messages but {have} were read "
            f"({len(short)} topic(s) differ); the file is damaged: re-record or re-export it",
            numbers,
        )
    if got.read == 0:
        return Check("integrity", path, Status.FAIL, f"{path}: the log holds no messages; record it again", numbers)
    if numbers["undecodable"]:
        return Check(
            "integrity",
            path,
            Status.WARN,
            f"{path}: {numbers['undecodable']} scan/TF message(s) could not be decoded and are skipped; "
            "check the recorder's message definitions",
            numbers,
        )
    return Check("integrity", path, Status.PASS, f"{path}: read to the end, {span}", numbers)


def types(reader: LogReader) -> Check:
    unknown = reader.unknown_types
    numbers: dict[str, int | float | str | None] = {"unknown": len(unknown)}
    if not unknown:
        return Check("types", str(reader.path), Status.PASS, "every topic's message type is known", numbers)
    listed = ", ".join(f"{t} ({ty})" for t, ty in sorted(unknown.items()))
    return Check(
        "types",
        str(reader.path),
        Status.WARN,
        f"{len(unknown)} topic(s) of unknown type are skipped by every command: {listed}; "
        "record with the message definitions in the log to use them",
        numbers,
    )


def required(reader: LogReader, topic: str) -> Check:
    info = reader.topics.get(topic)
    if info is None:
        hint = suggest(topic, reader.topics) or f" (the log has {', '.join(sorted(reader.topics)) or 'no topics'})"
        return Check(
            "required",
            topic,
            Status.FAIL,
            f"{topic}: required but not in the log{hint}; record it, or remap the topic the log has",
            {"count": 0},
        )
    if not info.known:
        return Check(
            "required",
            topic,
            Status.FAIL,
            f"{topic}: required but its type {info.typename} is unknown, so it cannot be read; "
            "record with the message definitions in the log",
            {"count": info.count},
        )
    if info.count == 0:
        return Check(
            "required",
            topic,
            Status.FAIL,
            f"{topic}: required but holds no messages; check its publisher",
            {"count": 0},
        )
    return Check("required", topic, Status.PASS, f"{topic}: present, {info.count} messages", {"count": info.count})


def _instants(series: TopicSeries) -> np.ndarray:
    """The topic's distinct log times, sorted: messages logged at one instant (several publishers of one topic,
    as /tf's odometry, localisation and joint transforms of one step) arrive together, once."""
    return np.unique(np.asarray(series.log_times, dtype=np.int64))


def _periods(series: TopicSeries) -> np.ndarray:
    return np.diff(_instants(series))


def _backward(values: Sequence[int]) -> tuple[int, int | None]:
    """How many steps back a sequence takes, and the index of the first message that steps back."""
    d = np.diff(np.asarray(values, dtype=np.int64))
    back = np.flatnonzero(d < 0)
    return int(back.size), (int(back[0]) + 1 if back.size else None)


def figures(series: TopicSeries) -> TopicFigures:
    n = len(series.log_times)
    periods = _periods(series)
    span = int(periods.sum()) if periods.size else 0
    median = float(np.median(periods)) if periods.size else 0.0
    return TopicFigures(
        series.topic,
        series.typename,
        n,
        round(periods.size / (span / 1e9), 6) if span > 0 else None,
        round(1e9 / median, 6) if median > 0 else None,
        _ns_s(int(periods.max())) if periods.size else None,
        _backward(series.log_times)[0],
        _backward(series.stamps)[0] if series.stamped else None,
    )


def rate(series: TopicSeries, expected: float | None, opts: CheckOptions) -> Check:
    fig = figures(series)
    topic, tol = series.topic, opts.rate_tolerance
    numbers: dict[str, int | float | str | None] = {
        "count": fig.count,
        "rate_hz": fig.rate_hz,
        "median_rate_hz": fig.median_rate_hz,
        "expected_hz": expected,
        "tolerance": tol,
    }
    if fig.rate_hz is None or fig.median_rate_hz is None:
        return Check(
            "rate",
            topic,
            Status.WARN if expected is None else Status.FAIL,
            f"{topic}: {fig.count} message(s) whose log times do not advance: no rate can be measured; "
            "check the recorder's clock",
            numbers,
        )
    # one instant's messages of several publishers differ in stamp or frame; a copy does not (a message whose stamp
    # could not be read has none: then the copies are not looked for)
    if series.stamped and len(series.stamps) == len(series.log_times):
        pairs = np.stack([np.asarray(series.log_times, dtype=np.int64), np.asarray(series.stamps, dtype=np.int64)])
        repeated = fig.count - np.unique(pairs, axis=1).shape[1]
        if repeated:
            numbers["repeated"] = repeated
            return Check(
                "rate",
                topic,
                Status.WARN if expected is None else Status.FAIL,
                f"{topic}: {repeated} message(s) repeat another's log time and header stamp: written twice by "
                "the recorder? Its rate is measured over its distinct log times",
                numbers,
            )
    ref, against = (expected, "expected") if expected else (fig.median_rate_hz, "its median rate")
    off = (fig.rate_hz - ref) / ref
    numbers["deviation"] = round(off, 6)
    if abs(off) <= tol:
        return Check(
            "rate",
            topic,
            Status.PASS,
            f"{topic}: {fig.rate_hz:.2f} Hz, within {tol:.0%} of {against} {ref:.2f} Hz",
            numbers,
        )
    fix = (
        "check the publisher's rate, or state the rate the log was recorded at"
        if expected
        else "messages are missing or bunched: see the gaps check"
    )
    return Check(
        "rate",
        topic,
        Status.FAIL if expected else Status.WARN,
        f"{topic}: {fig.rate_hz:.2f} Hz is {abs(off):.0%} {'above' if off > 0 else 'below'} {against} "
        f"{ref:.2f} Hz (tolerance {tol:.0%}); {fix}",
        numbers,
    )


def gaps(series: TopicSeries, log_span: tuple[int, int], opts: CheckOptions) -> Check:
    topic = series.topic
    t = _instants(series)
    d = np.diff(t)
    median = float(np.median(d))
    limit = max(opts.gap_factor * median, 1.0)
    k = int(np.argmax(d))  # the instant before the largest gap, and its last message (log times sorted)
    largest = int(d[k])
    i = int(np.searchsorted(np.sort(np.asarray(series.log_times, dtype=np.int64)), t[k], side="right")) - 1
    over = int((d > limit).sum())
    lead, tail = int(t[0]) - int(log_span[0]), int(log_span[1]) - int(t[-1])  # Python ints: no int64 overflow
    edge_limit = max(limit, opts.max_gap_s * 1e9)
    numbers: dict[str, int | float | str | None] = {
        "max_gap_s": _ns_s(largest),
        "max_gap_after_index": i,
        "max_gap_start_s": _ns_s(t[k] - log_span[0]),
        "median_period_s": _ns_s(median),
        "gap_factor": opts.gap_factor,
        "gaps_over_factor": over,
        "lead_s": _ns_s(lead),
        "tail_s": _ns_s(tail),
    }
    where = (
        f"largest gap {_s(largest)} after message {i} (t={_s(t[k] - log_span[0])} to {_s(t[k + 1] - log_span[0])}), "
        f"{largest / median:.0f}x the median period {_s(median)}"
        if median > 0
        else f"largest gap {_s(largest)} after message {i}"
    )
    if over and largest >= opts.max_gap_s * 1e9:
        return Check(
            "gaps",
            topic,
            Status.FAIL,
            f"{topic}: {where}; {over} gap(s) over {opts.gap_factor:g}x; the publisher stalled or messages were "
            "dropped: re-record, or replay only the part without the gap",
            numbers,
        )
    if over:
        return Check(
            "gaps",
            topic,
            Status.WARN,
            f"{topic}: {over} gap(s) over {opts.gap_factor:g}x the median period; {where}; check for dropped messages",
            numbers,
        )
    if lead > edge_limit or tail > edge_limit:
        late = f"starts {_s(lead)} after the log" if lead > edge_limit else f"stops {_s(tail)} before its end"
        return Check(
            "gaps",
            topic,
            Status.WARN,
            f"{topic}: {late}; replay only the part the topic covers, or check its publisher",
            numbers,
        )
    return Check(
        "gaps", topic, Status.PASS, f"{topic}: no gap over {opts.gap_factor:g}x the median period; {where}", numbers
    )


def stamps(series: TopicSeries, start_ns: int) -> Check:
    """Log times (in the order read) and header stamps only go forward."""
    topic = series.topic
    log_back, log_first = _backward(series.log_times)
    numbers: dict[str, int | float | str | None] = {"log_time_backward": log_back, "log_time_first_index": log_first}
    found = []
    if log_first is not None:
        lt = series.log_times
        found.append(
            f"log times step back {log_back} time(s), first at message {log_first} "
            f"(t={_s(lt[log_first] - start_ns)} after t={_s(lt[log_first - 1] - start_ns)})"
        )
    if series.stamped:
        st = series.stamps
        stamp_back, stamp_first = _backward(st)
        numbers.update({"stamp_backward": stamp_back, "stamp_first_index": stamp_first})
        if stamp_first is not None:
            numbers.update({"stamp_before_ns": st[stamp_first - 1], "stamp_after_ns": st[stamp_first]})
            found.append(
                f"header stamps step back {stamp_back} time(s), first at message {stamp_first} "
                f"(stamp {_s(st[stamp_first])} after {_s(st[stamp_first - 1])})"
            )
    if found:
        return Check(
            "stamps",
            topic,
            Status.FAIL,
            f"{topic}: {'; '.join(found)}; fix the publisher's clock or re-stamp the messages in order",
            numbers,
        )
    what = "log times and header stamps" if series.stamped else "log times"
    return Check("stamps", topic, Status.PASS, f"{topic}: {what} only go forward", numbers)


def edge_stamps(edge: EdgeSeries) -> Check:
    """A dynamic TF edge's stamps only go forward."""
    subject = f"/tf {edge.parent}->{edge.child}"
    back, first = _backward(edge.stamps)
    numbers: dict[str, int | float | str | None] = {"stamp_backward": back, "stamp_first_index": first}
    if first is None:
        return Check("stamps", subject, Status.PASS, f"{subject}: stamps only go forward", numbers)
    st = edge.stamps
    numbers.update({"stamp_before_ns": st[first - 1], "stamp_after_ns": st[first]})
    return Check(
        "stamps",
        subject,
        Status.FAIL,
        f"{subject}: stamps step back {back} time(s), first at transform {first} "
        f"(stamp {_s(st[first])} after {_s(st[first - 1])}); two publishers of one transform, or a clock reset",
        numbers,
    )


def scan_values(series: TopicSeries) -> Check:
    topic, sv = series.topic, series.scan
    if sv is None:
        return Check("scan_values", topic, Status.WARN, f"{topic}: no scan could be decoded", {"scans": 0})
    numbers: dict[str, int | float | str | None] = {
        "scans": sv.scans,
        "ranges": sv.beams,
        "nan": sv.nan,
        "pos_inf": sv.pos_inf,
        "neg_inf": sv.neg_inf,
        "scans_without_finite_range": sv.no_finite,
    }
    counts = f"{sv.nan} NaN, {sv.pos_inf} +inf (no return), {sv.neg_inf} -inf (too close) of {sv.beams} ranges"
    if sv.bad_geometry:  # (the key only then: the reports of valid logs keep their bytes)
        numbers["scans_with_bad_geometry"] = sv.bad_geometry
        return Check(
            "scan_values",
            topic,
            Status.FAIL,
            f"{topic}: {sv.bad_geometry} of {sv.scans} scan(s) unusable, first: {sv.first_fault}; replay skips "
            "them: check the laser driver's angle_min, angle_max, angle_increment and beam count",
            numbers,
        )
    if sv.scans and sv.no_finite == sv.scans:
        return Check(
            "scan_values",
            topic,
            Status.FAIL,
            f"{topic}: no scan has a finite range ({counts}); check the laser driver and its range limits",
            numbers,
        )
    if sv.nan or sv.no_finite:
        return Check(
            "scan_values",
            topic,
            Status.WARN,
            f"{topic}: {counts}; {sv.no_finite} scan(s) without a finite range; NaN ranges are skipped as invalid: "
            "check the laser driver",
            numbers,
        )
    return Check("scan_values", topic, Status.PASS, f"{topic}: {counts}", numbers)


def resolve_frame(frame: str, frames: set[str]) -> str | None:
    """A frame as the log names it: exact, or the one known frame that ends in ``/frame`` (a prefixed tree)."""
    frame = frame.lstrip("/")
    if frame in frames:
        return frame
    prefixed = [f for f in frames if f.endswith("/" + frame)]
    return prefixed[0] if len(prefixed) == 1 else None


def stamp_span(got: Collected, log_span: tuple[int, int]) -> tuple[int, int]:
    """The span of the sensor data's header stamps (zero stamps ignored), else the log's span.

    TF is looked up at header stamps, which may run on another clock than the log times (a bag of a
    simulation recorded with wall-clock log times), so TF coverage is measured over the stamps of the
    sensor topics (``PERIODIC_TYPES``; a log's /rosout may be stamped by the wall clock).
    """
    lo = hi = None
    for s in got.topics.values():
        if s.stamped and s.typename in PERIODIC_TYPES and len(s.stamps):
            arr = np.asarray(s.stamps, dtype=np.int64)
            arr = arr[arr > 0]
            if arr.size:
                lo = int(arr.min()) if lo is None else min(lo, int(arr.min()))
                hi = int(arr.max()) if hi is None else max(hi, int(arr.max()))
    return (lo, hi) if lo is not None and hi is not None else log_span


def tf(got: Collected, target: str, source: str, span: tuple[int, int], opts: CheckOptions) -> Check:
    subject = f"{target}->{source}"
    frames = {f for key in got.edges for f in key}
    numbers: dict[str, int | float | str | None] = {"span_start_ns": span[0], "span_end_ns": span[1], "coverage": 0.0}
    if not got.edges:
        return Check(
            "tf",
            subject,
            Status.FAIL,
            f"{subject}: the log has no /tf or /tf_static transforms; record TF (and /tf_static) with the data",
            numbers,
        )
    names = []
    for frame in (target, source):
        name = resolve_frame(frame, frames)
        if name is None:
            return Check(
                "tf",
                subject,
                Status.FAIL,
                f"{subject}: frame '{frame}' is in neither /tf nor /tf_static{suggest(frame, frames)}; "
                f"the log's frames: {', '.join(sorted(frames))}; record the transform that publishes it",
                numbers,
            )
        names.append(name)
    edges = {key: (e.static, e.stamps) for key, e in got.edges.items()}
    cov = chain_coverage(edges, names[0], names[1], span, int(opts.tf_max_gap_s * 1e9))
    chain = " ".join(cov.chain) or "none"
    numbers.update({"coverage": round(cov.coverage, 6), "covered_s": _ns_s(cov.covered_ns), "chain": chain})
    if cov.largest_hole is not None:
        numbers.update({"largest_hole_start_ns": cov.largest_hole[0], "largest_hole_end_ns": cov.largest_hole[1]})
    if not cov.chain and names[0] != names[1]:
        tree = tf_tree((p, c, len(e.stamps)) for (p, c), e in got.edges.items())
        roots = sorted({f for f in frames if f not in tree})
        return Check(
            "tf",
            subject,
            Status.FAIL,
            f"{subject}: {names[0]} and {names[1]} are not connected in the TF tree (its roots: {', '.join(roots)}); "
            "record the missing transform (a static one in /tf_static?)",
            numbers,
        )
    share = f"{cov.coverage:.1%} of the {_s(span[1] - span[0])} stamped span via {chain}"
    hole = (
        f"; longest stretch without it {_s(cov.largest_hole[1] - cov.largest_hole[0])} from stamp {_s(cov.largest_hole[0])}"
        if cov.largest_hole is not None
        else ""
    )
    if cov.coverage >= opts.tf_min_coverage:
        return Check("tf", subject, Status.PASS, f"{subject}: available over {share}", numbers)
    status = Status.WARN if cov.coverage >= opts.tf_fail_coverage else Status.FAIL
    return Check(
        "tf",
        subject,
        status,
        f"{subject}: available over only {share}{hole}; check the TF publishers' rates "
        f"(an edge is lost after {opts.tf_max_gap_s:g} s without a sample)",
        numbers,
    )
