"""``check_log``: is a log fit to replay? One streaming pass, then every check on what it gathered."""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import replace
from pathlib import Path

from navlog.analysis.check import checks
from navlog.analysis.check.checks import PERIODIC_TYPES, CheckOptions
from navlog.analysis.check.collect import collect
from navlog.analysis.check.result import Check, LogCheck, Status
from navlog.errors import ConfigError
from navlog.replay.io.reader import LogReader


def parse_frames(items: Iterable[str]) -> list[tuple[str, str]]:
    """``["map:base_link", ...]`` as (target, source) pairs; a malformed item is refused with its text."""
    pairs = []
    for item in items:
        target, sep, source = item.partition(":")
        if not sep or not target.strip() or not source.strip() or ":" in source:
            raise ConfigError(f"frames '{item}': expected TARGET:SOURCE, e.g. map:base_link or odom:base_footprint")
        pairs.append((target.strip(), source.strip()))
    return pairs


def parse_rates(items: Iterable[str]) -> dict[str, float]:
    """``["/scan=10", ...]`` as {topic: Hz}; a malformed item is refused with its text."""
    out = {}
    for item in items:
        topic, sep, value = item.partition("=")
        try:
            hz = float(value)
        except ValueError:
            hz = 0.0
        if not sep or not topic or not hz > 0:
            raise ConfigError(f"rate '{item}': expected TOPIC=HZ with HZ > 0, e.g. /scan=10")
        out[topic] = hz
    return out


def pipeline_inputs(name: str, log_topics: Iterable[str], reader: LogReader | None = None) -> list[str]:
    """The topics pipeline ``name`` (with its shipped parameters, settled on ``reader``'s log as a replay
    settles them: e.g. the odometry topic a recording names) must find in a log with ``log_topics``."""
    from navlog.replay.pipelines import pipeline_spec
    from navlog.replay.session import pipeline_params

    spec, params = pipeline_spec(name), pipeline_params(name)
    if reader is not None:
        params = spec.settle(params, reader, {})
    return list(spec.build(params, set(log_topics)).inputs)


def read_by_pipelines(log_topics: Iterable[str], reader: LogReader | None = None) -> set[str]:
    """The topics of a log with ``log_topics`` that some replay pipeline reads (its inputs and optional
    inputs, with its shipped parameters, settled on ``reader``'s log when given); a pipeline that needs
    more than the log to build (localization: a map) adds the topics its parameters name."""
    from navlog.errors import NavlogError
    from navlog.replay.pipelines import pipeline_names, pipeline_spec
    from navlog.replay.session import pipeline_params

    topics = set(log_topics)
    read: set[str] = set()
    for name in pipeline_names():
        params = pipeline_params(name)
        try:
            if reader is not None:
                params = pipeline_spec(name).settle(params, reader, {})
            built = pipeline_spec(name).build(params, topics)
        except NavlogError:  # it needs more than the log: the topics its parameters name
            read |= {v for v in vars(params).values() if isinstance(v, str) and v.startswith("/")}
            continue
        read |= {*built.inputs, *built.optional_inputs}
    return read


def check_log(
    log: LogReader | str | Path,
    *,
    require: Sequence[str] = (),
    rates: Mapping[str, float] | None = None,
    frames: Sequence[tuple[str, str]] = (),
    pipeline: str | None = None,
    options: CheckOptions | None = None,
) -> LogCheck:
    """Check a log (a path, or a reader from ``open_log``): integrity, types, required topics, rates,
    gaps, stamps, scan values and TF coverage of ``frames`` ((target, source) pairs).

    ``require``: topics that must be present (``pipeline`` adds the inputs of that replay pipeline);
    ``rates``: expected Hz per topic (others are held to their own median rate; a topic with a rate is
    required). When topics are required, a rate, gap, stamp or scan failure on another topic is reported
    as a WARN: the log is judged for what it will be used for; when none are, the same holds for a topic no
    replay pipeline reads (``read_by_pipelines``). A path is opened with ``recover=True``
    so that a truncated file is checked and reported, not refused.
    """
    if not isinstance(log, LogReader):
        from navlog.replay.io.formats import open_log

        with open_log(log, recover=True) as reader:
            return check_log(reader, require=require, rates=rates, frames=frames, pipeline=pipeline, options=options)
    reader = log
    opts = options or CheckOptions()
    rates = dict(rates or {})
    inputs = pipeline_inputs(pipeline, reader.topics, reader) if pipeline else []
    needed = list(dict.fromkeys([*require, *inputs, *rates]))
    got = collect(reader)
    span = (reader.start_ns, reader.end_ns)
    found: list[Check] = [checks.integrity(reader, got), checks.types(reader)]
    found += [checks.required(reader, t) for t in needed]
    series = [got.topics[name] for name in sorted(got.topics)]
    timed = [s for s in series if len(s.log_times) >= 3 and (s.typename in PERIODIC_TYPES or s.topic in needed)]
    timed_names = {s.topic for s in timed}
    per_topic = [checks.rate(s, rates.get(s.topic), opts) for s in series if s.topic in timed_names or s.topic in rates]
    per_topic += [checks.gaps(s, span, opts) for s in timed if len(set(s.log_times)) >= 2]  # (a gap between instants)
    per_topic += [checks.stamps(s, reader.start_ns) for s in series if len(s.log_times) >= 2]
    per_topic += [checks.edge_stamps(e) for _, e in sorted(got.edges.items()) if not e.static and len(e.stamps) >= 2]
    per_topic += [
        checks.scan_values(s) for s in series if s.typename == "sensor_msgs/msg/LaserScan" and len(s.log_times)
    ]
    # with topics named, a failure elsewhere is only a warning (TF counts as named when frames are); with
    # none named, a failure on a topic no pipeline reads
    if needed:
        relevant, why = set(needed) | ({"/tf", "/tf_static"} if frames else set()), "not a required topic"
    elif any(c.status is Status.FAIL for c in per_topic):  # (building the pipelines costs ~0.5 s: only then)
        relevant, why = read_by_pipelines(reader.topics, reader), "no replay pipeline reads this topic"
    else:
        relevant, why = {c.subject.split(" ")[0] for c in per_topic}, ""
    found += [c if c.subject.split(" ")[0] in relevant else _as_warning(c, why) for c in per_topic]
    if frames:
        tf_span = checks.stamp_span(got, span)
        found += [checks.tf(got, target, source, tf_span, opts) for target, source in frames]
    return LogCheck(
        str(reader.path),
        reader.format,
        reader.start_ns,
        reader.end_ns,
        got.read,
        got.order,
        [checks.figures(s) for s in series],
        found,
    )


def _as_warning(check: Check, why: str) -> Check:
    """A failure on a topic the log is not judged for: reported, but it does not fail the log."""
    if check.status is not Status.FAIL:
        return check
    return replace(check, status=Status.WARN, message=f"{check.message} ({why}: a warning)")
